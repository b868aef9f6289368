# SPDX-License-Identifier: Apache-2.0
"""Builds the Python module `immtrain` with the project's CMake for pip (pyproject.toml).

The extension is the CMake target `immtrain_python` (bindings/python), built in build/python-wheel
(or, with IMMTRAIN_CMAKE_BUILD_DIR, in an existing configured build, which is only brought up to
date); the wheel holds the module, the trainer's side `immtrain_lab` beside it (where the build has
the trainer) and the runtime library both link, libimmruntime, in immtrain.libs/ (the modules'
RPATH looks there). The version is the CMake project's.
"""
import os
import pathlib
import re
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(immtrain VERSION ([0-9.]+)", text)
    if not match:
        raise RuntimeError("CMakeLists.txt: no project(immtrain VERSION …)")
    return match.group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = os.environ.get("IMMTRAIN_CMAKE_BUILD_DIR")
        if build:
            build = pathlib.Path(build).resolve()
        else:
            build = ROOT / "build" / "python-wheel"
            # The runtime, the trainer and the two modules: no tests or benchmarks.
            subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build),
                            "-DCMAKE_BUILD_TYPE=Release",
                            "-DIMM_BUILD_TESTS=OFF", "-DIMM_BUILD_BENCHMARKS=OFF",
                            "-DIMM_BUILD_PYTHON=ON",
                            f"-DPython3_EXECUTABLE={sys.executable}"], check=True)
        jobs = str(os.cpu_count() or 1)
        subprocess.run(["cmake", "--build", str(build), "--target", "immtrain_python", "-j", jobs],
                       check=True)
        modules = sorted((build / "python").glob("immtrain.*.so"))
        if not modules:
            raise RuntimeError(f"{build}/python: the build wrote no immtrain module")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(modules[0], target)
        # The trainer's side, immtrain_lab, beside it (absent from a build without the trainer:
        # immtrain then says so when one of its names is used).
        for lab in sorted((build / "python").glob("immtrain_lab.*.so")):
            shutil.copyfile(lab, target.parent / lab.name)
        shutil.copyfile(ROOT / "bindings" / "python" / "immtrain.pyi",
                        target.parent / "immtrain.pyi")
        libs = target.parent / "immtrain.libs"
        libs.mkdir(exist_ok=True)
        # The runtime under the name the module asks for (its soname, from readelf).
        dynamic = subprocess.run(["readelf", "-d", str(modules[0])], check=True,
                                 capture_output=True, text=True).stdout
        needed = re.findall(r"\[(libimmruntime[^\]]*)\]", dynamic)
        if not needed:
            raise RuntimeError(f"{modules[0]}: links no libimmruntime")
        shutil.copyfile((build / "runtime" / needed[0]).resolve(), libs / needed[0])


setup(
    version=project_version(),
    packages=[],
    py_modules=[],
    ext_modules=[Extension("immtrain", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    # setuptools' own scratch (and the egg-info) under build/, not beside the sources.
    options={"build": {"build_base": "build/setuptools"},
             "egg_info": {"egg_base": "build/setuptools"}},
    zip_safe=False,
)
