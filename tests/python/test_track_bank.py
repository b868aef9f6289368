# SPDX-License-Identifier: Apache-2.0
"""immtrain.TrackBank: every kind's bank equals its tracks run one by one, to the bit; every kind
load_tracker reads has a bank; the gating matrix scores candidate plots without changing a track;
a calibrated model's bank states and gates as its calibrated Filter.

Run by ctest (python.Bindings, beside test_bindings.py) with PYTHONPATH=<build>/python, from the
source root."""

import os

import numpy as np
import pytest

import immtrain

MODELS = os.environ.get("IMM_MODELS", "models")


def bank_equal_to_banks_of_one(model, starts, P0, plots):
    """A bank of len(starts) tracks stepped through `plots` (each an (N, 2) array, every step ok)
    against each track in a bank of its own: the same estimates and μ to the bit. Returns the
    bank."""
    bank = immtrain.TrackBank(model, len(starts))
    for t, start in enumerate(starts):
        bank.initialize(t, start, P0)
    for z in plots:
        assert bank.step(z) == ["ok"] * len(starts)
    for t, start in enumerate(starts):
        one = immtrain.TrackBank(model, 1)
        one.initialize(0, start, P0)
        for z in plots:
            one.step(z[t:t + 1])
        mean, cov = bank.estimate(t)
        mean1, cov1 = one.estimate(0)
        assert mean.tolist() == mean1.tolist()
        assert cov.tolist() == cov1.tolist()
        assert bank.mode_probabilities(t).tolist() == one.mode_probabilities(0).tolist()
    return bank


@pytest.mark.parametrize("name,kind", [("cv3_imm.h5", "plain_imm"),
                                       ("ga_fuzzy_imm.h5", "ga_fuzzy_imm"),
                                       ("mlp_input_estimator_ground_vehicle.h5",
                                        "mlp_input_estimator"),
                                       ("fcm_imm.h5", "fcm_imm")])
def test_the_track_bank_equals_single_tracks(name, kind):
    rng = np.random.default_rng(3)
    starts = [np.array([100.0 * t, 10.0, 50.0 * t, -5.0]) for t in range(3)]
    truth = np.array([s.copy() for s in starts])
    plots = []
    for k in range(30):
        truth[:, 0] += truth[:, 1]
        truth[:, 2] += truth[:, 3]
        plots.append(truth[:, [0, 2]] + rng.normal(0.0, 5.0, (3, 2)))
    bank = bank_equal_to_banks_of_one(os.path.join(MODELS, name), starts,
                                      np.diag([100.0, 25.0, 100.0, 25.0]), plots)
    assert bank.kind == kind
    with pytest.raises(ValueError):
        bank.step(np.zeros((3, 3)))


def test_the_weighted_imms_bank_equals_single_tracks():
    # Polar plots (range, azimuth) of three targets 30-50 km out, with the 6-state start.
    rng = np.random.default_rng(4)
    starts = [np.array([30e3 + 5e3 * t, -150.0, 0.0, 20e3, 100.0, 0.0]) for t in range(3)]
    plots = []
    for k in range(1, 31):
        x = np.array([s[0] + 2.0 * k * s[1] for s in starts])
        y = np.array([s[3] + 2.0 * k * s[4] for s in starts])
        plots.append(np.column_stack([np.hypot(x, y) + rng.normal(0.0, 50.0, 3),
                                      np.arctan2(x, y) + rng.normal(0.0, 0.005, 3)]))
    bank = bank_equal_to_banks_of_one(os.path.join(MODELS, "wimm.h5"), starts,
                                      np.diag([2500.0, 400.0, 25.0, 2500.0, 400.0, 25.0]), plots)
    assert bank.kind == "wimm" and bank.state_dimension == 6
    for t in range(3):
        mean, cov = bank.estimate(t)
        assert mean.shape == (6,) and cov.shape == (6, 6)
        assert abs(mean[0] - (starts[t][0] + 60.0 * starts[t][1])) < 300.0
    with pytest.raises(immtrain.InvalidParameter, match="mean: expected 6 entries"):
        bank.initialize(0, np.zeros(4), np.eye(4))


def test_the_fimms_bank_equals_single_tracks():
    # The sensor's plots (z1, z2) of three vehicles 3 m/s ahead, with the 6-state start.
    rng = np.random.default_rng(5)
    starts = [np.array([3.5 - 1.0 * t, 0.0, 0.0, 5.0 + 10.0 * t, 3.0, 0.0]) for t in range(3)]
    plots = [np.array([[s[0], s[3] + 0.3 * k] for s in starts]) + rng.normal(0.0, 0.5, (3, 2))
             for k in range(1, 41)]
    bank = bank_equal_to_banks_of_one(os.path.join(MODELS, "tsk_range_sensor.h5"), starts,
                                      np.eye(6), plots)
    assert bank.kind == "tsk_sensor" and bank.state_dimension == 6


@pytest.mark.parametrize("name", ["classical_imm_air_surveillance.h5",
                                  "scheduled_ct_imm_air_surveillance.h5"])
