#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the Debian packages immtrain builds with, only those that are missing.
# Idempotent: when everything is present it prints one line and touches nothing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libeigen3-dev libhdf5-dev
  libceres-dev libnlopt-cxx-dev libspdlog-dev
  libtomlplusplus-dev libcli11-dev nlohmann-json3-dev
  libssl-dev              # libcrypto's SHA-256 (datasets/src/sha256.cpp)
  libgtest-dev libgmock-dev libbenchmark-dev
  gnuplot-nox
  doxygen python3-h5py    # the API documentation test; the h5py reading test
  libopenmpi-dev openmpi-bin  # mpirun: GA fitness, sweeps and evaluations over MPI ranks
  clang libclang-rt-dev   # make test-sanitize / make fuzz: ASan, UBSan, libFuzzer
  ccache                  # repeated builds (cmake/ImmBuildSpeed.cmake)
  chromium                # the morning report rendered headless (tests/tools/nightly_test.cpp)
  strace                  # the registry's durable writes, observed (tests/tools/nightly_test.cpp)
  pybind11-dev python3-dev python3-numpy  # the Python module (bindings/python)
  python3-pytest python3-matplotlib       # its tests and its example (tests/python, docs/examples)
  python3-scipy                           # the multi-target example's assignment (docs/examples)
  python3-venv python3-pip python3-setuptools python3-wheel  # pip install . (pyproject.toml)
  python3-pandas python3-tqdm             # evaluate()'s DataFrame, train()'s progress bar
)

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  if [[ "$status" != "install ok installed" ]]; then
    missing+=("$package")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
