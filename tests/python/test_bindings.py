# SPDX-License-Identifier: Apache-2.0
"""The Python module immtrain against imm-track: every shipped model gives the same numbers to the
bit over plots of its own regime; bad files and bad plots raise the documented errors with the C++
message; a filter's split cycle, calibration and time stamps; nothing grows when a tracker is made
and run again and again (the track bank: test_track_bank.py).

Run by ctest (python.Bindings) with PYTHONPATH=<build>/python and IMM_BIN=<build>/bin, from the
source root."""

import csv
import glob
import os
import re
import resource
import shutil
import subprocess

import numpy as np
import pytest

import immtrain

BIN = os.environ.get("IMM_BIN", "build/bin")
MODELS = os.environ.get("IMM_MODELS", "models")


# The tools run without the sanitizer runtime preloaded into this interpreter (tests/python/
# CMakeLists.txt): an instrumented tool carries its own.
TOOL_ENV = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}


def shipped_models():
    files = sorted(glob.glob(os.path.join(MODELS, "*.h5")) +
                   glob.glob(os.path.join(MODELS, "*", "tracker.h5")))
    return [f for f in files if "/reference/" not in f]


def recorded_set_missing(regime):
    """A recorded regime whose track set (the nightly's data, absent from a fresh checkout) is
    not there: its plots cannot be drawn again."""
    match = re.search(r'^\s*set\s*=\s*"([^"]+)"', regime, re.MULTILINE)
    return "[recorded]" in regime and (match is None or not os.path.exists(match.group(1)))


def regime_plots(model, folder):
    """One test track of the model's own regime as imm-track's CSV (imm-data writes it), or a
    straight Cartesian track where the model records no regime or a recorded one whose set is
    missing (the recorded regimes' models are Cartesian)."""
    regime = immtrain.inspect(model)["provenance"]["regime_toml"]
    out = os.path.join(folder, "plots.csv")
    if regime and not recorded_set_missing(regime):
        toml = os.path.join(folder, "regime.toml")
        with open(toml, "w") as f:
            f.write(regime)
        subprocess.run([os.path.join(BIN, "imm-data"), "tracks", "--regime", toml, "--out",
                        os.path.join(folder, "tracks.h5"), "--count", "1", "--csv", out],
                       check=True, capture_output=True, env=TOOL_ENV)
        return out
    rng = np.random.default_rng(7)
    with open(out, "w") as f:
        f.write("k,zx,zy\n")
        for k in range(120):
            x, y = 1000.0 + 150.0 * k, 2000.0 - 80.0 * k
            f.write(f"{k},{x + rng.normal(0, 30)!r},{y + rng.normal(0, 30)!r}\n")
    return out