def test_the_classical_turn_imms_bank_equals_single_tracks(name):
    # The tuned CV + CT IMM of air_surveillance (polar plots, 5 states [x, vx, y, vy, w]), and the
    # same with its learned noise schedules: three targets in turns of different rates, 30-50 km
    # out, started at w = 0.
    rng = np.random.default_rng(6)
    rates = [0.02, -0.01, 0.0]
    starts = [np.array([30e3 + 10e3 * t, -150.0, 20e3, 100.0, 0.0]) for t in range(3)]
    truth = [s.copy() for s in starts]
    plots = []
    for k in range(40):
        rows = []
        for t, w in enumerate(rates):
            x, vx, y, vy, _ = truth[t]
            c, s = np.cos(5.0 * w), np.sin(5.0 * w)
            if w == 0.0:
                x, y = x + 5.0 * vx, y + 5.0 * vy
            else:
                x, y = x + (s * vx - (1.0 - c) * vy) / w, y + ((1.0 - c) * vx + s * vy) / w
            vx, vy = c * vx - s * vy, s * vx + c * vy
            truth[t] = np.array([x, vx, y, vy, w])
            rows.append([np.hypot(x, y) + rng.normal(0.0, 100.0),
                         np.arctan2(x, y) + rng.normal(0.0, 0.0035)])
        plots.append(np.array(rows))
    bank = bank_equal_to_banks_of_one(os.path.join(MODELS, name), starts,
                                      np.diag([1e4, 400.0, 1e4, 400.0, 1e-4]), plots)
    assert bank.kind == "plain_imm" and bank.state_dimension == 5
    for t in range(3):
        mean, _ = bank.estimate(t)
        assert abs(mean[0] - truth[t][0]) < 500.0 and abs(mean[2] - truth[t][2]) < 500.0


@pytest.mark.parametrize("name,kind,dimension", [("cv3_imm.h5", "plain_imm", 4),
                                                 ("classical_imm_air_surveillance.h5",
                                                  "plain_imm", 5),
                                                 ("ga_fuzzy_imm.h5", "ga_fuzzy_imm", 4),
                                                 ("mlp_input_estimator.h5",
                                                  "mlp_input_estimator", 4),
                                                 ("wimm.h5", "wimm", 6),
                                                 ("tsk_range_sensor.h5", "tsk_sensor", 6),
                                                 ("fcm_imm.h5", "fcm_imm", 4)])
def test_every_kind_load_tracker_reads_has_a_bank(name, kind, dimension):
    bank = immtrain.TrackBank(os.path.join(MODELS, name), 2)
    assert bank.kind == kind and bank.state_dimension == dimension
    with pytest.raises(immtrain.InvalidParameter, match="mean: expected"):
        bank.initialize(0, np.zeros(dimension + 1), np.eye(dimension + 1))


def test_the_bank_scores_candidate_plots_without_changing_a_track():
    """The gating matrix of a CV-mode bank: a plot at a track's predicted position scores higher
    for it than for a track far away, which the gate cuts to -inf; an unusable plot is NaN; asking
    leaves the next step's numbers as they would be; a kind without the question raises."""
    model = os.path.join(MODELS, "cv3_imm.h5")
    P0 = np.diag([100.0, 25.0, 100.0, 25.0])
    starts = [np.array([0.0, 10.0, 0.0, 0.0]), np.array([5000.0, 0.0, 5000.0, 0.0])]
    asked, quiet = immtrain.TrackBank(model, 2), immtrain.TrackBank(model, 2)
    for bank in (asked, quiet):
        for t, start in enumerate(starts):
            bank.initialize(t, start, P0)
    T = immtrain.load_tracker(model).sample_period
    plots = np.array([[10.0 * T, 0.0], [5000.0, 5000.0], [np.nan, 1.0]])
    everything = asked.candidate_log_likelihoods(plots, 2)
    gated = asked.candidate_log_likelihoods(plots, 2, gate=9.21)
    assert everything.shape == (2, 3)
    assert everything[0, 0] > everything[1, 0] and everything[1, 1] > everything[0, 1]
    assert np.isfinite(gated[0, 0]) and gated[1, 0] == -np.inf and gated[0, 1] == -np.inf
    assert np.isnan(everything[:, 2]).all()
    step = np.array([[10.0 * T, 0.0], [5000.0, 5000.0]])
    assert asked.step(step) == quiet.step(step) == ["ok", "ok"]
    assert asked.estimate(0)[0].tolist() == quiet.estimate(0)[0].tolist()
    wimm = immtrain.TrackBank(os.path.join(MODELS, "wimm.h5"), 1)  # fuses the azimuth
    wimm.initialize(0, np.array([3e4, 0.0, 0.0, 4e4, 0.0, 0.0]), np.eye(6))
    with pytest.raises(RuntimeError, match="does not score candidate plots"):
        wimm.candidate_log_likelihoods(plots, 1)
    # The input estimator's, the GA-fuzzy IMM's and the FCM-IMM's banks answer: the plot where
    # the track goes inside, the far one cut, NaN for the unusable one.
    for name in ("mlp_input_estimator.h5", "ga_fuzzy_imm.h5", "fcm_imm.h5"):
        path = os.path.join(MODELS, name)
        learned = immtrain.TrackBank(path, 1)
        learned.initialize(0, starts[0], P0)
        T = immtrain.load_tracker(path).sample_period
        own = np.array([[10.0 * T, 0.0], [5000.0, 5000.0], [np.nan, 1.0]])
        scores = learned.candidate_log_likelihoods(own, 1, gate=9.21)
        assert np.isfinite(scores[0, 0]) and scores[0, 1] == -np.inf, name
        assert np.isnan(scores[0, 2]), name


