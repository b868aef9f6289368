# SPDX-License-Identifier: Apache-2.0
"""The trainer's side from Python (immtrain_lab through immtrain): regimes read from files and
built from dicts with the tools' validation errors; tracks drawn as imm-data draws them (the same
digest); experiments and the ranking with the numbers imm-eval writes into metrics.json and
tracker.json.

Run by ctest (python.TheTrainersSide…) with PYTHONPATH=<build>/python and IMM_BIN=<build>/bin,
from the source root."""

import json
import os
import subprocess

import numpy as np
import pytest

import immtrain

BIN = os.environ.get("IMM_BIN", "build/bin")
TOOL_ENV = {k: v for k, v in os.environ.items() if k != "LD_PRELOAD"}

SMALL = {
    "name": "small_turns",
    "units": "m",
    "sample_period": 1.0,
    "scans": 40,
    "process_noise_sigma": 0.5,
    "sensor": {"kind": "cartesian", "sigma": [20.0, 20.0]},
    "start": {"range": [10000.0, 30000.0], "bearing_deg": [0.0, 360.0], "heading": "inbound",
              "heading_offset_deg": [-60.0, 60.0], "speed": [150.0, 250.0]},
    "maneuvers": [{"kind": "cv", "probability": 0.5, "duration": [8.0, 20.0]},
                  {"kind": "turn", "probability": 0.5, "duration": [6.0, 15.0],
                   "rate_deg": [3.0, 6.0]}],
    "splits": {"training": 4, "validation": 2, "test": 10, "seed": 3},
}


def test_the_lab_is_reached_through_immtrain_and_unknown_names_are_not():
    assert immtrain.load_regime.__module__ == "immtrain_lab"
    with pytest.raises(AttributeError):
        immtrain.no_such_function  # noqa: B018


