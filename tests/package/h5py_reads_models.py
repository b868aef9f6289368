# SPDX-License-Identifier: Apache-2.0
"""Every shipped model file read by h5py, as a user with no immtrain code reads it.

Checks, for each models/*.h5: schema version 2 (3 for a file with a version-3 field: a GA-fuzzy
IMM with normalized antecedents, an input estimator with its input's error variance, a plain IMM
with a learned noise schedule); every text attribute comes back as str (variable length UTF-8), never
bytes; every dataset has `units`, every matrix `columns` naming each of its columns; every group
with real-valued attributes a `units` entry for each of them; the counts are integers; the
datasets' values are finite. Exits 77 (skipped) where h5py is absent.
"""
import math
import pathlib
import sys

try:
    import h5py
    import numpy
except ImportError as error:  # Debian: apt-get install python3-h5py
    print(f"SKIPPED: h5py is not installed ({error}); apt-get install python3-h5py")
    sys.exit(77)

COUNTS = {"schema_version", "seed", "mode_count", "level_count", "layer_count", "window",
          "max_iterations", "iterations", "compensate_lowest", "rules", "generations"}


def split(text):
    return text.split(",")


def check(path):
    problems = []

    def problem(where, message):
        problems.append(f"{path.name}: {where}: {message}")

    with h5py.File(path, "r") as f:
        # Version 3 only for a file with a version-3 field (a GA-fuzzy IMM with normalized
        # antecedents, an input estimator with its input's error variance, a plain IMM mode with a
        # noise schedule); every other file is written as version 2.
        group = f.get("ga_fuzzy_imm")
        mlp = f.get("mlp")
        modes = f.get("imm/modes")
        scheduled = modes is not None and any(
            "noise_schedule_rules" in mode.attrs for mode in modes.values())
        newer = (group is not None and "antecedents" in group.attrs) or (
            mlp is not None and "input_variance" in mlp.attrs) or scheduled
        # Version 4 for a file with a covariance calibration (every trained model's).
        expected = 4 if "calibration" in f else 3 if newer else 2
        if f.attrs.get("schema_version") != expected:
            problem("/@schema_version",
                    f"is {f.attrs.get('schema_version')!r}, expected {expected}")
        if f.attrs.get("length_unit") not in ("m", "km"):
            problem("/@length_unit", f"is {f.attrs.get('length_unit')!r}")
        if str(f.attrs.get("trainer_version", "")).endswith("-dirty"):
            problem("/@trainer_version", "stamped from a dirty tree")

        def visit(name, obj):
            where = "/" + name if name else "/"
            for key, value in obj.attrs.items():
                if isinstance(value, bytes):
                    problem(f"{where}@{key}", "text read as bytes (not variable-length UTF-8)")
                if key in COUNTS and not isinstance(value, (int, numpy.integer)):
                    problem(f"{where}@{key}", f"a count stored as {type(value).__name__}")
            if isinstance(obj, h5py.Dataset):
                units = obj.attrs.get("units")
                if not isinstance(units, str) or not units:
                    problem(where, "no units")
                    return
                data = obj[()]
                if not numpy.all(numpy.isfinite(data)):
                    problem(where, "non-finite values")
                if obj.ndim == 2:
                    columns = obj.attrs.get("columns")
                    if not isinstance(columns, str):
                        problem(where, "a matrix without columns")
                    elif len(split(columns)) != obj.shape[1]:
                        problem(where, f"columns {columns!r} for {obj.shape[1]} columns")
                    elif len(split(units)) not in (1, obj.shape[1]):
                        problem(where, f"units {units!r} for {obj.shape[1]} columns")
                elif len(split(units)) not in (1, obj.shape[0] if obj.ndim == 1 else 1):
                    problem(where, f"units {units!r} for shape {obj.shape}")
                return
            if where == "/":
                return
            reals = [k for k, v in obj.attrs.items() if isinstance(v, (float, numpy.floating))]
            named = {}
            for entry in split(obj.attrs.get("units", "")) if reals else []:
                key, _, unit = entry.partition("=")
                named[key] = unit
            for key in reals:
                if not named.get(key):
                    problem(f"{where}@{key}", "a real without units")

        visit("", f)
        f.visititems(visit)
    return problems


def main():
    files = sorted(f for folder in sys.argv[1:] for f in pathlib.Path(folder).glob("*.h5"))
    if not files:
        print(f"no model files in {' '.join(sys.argv[1:])}")
        return 1
    problems = [p for path in files for p in check(path)]
    for p in problems:
        print(p)
    print(f"{len(files)} model files read by h5py {h5py.__version__}: "
          f"{'all self-describing' if not problems else f'{len(problems)} problems'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