def read_plots(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return np.array([[float(v) for v in row[:3]] for row in rows[1:]])


@pytest.mark.parametrize("model", shipped_models())
def test_every_shipped_model_equals_imm_track_to_the_bit(model, tmp_path):
    plots_csv = regime_plots(model, str(tmp_path))
    track = subprocess.run([os.path.join(BIN, "imm-track"), "--filter", model, "--measurements",
                            plots_csv], check=True, capture_output=True, text=True,
                           env=TOOL_ENV).stdout
    rows = list(csv.reader(track.splitlines()))
    header, rows = rows[0], rows[1:]
    tracker = immtrain.load_tracker(model)
    out = tracker.run(read_plots(plots_csv))
    n, m = tracker.state_dimension, tracker.mode_count
    assert header[2:2 + n] == tracker.state_names
    assert len(rows) == len(out["event"]) > 10
    compared = 0
    for i, row in enumerate(rows):
        assert row[1] == out["event"][i]
        if row[2] == "":
            assert np.isnan(out["mean"][i]).all()
            continue
        values = [float(v) for v in row[2:2 + 2 * n + m]]
        assert values[:n] == out["mean"][i].tolist()
        assert values[n:2 * n] == np.diag(out["covariance"][i]).tolist()
        assert values[2 * n:] == out["mode_probabilities"][i].tolist()
        nis = row[2 + 2 * n + m]
        assert (float(nis) if nis else float("nan")) == pytest.approx(out["envelope_nis"][i],
                                                                      rel=0, abs=0, nan_ok=True)
        assert int(row[-1]) == int(out["outside_envelope"][i])
        compared += 1
    assert compared > 10
    # process() one plot at a time is run() row by row.
    again = immtrain.load_tracker(model)
    plots = read_plots(plots_csv)
    for i in range(len(plots)):
        step = again.process(int(plots[i, 0]), plots[i, 1:])
        assert step["event"] == out["event"][i]
    mean, covariance = again.state()
    assert mean.tolist() == out["mean"][-1].tolist()
    assert covariance.tolist() == out["covariance"][-1].tolist()


def test_inspect_and_verify_say_what_a_model_is():
    model = os.path.join(MODELS, "cv3_imm.h5")
    info = immtrain.inspect(model)
    assert info["kind"] == "plain_imm"
    assert info["schema_version"] >= 1
    assert info["provenance"]["model_kind"] == "plain_imm"
    assert info["provenance"]["length_unit"] in ("m", "km")
    datasets = {k: v for k, v in info["parameters"].items() if "values" in v}
    assert datasets, info["parameters"].keys()
    for path, entry in datasets.items():
        assert isinstance(entry["values"], np.ndarray) and np.isfinite(entry["values"]).all(), path
    assert any(unit for unit in info["units"].values())
    assert immtrain.verify(model)["ok"] is True
    assert set(immtrain.loadable_kinds()) >= {"plain_imm", "ga_fuzzy_imm", "fcm_imm", "wimm",
                                              "mlp_input_estimator", "tsk_sensor"}


def test_bad_files_raise_file_error_naming_the_file(tmp_path):
    missing = str(tmp_path / "missing.h5")
    with pytest.raises(immtrain.FileError, match="missing.h5"):
        immtrain.load_tracker(missing)
    text = tmp_path / "text.h5"
    text.write_text("not a model\n")
    with pytest.raises(immtrain.FileError, match="text.h5"):
        immtrain.verify(str(text))
    truncated = tmp_path / "truncated.h5"
    data = open(os.path.join(MODELS, "cv3_imm.h5"), "rb").read()
    truncated.write_bytes(data[: len(data) // 2])
    for call in (immtrain.load_tracker, immtrain.inspect, immtrain.verify):
        with pytest.raises(immtrain.FileError, match="truncated.h5"):
            call(str(truncated))
    # A flipped payload byte: the checksum names the field.
    flipped = tmp_path / "flipped.h5"
    shutil.copy(os.path.join(MODELS, "cv3_imm.h5"), flipped)
    raw = bytearray(flipped.read_bytes())
    raw[-200] ^= 0xFF
    flipped.write_bytes(bytes(raw))
    with pytest.raises(immtrain.FileError, match="flipped.h5"):
        immtrain.verify(str(flipped))
    assert issubclass(immtrain.FileError, RuntimeError)


def test_bad_plots_raise_invalid_parameter_or_are_rejected():
    tracker = immtrain.load_tracker(os.path.join(MODELS, "cv3_imm.h5"))
    with pytest.raises(immtrain.InvalidParameter, match=r"plots: expected an \(N, 3\)"):
        tracker.run(np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"plots\[1, 0\]: the scan k must be a whole number"):
        tracker.run(np.array([[0.0, 1.0, 2.0], [1.5, 1.0, 2.0]]))
    with pytest.raises(immtrain.InvalidParameter, match="state: no track is running yet"):
        tracker.state()
    out = tracker.run(np.array([[0.0, 1.0, 2.0], [1.0, np.nan, 2.0], [2.0, 3.0, 2.0]]))
    assert out["event"] == ["waiting", "rejected", "initialized"]
    with pytest.raises(TypeError):
        tracker.process(3, [1.0, 2.0, 3.0])


def test_a_filter_reports_no_state_before_it_starts():
    f = immtrain.Filter(os.path.join(MODELS, "cv3_imm.h5"))
    for question in (f.state, f.mode_probabilities):
        with pytest.raises(RuntimeError, match="initialize"):
            question()
    f.initialize(np.zeros(4), np.eye(4))
    assert f.state()[0].tolist() == [0.0] * 4 and f.mode_probabilities().sum() == pytest.approx(1)


def test_a_filter_split_into_predict_candidates_and_update_equals_its_step():
    """immtrain.Filter: predict(), candidate questions, then update(z) or miss() give step()'s and
    predict_only()'s numbers to the bit on a plain IMM (here the CV/CA/CT IMM of agile_air); a
    learned kind's filter, whose prediction reads the plot, scores candidates by trial updates;
    the wIMM refuses the split."""
    model = os.path.join(MODELS, "classical_imm_agile_air.h5")
    whole, halves = immtrain.Filter(model), immtrain.Filter(model)
    assert halves.predicts_before_the_plot and halves.kind == "plain_imm"
    n, T = whole.state_dimension, whole.sample_period
    mean = np.zeros(n)
    mean[1] = 200.0  # vx
    P = np.eye(n) * 400.0
    P[-1, -1] = 1e-4
    for f in (whole, halves):
        f.initialize(mean, P)
    rng = np.random.default_rng(9)
    sigma = np.sqrt(whole.measurement_covariance[0, 0])
    for k in range(1, 60):
        z = np.array([200.0 * T * k, 0.0]) + sigma * rng.standard_normal(2)
        assert halves.predict() == "ok"
        far = z + 1e3 * sigma
        ll, d2 = halves.candidates(np.array([z, far, [np.nan, 0.0]]))
        assert ll[0] > ll[1] and d2[0] < d2[1] and np.isnan(ll[2])
        z_hat, S = halves.predicted_plot()
        assert z_hat.shape == (2,) and S.shape == (2, 2)
        if k % 7 == 0:
            assert halves.miss() == whole.predict_only() == "ok"
        else:
            assert halves.update(z) == whole.step(z) == "ok"
        for a, b in zip(whole.state(), halves.state()):
            assert a.tolist() == b.tolist()
    # A learned kind scores a candidate by a trial update: the likelihood update() then reports.
    learned, twin = (immtrain.Filter(os.path.join(MODELS, "ga_fuzzy_imm.h5")) for _ in range(2))
    for f in (learned, twin):
        f.initialize(np.array([0.0, 0.2, 0.0, -0.1]), np.eye(4))
    assert learned.has_split_cycle and not learned.predicts_before_the_plot
    for k in range(1, 20):
        z = np.array([0.2 * k, -0.1 * k]) + 0.3 * rng.standard_normal(2)
        assert learned.predict() == "ok"
        learned.candidate_log_likelihood(z + 50.0)  # another candidate first: nothing is kept
        likelihood = learned.candidate_log_likelihood(z)
        assert learned.update(z) == twin.step(z) == "ok"
        assert learned.state()[0].tolist() == twin.state()[0].tolist()
        assert np.isfinite(likelihood)
    with pytest.raises(immtrain.InvalidParameter, match="mean: expected 4"):
        learned.initialize(np.zeros(5), np.eye(4))
    wimm = immtrain.Filter(os.path.join(MODELS, "wimm.h5"))
    wimm.initialize(np.zeros(6), np.eye(6))
    assert not wimm.has_split_cycle
    with pytest.raises(RuntimeError, match="does not split its cycle"):
        wimm.predict()


def test_a_filter_states_its_calibration_and_the_factors_it_applies():
    """Filter.calibration: the tables of the model file's covariance calibration, and the track's
    place in them; the factor of S it reports is the tables' at the plots used and the NIS level
    (recomputed here from the tables: start[min(u, n - 1)] times level[bin]), and the level follows
    the model's own NIS with the stated memory."""
    import bisect
    f = immtrain.Filter(os.path.join(MODELS, "agile_air", "tracker.h5"))
    c = f.calibration
    assert c is not None and c["plots_used"] == 0 and c["nis_level"] == 2.0
    assert len(c["edges"]) + 1 == len(c["level_innovation"]) == len(c["level_state"])
    assert len(c["start_innovation"]) == len(c["start_state"]) >= 1

    def factor(start, level, c):
        u = min(c["plots_used"], len(start) - 1)
        return start[u] * level[bisect.bisect_right(c["edges"], c["nis_level"])]

    sigma = np.sqrt(f.measurement_covariance[0, 0])
    rng = np.random.default_rng(4)
    assert f.start(0, np.array([0.0, 0.0]), 1, np.array([200.0, 0.0]) + sigma * rng.standard_normal(2))
    for k in range(2, 30):
        assert f.predict() == "ok"
        c = f.calibration
        assert c["innovation_scale"] == factor(c["start_innovation"], c["level_innovation"], c)
        assert f.update(np.array([200.0 * k, 0.0]) + sigma * rng.standard_normal(2)) == "ok"
        after = f.calibration
        assert after["plots_used"] == c["plots_used"] + 1
        assert after["state_scale"] == factor(after["start_state"], after["level_state"], after)
    assert immtrain.Filter(os.path.join(MODELS, "cv3_imm.h5")).calibration is None


def test_time_stamps_any_interval_for_a_plain_imm_whole_periods_for_a_learned_model():
    """dt through Filter.step and Tracker.process_at: a plain IMM (agile_air's CV/CA/CT) at one
    sample period gives step()'s bits and takes any other interval; a learned model takes two
    periods as predict_only() then step(), and refuses one and a half without moving."""
    model = os.path.join(MODELS, "classical_imm_agile_air.h5")
    by_scan, by_time = immtrain.Filter(model), immtrain.Filter(model)
    assert by_time.takes_any_interval
    n, T = by_scan.state_dimension, by_scan.sample_period
    P = np.eye(n) * 400.0
    P[-1, -1] = 1e-4
    for f in (by_scan, by_time):
        f.initialize(np.zeros(n), P)
    rng = np.random.default_rng(4)
    for k in range(1, 30):
        z = np.array([200.0 * T * k, 0.0]) + 30.0 * rng.standard_normal(2)
        assert by_scan.step(z) == by_time.step(z, dt=T) == "ok"
        for a, b in zip(by_scan.state(), by_time.state()):
            assert a.tolist() == b.tolist()
    assert by_time.step(np.array([200.0 * T * 30.7, 0.0]), dt=0.7 * T) == "ok"
    assert by_time.step(np.array([200.0 * T * 31.0, 0.0]), dt=-1.0) != "ok"

    learned, twin = (immtrain.Filter(os.path.join(MODELS, "ga_fuzzy_imm.h5")) for _ in range(2))
    assert not learned.takes_any_interval
    for f in (learned, twin):
        f.initialize(np.zeros(4), np.eye(4) * 1e4)
    T = learned.sample_period
    before = [a.tolist() for a in learned.state()]
    assert "whole number" in learned.step(np.array([1.0, 1.0]), dt=1.5 * T)
    assert [a.tolist() for a in learned.state()] == before
    assert learned.step(np.array([1.0, 1.0]), dt=2.0 * T) == "ok"
    assert twin.predict_only() == twin.step(np.array([1.0, 1.0])) == "ok"
    for a, b in zip(learned.state(), twin.state()):
        assert a.tolist() == b.tolist()

    tracker = immtrain.load_tracker(model)
    t = 1000.0
    for k in range(40):
        t += rng.uniform(0.3, 2.5)
        r = tracker.process_at(t, np.array([150.0 * t, 50.0 * t]) + 30.0 * rng.standard_normal(2))
        assert r["event"] != "rejected", r
    assert tracker.process(41, np.zeros(2))["event"] == "rejected"

    # A bank takes a scan's interval for every track where the model takes any interval.
    assert immtrain.TrackBank(model, 3).set_interval(0.4 * T)
    fixed = immtrain.TrackBank(os.path.join(MODELS, "ga_fuzzy_imm.h5"), 3)
    assert not fixed.set_interval(0.4 * T)


def test_nothing_grows_when_trackers_are_made_and_run_again_and_again():
    model = os.path.join(MODELS, "cv3_imm.h5")
    plots = np.array([[k, 10.0 * k, 5.0 * k] for k in range(200)], dtype=float)

    def cycle(times):
        for _ in range(times):
            tracker = immtrain.load_tracker(model)
            tracker.run(plots)
            immtrain.inspect(model)

    cycle(50)  # the allocator's and HDF5's caches settle
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    cycle(300)
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # A leak of one tracker (its filter, > 10 kB) per cycle would add > 3 MB.
    assert after - before < 3000, (before, after)


def test_the_type_stubs_name_every_public_name_and_nothing_else():
    # bindings/python/immtrain.pyi against the compiled module: the same top-level names, and per
    # class the same public methods and properties.
    import ast
    tree = ast.parse(open(os.path.join("bindings", "python", "immtrain.pyi")).read())
    stubbed, classes = set(), {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stubbed.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stubbed.add(node.target.id)
        if isinstance(node, ast.ClassDef):
            classes[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)
                                  and (not n.name.startswith("_") or n.name == "__init__")}
    public = {n for n in dir(immtrain) if not n.startswith("_") or n == "__version__"}
    assert stubbed - {"_Path", "_Array"} == public
    for name, members in classes.items():
        cls = getattr(immtrain, name)
        if name in ("FileError", "InvalidParameter"):
            continue
        actual = {n for n in vars(cls) if not n.startswith("_")}
        assert members - {"__init__"} == actual, name


def test_a_long_run_lets_other_python_threads_go_on():
    # The filter runs without the GIL: while one thread runs 200 000 plots, this one keeps going.
    # Its time stamps (one per 256 turns of its loop) are counted over the middle half of the run:
    # were the GIL held through the call, none could fall there.
    import threading
    import time
    tracker = immtrain.load_tracker(os.path.join(MODELS, "cv3_imm.h5"))
    rows = 200_000
    k = np.arange(rows, dtype=float)
    plots = np.column_stack([k, 10.0 * k, 5.0 * k])
    started, done = threading.Event(), threading.Event()
    span = []

    def work():
        started.set()
        begin = time.perf_counter()
        tracker.run(plots)
        span.extend([begin, time.perf_counter()])
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    started.wait()
    stamps, turns = [], 0
    while not done.is_set():
        turns += 1
        if turns % 256 == 0:
            stamps.append(time.perf_counter())
    worker.join()
    begin, end = span
    quarter = 0.25 * (end - begin)
    inside = sum(begin + quarter < t < end - quarter for t in stamps)
    assert inside > 20, (inside, end - begin)