def test_a_regime_from_a_dict_draws_what_imm_data_draws_from_its_text(tmp_path):
    regime = immtrain.regime_from_dict(SMALL, name="small")
    assert (regime.name, regime.units, regime.sample_period, regime.scans) == \
        ("small_turns", "m", 1.0, 40)
    assert regime.splits["test"] == 10
    tracks = regime.draw("test", seed=5)
    assert tracks["truth"].shape == (10, 40, 6)
    assert tracks["plots"].shape == (10, 40, 2)
    np.testing.assert_array_equal(tracks["times"], np.arange(40.0))
    # The plots are the truth's positions plus noise of the regime's σ.
    noise = tracks["plots"] - tracks["truth"][:, :, [0, 3]]
    assert 15.0 < noise.std() < 25.0
    # Its text, written out, is the same regime for the tools: the same tracks, to the digest.
    (tmp_path / "small.toml").write_text(regime.toml)
    again = immtrain.load_regime(tmp_path / "small.toml")
    assert again.digest == regime.digest
    # imm-data's CSV of track 2 of the same split and seed: the same plots (10 significant digits).
    subprocess.run([os.path.join(BIN, "imm-data"), "tracks", "--regime", str(tmp_path / "small.toml"),
                    "--split", "test", "--seed", "5", "--out", str(tmp_path / "test.h5"),
                    "--csv", str(tmp_path / "track2.csv"), "--csv-track", "2"],
                   check=True, env=TOOL_ENV, capture_output=True)
    csv = np.loadtxt(tmp_path / "track2.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(csv[:, 1:], tracks["plots"][2], rtol=1e-9, atol=1e-9)


def test_an_invalid_regime_is_a_value_error_naming_the_key():
    bad = dict(SMALL)
    del bad["scans"]
    with pytest.raises(ValueError, match="scans"):
        immtrain.regime_from_dict(bad)
    worse = dict(SMALL, sensor={"kind": "sonar", "sigma": [1.0, 1.0]})
    with pytest.raises(ValueError, match="sensor.kind"):
        immtrain.regime_from_dict(worse)
    with pytest.raises(ValueError, match="split"):
        immtrain.regime_from_dict(SMALL).draw("tests")


def test_a_dicts_strings_and_keys_reach_the_regime_as_they_are_written():
    # Quotes, backslashes and control characters are escaped in the TOML the dict becomes.
    odd = dict(SMALL, name='turns "A"\\B\x01C\nD')
    assert immtrain.regime_from_dict(odd).name == 'turns "A"\\B\x01C\nD'
    # A key with a space stays one key: refused as unknown, naming it.
    with pytest.raises(ValueError, match="'scan count': unknown key"):
        immtrain.regime_from_dict(dict(SMALL, **{"scan count": 3}))
    # An integer beyond 64 bits is refused naming its key.
    with pytest.raises(ValueError, match="scans"):
        immtrain.regime_from_dict(dict(SMALL, scans=2**70))


def test_an_experiment_returns_the_numbers_of_its_metrics_json(tmp_path):
    result = immtrain.evaluate("ga-imm", model="models/ga_fuzzy_imm.h5", runs=6,
                               out=tmp_path / "ga")
    metrics = json.loads((tmp_path / "ga" / "metrics.json").read_text())["results"]
    assert set(result["filters"]) == set(metrics)
    for name, figures in result["filters"].items():
        assert figures["zeta_p"] == metrics[name]["zeta_p"]
        assert figures["zeta_v"] == metrics[name]["zeta_v"]
        assert figures["nis"] == metrics[name]["nis"]
    details = json.loads((tmp_path / "ga" / "details.json").read_text())
    for name, d in result["ga_imm_minus"].items():
        assert d["zeta_p"] == details["ga_imm_minus"][name]["zeta_p"]
    assert result["findings"] == details["findings"]
    assert result["exit_code"] in (0, 5, 7)
    # report.md as imm-eval writes it, with the command line that gives the same result.
    report = open(result["report"]).read()
    assert "- Command: `imm-eval ga-imm --models models --model models/ga_fuzzy_imm.h5 --runs 6" \
        in report
    assert "| GA-IMM " in report
    # One table of the filters' figures: a DataFrame where pandas is installed (it is a Debian
    # package scripts/install-deps.sh installs), else a dict of columns.
    table = result["table"]
    try:
        import pandas
        assert isinstance(table, pandas.DataFrame)
        assert table.loc["GA-IMM", "zeta_p"] == metrics["GA-IMM"]["zeta_p"]
    except ImportError:
        row = table["filter"].index("GA-IMM")
        assert table["zeta_p"][row] == metrics["GA-IMM"]["zeta_p"]
    # Without `out` nothing is written, and the figures are the same.
    again = immtrain.evaluate("ga-imm", model="models/ga_fuzzy_imm.h5", runs=6)
    assert again["filters"]["GA-IMM"]["zeta_p"] == result["filters"]["GA-IMM"]["zeta_p"]


def test_the_lab_raises_immtrains_errors_and_leaves_immtrains_own_as_documented(tmp_path):
    """Once the trainer's side is loaded (here by the first lab name used), the runtime's errors
    are still immtrain.InvalidParameter and immtrain.FileError, from immtrain's functions and from
    the lab's alike."""
    immtrain.regime_from_dict(SMALL)
    bank = immtrain.TrackBank("models/cv3_imm.h5", 1)
    with pytest.raises(immtrain.InvalidParameter, match="mean: expected 4 entries"):
        bank.initialize(0, np.zeros(5), np.eye(5))
    with pytest.raises(immtrain.FileError, match="no_such_model"):
        immtrain.load_tracker(str(tmp_path / "no_such_model.h5"))
    with pytest.raises(immtrain.FileError, match="no_such_model"):
        immtrain.evaluate("plain-imm", model=str(tmp_path / "no_such_model.h5"))


def test_experiment_options_are_checked():
    # An invalid argument is immtrain.InvalidParameter (a ValueError) naming it, as the
    # runtime's are.
    with pytest.raises(immtrain.InvalidParameter, match="^experiment: 'ga_imm' is none of"):
        immtrain.evaluate("ga_imm")
    with pytest.raises(TypeError, match="gate_on"):
        immtrain.evaluate("ga-imm", gate_on="best")
    with pytest.raises(immtrain.InvalidParameter, match="^runs: must be"):
        immtrain.evaluate("plain-imm", runs=0)
    with pytest.raises(immtrain.InvalidParameter, match="^baselines: at least one"):
        immtrain.rank([], ["models/cv3_imm.h5"])
    with pytest.raises(RuntimeError, match="no_such_model"):
        immtrain.evaluate("plain-imm", model="models/no_such_model.h5")


def test_rank_chooses_what_tracker_json_records(tmp_path):
    result = immtrain.rank(["models/baseline_imm_agile_air.h5", "models/classical_imm_agile_air.h5"],
                           ["models/ga_fuzzy_imm_agile_air.h5"], runs=5, out=tmp_path / "rank")
    tracker = json.loads((tmp_path / "rank" / "tracker.json").read_text())
    assert result["tracker"] == tracker["tracker"]
    assert result["bar"] == tracker["bar"]
    assert [row["filter"] for row in result["ranking"]] == \
        [row["filter"] for row in tracker["ranking"]]
    assert result["findings"] == tracker["findings"]
    assert os.path.exists(result["report"])


def small_ga_config(tmp_path):
    text = open("configs/ga_fuzzy_imm.toml").read()
    text = text.replace("population = 500", "population = 16").replace(
        "generations = 100", "generations = 2")
    path = tmp_path / "ga.toml"
    path.write_text(text)
    return path


def test_training_gives_what_imm_train_gives_with_the_same_seed(tmp_path):
    config = small_ga_config(tmp_path)
    lines = []
    result = immtrain.train("ga", config=config, seed=7, out=tmp_path / "py.h5", threads=1,
                            progress=lambda level, message: lines.append((level, message)))
    assert result["exit_code"] == 0
    assert result["model"] == tmp_path / "py.h5"
    assert result["metrics"]["seed"] == 7
    assert lines and all(isinstance(m, str) for _, m in lines)
    subprocess.run([os.path.join(BIN, "imm-train"), "ga", "--config", str(config), "--seed", "7",
                    "--out", str(tmp_path / "cli.h5"), "--threads", "1"],
                   check=True, env=TOOL_ENV, capture_output=True)
    ours = immtrain.inspect(tmp_path / "py.h5")
    theirs = immtrain.inspect(tmp_path / "cli.h5")
    # Every parameter the same (provenance and the levels' wall times aside).
    assert ours["parameters"].keys() == theirs["parameters"].keys()
    for name, value in ours["parameters"].items():
        other = theirs["parameters"][name]
        timeless = [{k: v for k, v in p["attributes"].items() if k != "wall_seconds"}
                    for p in (value, other)]
        assert timeless[0] == timeless[1], name
        assert ("values" in value) == ("values" in other), name
        if "values" in value:
            np.testing.assert_array_equal(value["values"], other["values"], err_msg=name)
    # The kind's own name is accepted as imm-train accepts it.
    again = immtrain.train("ga_fuzzy_imm", config=config, seed=7, out=tmp_path / "kind.h5",
                           threads=1)
    assert again["exit_code"] == 0


def test_progress_true_shows_a_bar_of_the_log_lines(tmp_path, capsys):
    result = immtrain.train("ga", config=small_ga_config(tmp_path), seed=5,
                            out=tmp_path / "bar.h5", threads=1, progress=True)
    assert result["exit_code"] == 0
    shown = capsys.readouterr()
    # tqdm draws on stderr; without tqdm each line is printed.
    assert "train ga" in shown.err or "generation" in shown.out


def test_training_refuses_what_imm_train_refuses(tmp_path):
    with pytest.raises(ValueError, match="unknown command 'no_such_kind'"):
        immtrain.train("no_such_kind")
    with pytest.raises(ValueError, match="did you mean 'ga'"):
        immtrain.train("gaa")
    bad = tmp_path / "bad.toml"
    bad.write_text(open("configs/ga_fuzzy_imm.toml").read().replace(
        "population = 500", "population = -3"))
    with pytest.raises(ValueError, match="population"):
        immtrain.train("ga", config=bad, out=tmp_path / "never.h5")
    assert not (tmp_path / "never.h5").exists()


def test_a_progress_callback_that_raises_stops_the_training_and_leaves_no_model(tmp_path):
    def fail(level, message):
        raise RuntimeError("callback says no")
    with pytest.raises(RuntimeError, match="callback says no"):
        immtrain.train("ga", config=small_ga_config(tmp_path), seed=3, out=tmp_path / "m.h5",
                       threads=1, progress=fail)
    assert not (tmp_path / "m.h5").exists()


def test_ctrl_c_stops_a_training_cleanly(tmp_path):
    # SIGINT arrives while the GA runs (raised at its third log line): the training stops there,
    # KeyboardInterrupt is raised, and neither the model nor a temporary is left behind.
    import signal
    out = tmp_path / "models"
    out.mkdir()
    lines = []

    def interrupt(level, message):
        lines.append(message)
        if len(lines) == 3:
            signal.raise_signal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt):
        immtrain.train("ga", config=small_ga_config(tmp_path), seed=3, out=out / "m.h5",
                       threads=1, progress=interrupt)
    assert len(lines) == 3
    assert sorted(os.listdir(out)) == []
    # The module goes on working: the same training runs to its end afterwards.
    assert immtrain.train("ga", config=small_ga_config(tmp_path), seed=3, out=out / "m.h5",
                          threads=1)["exit_code"] == 0


