#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The whole product from Python, in one script: write a regime, train two kinds of filter for it,
evaluate the learned one against the tuned classical IMM, choose the regime's tracker, and track a
test track with it.

    PYTHONPATH=build/python python3 docs/examples/tutorial.py [--out tutorial.png] [--work DIR]
        [--size small|full]

Every step is a call into the C++ libraries through the module immtrain (no command-line tool is
run). --size small (the default) keeps it under a minute — a few generations of a small GA —
which is enough to show the steps, not to learn a good table; --size full trains with the
config's own population and generations. The figure: the filters' normalized errors with their
95 % intervals against the learned model (left), and the chosen tracker on a test track (right).
"""

import argparse
import os
import tempfile

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import immtrain  # noqa: E402

# 1. A regime: targets at 150–250 m/s that fly straight or turn at 3–8 °/s, seen every second by
# a sensor with 25 m plots. A dict shaped like a regime file (docs/regimes.md).
REGIME = {
    "name": "tutorial_turns",
    "units": "m",
    "sample_period": 1.0,
    "scans": 60,
    "process_noise_sigma": 0.5,
    "sensor": {"kind": "cartesian", "sigma": [25.0, 25.0]},
    "start": {"range": [10000.0, 30000.0], "bearing_deg": [0.0, 360.0], "heading": "inbound",
              "heading_offset_deg": [-60.0, 60.0], "speed": [150.0, 250.0]},
    "maneuvers": [{"kind": "cv", "probability": 0.5, "duration": [8.0, 20.0]},
                  {"kind": "turn", "probability": 0.5, "duration": [6.0, 15.0],
                   "rate_deg": [3.0, 8.0]}],
    "splits": {"training": 24, "validation": 8, "test": 30, "seed": 1},
}


def config_for(path, regime_file, work, small):
    """A training config of the repository with our regime (and, small, a small GA)."""
    text = open(path).read()
    lines = [line for line in text.splitlines() if not line.startswith("regime = ")]
    text = f'regime = "{regime_file}"\n' + "\n".join(lines) + "\n"
    if small:
        text = text.replace("population = 500", "population = 24").replace(
            "generations = 100", "generations = 4")
    out = os.path.join(work, os.path.basename(path))
    with open(out, "w") as f:
        f.write(text)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="tutorial.png")
    parser.add_argument("--work", help="folder for the regime, models and reports (default: a "
                                       "temporary one)")
    parser.add_argument("--size", choices=["small", "full"], default="small")
    parser.add_argument("--check", action="store_true",
                        help="fail unless the steps gave what they should (the test suite's run)")
    args = parser.parse_args()
    work = args.work or tempfile.mkdtemp(prefix="immtrain-tutorial-")
    os.makedirs(work, exist_ok=True)
    small = args.size == "small"

    regime = immtrain.regime_from_dict(REGIME)  # validated as a file: ValueError naming the key
    regime_file = os.path.join(work, "tutorial_turns.toml")
    with open(regime_file, "w") as f:
        f.write(regime.toml)
    print(f"regime {regime.name}: T {regime.sample_period} s, {regime.scans} scans, "
          f"splits {regime.splits}")

    # 2. Two kinds: the classical CV/CA/CT IMM tuned on the training split (the bar a tracking
    # engineer would set), and a GA-fuzzy IMM learned on top of the tuned constant-q IMM.
    models = os.path.join(work, "models")
    log = []
    classical = immtrain.train("baseline", config="configs/classical_imm.toml",
                               regime=regime_file, out=os.path.join(models, "classical.h5"))
    learned = immtrain.train("ga", config=config_for("configs/ga_fuzzy_imm_tuned.toml",
                                                     regime_file, work, small),
                             seed=1, out=os.path.join(models, "ga.h5"),
                             progress=lambda level, message: log.append(message))
    print(f"trained {classical['model']} and {learned['model']} ({len(log)} log lines)")

    # 3. The GA-fuzzy IMM's own experiment on the test split: every filter on the same tracks.
    result = immtrain.evaluate("ga-imm", model=learned["model"], classical=classical["model"],
                               out=os.path.join(work, "reports", "ga-imm"))
    ours = result["filters"]["GA-IMM"]
    print(f"ga-imm on {result['runs']} test tracks: GA-IMM zeta_p {ours['zeta_p']:.4f}, "
          f"exit {result['exit_code']}; findings: {result['findings'] or 'none'}")

    # 4. The regime's tracker: the best classical filter unless a learned model beats it.
    choice = immtrain.rank([classical["model"]], [learned["model"]],
                           evaluations=[os.path.join(work, "reports", "ga-imm")],
                           out=os.path.join(work, "reports", "rank"))
    print(f"tracker: {choice['tracker']} — {choice['reason']}")

    # 5. Track one test track with it.
    tracks = regime.draw("test", seed=1, runs=1)
    tracker = immtrain.load_tracker(choice["tracker_file"])
    plots = np.column_stack([np.arange(regime.scans, dtype=float), tracks["plots"][0]])
    run = tracker.run(plots)
    names = tracker.state_names
    x, y = run["mean"][:, names.index("x")], run["mean"][:, names.index("y")]
    truth = tracks["truth"][0]
    started = ~np.isnan(x)
    error = np.hypot(x - truth[:, 0], y - truth[:, 3])[started]
    plot_error = np.hypot(*(tracks["plots"][0] - truth[:, [0, 3]]).T)[started]
    print(f"test track 0: position RMSE {np.sqrt(np.mean(error ** 2)):.1f} m against the plots' "
          f"{np.sqrt(np.mean(plot_error ** 2)):.1f} m")

    figure, (left, right) = plt.subplots(1, 2, figsize=(13, 5.5))
    names = [n for n in result["filters"] if n != "GA-IMM"]
    differences = [result["ga_imm_minus"][n]["zeta_p"] for n in names]
    centre = np.array([d[0] for d in differences])
    spread = np.array([[d[0] - d[1] for d in differences], [d[2] - d[0] for d in differences]])
    left.errorbar(centre, np.arange(len(names)), xerr=spread, fmt="o", capsize=4)
    left.axvline(0.0, color="grey", linewidth=1)
    left.set_yticks(np.arange(len(names)), names)
    left.set_xlabel("GA-IMM − filter, ζ_p [95 % interval] (below 0: GA-IMM better)")
    left.set_title(f"{regime.name}: the learned model against each filter")
    right.plot(truth[:, 0] / 1e3, truth[:, 3] / 1e3, "k-", label="truth")
    right.plot(tracks["plots"][0][:, 0] / 1e3, tracks["plots"][0][:, 1] / 1e3, ".", color="0.6",
               markersize=3, label="plots")
    right.plot(x / 1e3, y / 1e3, "-", color="tab:blue", label=f"tracker ({choice['tracker']})")
    right.set_xlabel("x (km)")
    right.set_ylabel("y (km)")
    right.set_aspect("equal", adjustable="datalim")
    right.legend()
    right.set_title("a test track")
    figure.tight_layout()
    figure.savefig(args.out, dpi=110)
    print(f"wrote {args.out} (work folder {work})")

    if args.check:
        assert classical["exit_code"] == 0 and learned["exit_code"] in (0, 4), learned
        assert {"AIMM3", "IMM-tuned", "CT-IMM-tuned", "GA-IMM"} <= set(result["filters"])
        assert result["exit_code"] in (0, 5, 7)
        assert choice["tracker"] in ("classical", "ga")
        assert np.sqrt(np.mean(error ** 2)) < np.sqrt(np.mean(plot_error ** 2)), \
            "the tracker should beat its raw plots"


if __name__ == "__main__":
    main()