@pytest.mark.parametrize("name", ["classical_imm_agile_air", "mlp_input_estimator_agile_air"])
def test_a_calibrated_models_bank_states_and_gates_as_its_filter(name):
    """A plain IMM or an input estimator whose file carries a covariance calibration: its bank's
    covariance and gate are the calibrated Filter's, scan by scan; every kind's bank is calibrated
    where its file is, and a file without a calibration keeps the model's own."""
    model = os.path.join(MODELS, name + ".h5")
    bank, alone = immtrain.TrackBank(model, 1), immtrain.Filter(model)
    assert bank.calibrated and alone.calibration is not None
    n = bank.state_dimension
    mean, P0 = np.zeros(n), np.eye(n) * 2500.0
    mean[1] = 200.0
    bank.initialize(0, mean, P0)
    alone.initialize(mean, P0)
    rng = np.random.default_rng(4)
    for k in range(1, 25):
        z = np.array([200.0 * k, 0.0]) + 40.0 * rng.standard_normal(2)
        assert bank.step(z[None, :]) == [alone.step(z)]
        # Each bank runs its one-track filter's arithmetic: the same numbers.
        np.testing.assert_array_equal(bank.estimate(0)[0], alone.state()[0])
        np.testing.assert_array_equal(bank.estimate(0)[1], alone.state()[1])
    # The gate: a plot just inside the filter's calibrated distance scores, just outside is cut.
    alone.predict()
    z_hat, S = alone.predicted_plot()
    direction = np.array([1.0, 0.0]) * np.sqrt(S[0, 0])
    for factor, inside in ((0.99, True), (1.01, False)):
        low, high = 0.0, 100.0
        for _ in range(60):
            mid = 0.5 * (low + high)
            if alone.candidate_distance(z_hat + mid * direction) > factor * 9.21:
                high = mid
            else:
                low = mid
        entry = bank.candidate_log_likelihoods((z_hat + low * direction)[None, :], 1, gate=9.21)
        assert np.isfinite(entry[0, 0]) == inside
    assert immtrain.TrackBank(os.path.join(MODELS, "wimm.h5"), 1).calibrated
    assert not immtrain.TrackBank(os.path.join(MODELS, "cv3_imm.h5"), 1).calibrated


def test_a_bank_refuses_bad_starts_and_more_rows_or_tracks_than_it_holds_naming_the_field():
    """A start its one-track Filter refuses (NaN, an infinite, asymmetric or negative variance),
    more plot rows than tracks and a gating question for more tracks than the bank holds raise
    immtrain.InvalidParameter naming the field; a track already running is left as it was."""
    model = os.path.join(MODELS, "cv3_imm.h5")
    bank = immtrain.TrackBank(model, 2)
    P0 = np.diag([100.0, 25.0, 100.0, 25.0])
    bank.initialize(0, np.array([0.0, 10.0, 0.0, 0.0]), P0)
    before = bank.estimate(0)
    asymmetric = P0.copy()
    asymmetric[0, 1] = 5.0
    negative = P0.copy()
    negative[3, 3] = -1.0
    for mean, P, field in ((np.array([np.nan, 0.0, 0.0, 0.0]), P0, "initial_state"),
                           (np.zeros(4), P0 * np.inf, "initial_covariance"),
                           (np.zeros(4), asymmetric, "initial_covariance"),
                           (np.zeros(4), negative, "initial_covariance")):
        for track in (0, 1):
            with pytest.raises(immtrain.InvalidParameter, match=field):
                bank.initialize(track, mean, P)
            with pytest.raises(immtrain.InvalidParameter, match=field):
                immtrain.Filter(model).initialize(mean, P)
    assert bank.estimate(0)[0].tolist() == before[0].tolist()
    assert bank.estimate(0)[1].tolist() == before[1].tolist()
    bank.initialize(1, np.zeros(4), P0)
    with pytest.raises(immtrain.InvalidParameter, match="plots: expected at most 2 rows"):
        bank.step(np.zeros((3, 2)))
    with pytest.raises(immtrain.InvalidParameter, match="tracks: must be at most the bank's 2"):
        bank.candidate_log_likelihoods(np.zeros((1, 2)), 3)