def test_recordings_import_as_imm_data_imports_them(tmp_path):
    # Three recorded tracks, one CSV each, at T = 2 s with a gap of one plot in the second.
    rng = np.random.default_rng(4)
    folder = tmp_path / "recordings"
    folder.mkdir()
    for n in range(3):
        t = np.arange(0.0, 80.0, 2.0)
        if n == 1:
            t = np.delete(t, 7)
        x = 1000.0 * n + 120.0 * t + rng.normal(0.0, 15.0, t.size)
        y = -500.0 + 40.0 * t + rng.normal(0.0, 15.0, t.size)
        rows = "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(t, x, y))
        (folder / f"track{n}.csv").write_text("t,zx,zy\n" + rows + "\n")
    ours = immtrain.import_recordings([folder], out=tmp_path / "py.h5", name="mine")
    assert (ours["recordings"], ours["sample_period"], ours["gap_scans"]) == (3, 2.0, 1)
    assert ours["repeated_lines"] == 0
    assert ours["tracks"]["plots"].shape == (ours["windows"], ours["scans"], 2)
    assert np.isnan(ours["tracks"]["plots"][1, 7]).all()  # the gap: a scan without a plot
    listing = subprocess.run([os.path.join(BIN, "imm-data"), "import", str(folder), "--out",
                              str(tmp_path / "cli.h5"), "--name", "mine"],
                             check=True, env=TOOL_ENV, capture_output=True, text=True)
    assert f"sha256 {ours['digest'][:16]}" in listing.stdout
    with pytest.raises(immtrain.InvalidParameter, match="sensor"):
        immtrain.import_recordings([folder], out=tmp_path / "x.h5", sensor="sonar")
    for bad in [{"sample_period": float("nan")}, {"tolerance": float("nan")}, {"scans": 2}]:
        with pytest.raises(immtrain.InvalidParameter, match="^" + next(iter(bad))):
            immtrain.import_recordings([folder], out=tmp_path / "x.h5", **bad)
    # A line written twice by the recorder is dropped and counted: the same set.
    doubled = (folder / "track0.csv").read_text().splitlines(keepends=True)
    (folder / "track0.csv").write_text("".join(doubled[:5] + doubled[4:]))
    again = immtrain.import_recordings([folder], out=tmp_path / "py2.h5", name="mine")
    assert (again["repeated_lines"], again["digest"]) == (1, ours["digest"])
    (folder / "bad.csv").write_text("t,zx,zy\n0,1,2\n1,nan,3\n")
    with pytest.raises(RuntimeError, match="bad.csv"):
        immtrain.import_recordings([folder], out=tmp_path / "y.h5")


def test_multi_target_gives_the_figures_of_imm_evals_metrics_json(tmp_path):
    models = ["models/classical_imm_agile_air.h5", "models/baseline_imm_agile_air.h5"]
    ours = immtrain.multi_target(models, pd=[0.9], clutter=[0.0, 20.0], runs=3)
    assert [c["clutter_per_scan"] for c in ours] == [0.0, 20.0]
    subprocess.run([os.path.join(BIN, "imm-eval"), "multi-target", "--models", *models, "--pd",
                    "0.9", "--clutter", "0,20", "--runs", "3", "--out", str(tmp_path / "mt")],
                   check=True, env=TOOL_ENV, capture_output=True)
    metrics = json.loads((tmp_path / "mt" / "metrics.json").read_text())
    for condition, written in zip(ours, metrics["conditions"]):
        for model, figures in zip(condition["models"], written["models"]):
            assert model["gospa"] == figures["gospa"]
            assert model["breaks_per_scene"] == figures["breaks_per_scene"]
            assert model["gospa_minus_first"] == figures["gospa_minus_first"]
    with pytest.raises(ValueError, match="detection_probability"):
        immtrain.multi_target(models, pd=[1.5], runs=2)
