#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Tracks one test track of a shipped model's own regime through the Python module immtrain and
plots truth, plots and estimates (and the mode probabilities) with matplotlib.

    PYTHONPATH=build/python python3 docs/examples/track_a_regime.py \
        [--model models/agile_air/tracker.h5] [--bin build/bin] [--out track.png]

The regime comes from the model file itself (immtrain.inspect), its test track from imm-data (the
same seeded draw the evaluations use), its truth from the data-set file (h5py)."""

import argparse
import os
import subprocess
import tempfile

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import immtrain  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="models/agile_air/tracker.h5")
    parser.add_argument("--bin", default="build/bin", help="folder of imm-data")
    parser.add_argument("--track", type=int, default=0, help="which test track")
    parser.add_argument("--out", default="track.png")
    args = parser.parse_args()

    info = immtrain.inspect(args.model)
    regime = info["provenance"]["regime_toml"]
    if not regime:
        raise SystemExit(f"{args.model}: records no regime to draw a test track from")
    tracker = immtrain.load_tracker(args.model)
    with tempfile.TemporaryDirectory() as folder:
        toml = os.path.join(folder, "regime.toml")
        with open(toml, "w") as f:
            f.write(regime)
        data = os.path.join(folder, "tracks.h5")
        # (imm-data without a sanitizer runtime preloaded into this interpreter, if any)
        env = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}
        subprocess.run([os.path.join(args.bin, "imm-data"), "tracks", "--regime", toml, "--out",
                        data, "--count", str(args.track + 1)], check=True, capture_output=True,
                       env=env)
        with h5py.File(data, "r") as f:
            z = f["plots"][args.track]
            truth = f["truth"][args.track]
            columns = f["truth"].attrs["columns"].split(",")
            sensor = f["parameters"].attrs["sensor"]
    if sensor != "cartesian" or tracker.measurement_kind != "cartesian":
        raise SystemExit(f"{args.model}: this example draws Cartesian plots ({sensor})")
    plots = np.column_stack([np.arange(len(z), dtype=float), z])
    out = tracker.run(plots)  # one call: no Python loop per plot
    names = tracker.state_names
    x, y = out["mean"][:, names.index("x")], out["mean"][:, names.index("y")]
    tx, ty = truth[:, columns.index("x")], truth[:, columns.index("y")]
    error = np.hypot(x - tx, y - ty)
    unit = info["provenance"]["length_unit"]

    fig, (track, probabilities) = plt.subplots(1, 2, figsize=(13, 5.5))
    track.plot(z[:, 0], z[:, 1], ".", color="0.6", markersize=3, label="plots")
    track.plot(tx, ty, "-", color="black", linewidth=1.5, label="truth")
    track.plot(x, y, "-", color="tab:red", linewidth=1.0, label="estimate")
    track.set_xlabel(f"x ({unit})")
    track.set_ylabel(f"y ({unit})")
    track.set_aspect("equal", adjustable="datalim")
    track.legend()
    track.set_title(f"{os.path.basename(args.model)} ({info['kind']}) on {info['regime']}, "
                    f"test track {args.track}\nposition RMSE "
                    f"{np.sqrt(np.nanmean(error[2:] ** 2)):.1f} {unit} over scans 2 on")
    for j, name in enumerate(tracker.mode_names):
        probabilities.plot(out["k"], out["mode_probabilities"][:, j], label=name)
    flagged = out["k"][out["outside_envelope"]]
    if len(flagged):
        probabilities.plot(flagged, np.full(len(flagged), 1.02), "|", color="tab:red",
                           label="outside its envelope")
    probabilities.set_xlabel("scan k")
    probabilities.set_ylabel("mode probability")
    probabilities.set_ylim(-0.02, 1.06)
    probabilities.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}: {len(z)} plots, position RMSE "
          f"{np.sqrt(np.nanmean(error[2:] ** 2)):.2f} {unit}")


if __name__ == "__main__":
    main()
