#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Learning curves of the learned kinds: how a learned part's gain over the baseline it is built
on grows with the number of training tracks.

For each (kind, regime) and each training size n, the regime is written with `splits.training = n`
and a fixed validation split (so every point is judged on the same tracks), the kind is trained by
`imm-train` with a fixed seed, and the model's own metrics give its validation objective against
its base's:
  ga    configs/ga_fuzzy_imm_tuned.toml: validation ζ_p + ζ_v of the learned tables against the
        tuned constant-q IMM (against_baseline);
  fcm   configs/fcm_imm.toml: validation objective against the λ = 0 IMM;
  wimm  configs/wimm_tuned.toml: validation objective as a ratio to the tuned nIMM;
  schedule  configs/scheduled_ct_imm.toml: validation ζ_p + ζ_v of the noise schedules against
        the tuned CV/CA/CT IMM they are learned on.
The gain is (learned − base) / base on the validation split: below 0 the learned part helps.
Writes <out>/learning_curves.csv and .md.

  scripts/learning_curves.py [--kinds ga,fcm,wimm,schedule] [--sizes 6,12,24,48] [--validation 30]
                             [--out reports/learning_curves] [--bin build/bin]
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import time

KINDS = {
    "ga": ("ga", "configs/ga_fuzzy_imm_tuned.toml", ["agile_air", "ground_vehicle"]),
    "fcm": ("fcm", "configs/fcm_imm.toml", ["agile_air", "ground_vehicle"]),
    "wimm": ("wimm", "configs/wimm_tuned.toml", ["air_surveillance"]),
    "schedule": ("schedule", "configs/scheduled_ct_imm.toml",
                 ["agile_air", "air_surveillance", "ground_vehicle"]),
}


def gain(kind, metrics):
    """(learned − base) / base on the validation split, and whether the learned part is on."""
    if kind == "ga":
        a = metrics["against_baseline"]
        base = a["validation_baseline"]["error"]
        return (a["validation_learned"]["error"] - base) / base, bool(a["learned_part_on"])
    if kind == "fcm":
        base = metrics["imm_lambda0_validation"]["objective"]
        return (metrics["validation"]["objective"] - base) / base, bool(metrics["learned_part_on"])
    if kind == "schedule":
        s = metrics["noise_schedule"]
        base = s["validation_base"]
        return (s["validation"] - base) / base, bool(metrics["learned_part_on"])
    return metrics["validation_objective"] - 1.0, bool(metrics["learned_part_on"])


def regime_with(text, training, validation):
    text, count = re.subn(r"(?m)^training = \d+", f"training = {training}", text)
    if count != 1:
        raise SystemExit("the regime has no single 'training = N' line")
    text, count = re.subn(r"(?m)^validation = \d+", f"validation = {validation}", text)
    if count != 1:
        raise SystemExit("the regime has no single 'validation = N' line")
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", default="ga,fcm,wimm")
    parser.add_argument("--sizes", default="6,12,24,48")
    parser.add_argument("--validation", type=int, default=30)
    parser.add_argument("--regimes", default="", help="only these regimes (comma-separated)")
    parser.add_argument("--out", default="reports/learning_curves")
    parser.add_argument("--bin", default="build/bin")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    only = set(filter(None, args.regimes.split(",")))
    os.makedirs(args.out, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for kind in args.kinds.split(","):
            command, config, regimes = KINDS[kind]
            for regime in regimes:
                if only and regime not in only:
                    continue
                with open(f"configs/regimes/{regime}.toml") as f:
                    text = f.read()
                for n in sizes:
                    path = os.path.join(tmp, f"{regime}.toml")
                    with open(path, "w") as f:
                        f.write(regime_with(text, n, args.validation))
                    model = os.path.join(tmp, f"{kind}_{regime}_{n}.h5")
                    start = time.time()
                    run = subprocess.run([os.path.join(args.bin, "imm-train"), command, "--config",
                                          config, "--regime", path, "--out", model, "--seed", "1"],
                                         capture_output=True, text=True)
                    seconds = time.time() - start
                    if run.returncode != 0:
                        print(f"{kind} {regime} n={n}: exit {run.returncode}: {run.stderr[-300:]}",
                              file=sys.stderr)
                        continue
                    with open(model[:-3] + ".metrics.json") as f:
                        value, on = gain(kind, json.load(f))
                    rows.append({"kind": kind, "regime": regime, "training_tracks": n,
                                 "validation_tracks": args.validation,
                                 "validation_gain": value, "learned_part_on": on,
                                 "seconds": round(seconds, 1)})
                    print(f"{kind:5} {regime:17} n={n:3}: gain {100 * value:+.3f} % "
                          f"({'on' if on else 'off'}, {seconds:.0f} s)", flush=True)
    with open(os.path.join(args.out, "learning_curves.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]) if rows else ["kind"])
        writer.writeheader()
        writer.writerows(rows)
    with open(os.path.join(args.out, "learning_curves.md"), "w") as f:
        f.write("| kind | regime | training tracks | validation gain | learned part | s |\n")
        f.write("|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['kind']} | {r['regime']} | {r['training_tracks']} | "
                    f"{100 * r['validation_gain']:+.3f} % | {'on' if r['learned_part_on'] else 'off'}"
                    f" | {r['seconds']} |\n")


if __name__ == "__main__":
    main()
