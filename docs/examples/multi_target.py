#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Two targets whose paths cross, detected with probability 0.9 among Poisson clutter, tracked by
a global-nearest-neighbour tracker written here on a model's split cycle (immtrain.Filter: predict,
gate and score every candidate, then update or miss) with SciPy's linear_sum_assignment; prints the
GOSPA per scan against the truth and draws tracks, plots and clutter.

    PYTHONPATH=build/python /usr/bin/python3 docs/examples/multi_target.py --out scene.png

The model is any kind that splits its cycle, with Cartesian plots (default: agile_air's tuned CV/CA/CT IMM); the
scene uses its sample period and plot noise. --check exits 1 unless both targets are held (GOSPA's
missed part zero) on at least 90 % of the scans after the tenth and the median GOSPA is below
three plot σ.
"""
import argparse
import os
import sys

import numpy as np
from scipy.optimize import linear_sum_assignment

import immtrain

GATE = 9.21  # χ²(2), 99 %
CONFIRM_HITS, CONFIRM_SCANS, MISSES_TO_DELETE = 3, 4, 3


class Track:
    count = 0

    def __init__(self, model, first, second):
        self.filter = immtrain.Filter(model)
        if not self.filter.start(first[0], first[1], second[0], second[1]):
            raise ValueError("no two-point start")
        self.id = Track.count
        Track.count += 1
        self.hits, self.age, self.misses, self.confirmed = 2, 2, 0, False

    def position(self):
        mean, _ = self.filter.state()
        return np.array([mean[0], mean[len(mean) // 2]])


def scene(filter_, scans, rng, clutter_rate):
    """Truth (scans, 2, 2) of two targets crossing at the middle scan, and each scan's plots with
    their source (0, 1, or -1 for clutter)."""
    T, sigma = filter_.sample_period, np.sqrt(filter_.measurement_covariance[0, 0])
    speed, spread = 10.0 * sigma / T, 40.0 * sigma  # targets well apart except where they cross
    t = np.arange(scans) * T
    middle = t[scans // 2]
    truth = np.stack([np.column_stack([speed * t, spread * (t - middle) / middle]),
                      np.column_stack([speed * t, -spread * (t - middle) / middle])], axis=1)
    low, high = truth.reshape(-1, 2).min(axis=0) - 20 * sigma, truth.reshape(-1, 2).max(axis=0) + 20 * sigma
    plots = []
    for k in range(scans):
        rows = [(truth[k, j] + sigma * rng.standard_normal(2), j) for j in (0, 1) if rng.random() < 0.9]
        rows += [(low + (high - low) * rng.random(2), -1) for _ in range(rng.poisson(clutter_rate))]
        order = rng.permutation(len(rows))
        plots.append([rows[i] for i in order])
    return truth, plots, (low, high)


def gospa(truth, estimates, c):
    """GOSPA (α = 2, p = 2) and its missed-target count."""
    if len(truth) == 0 or len(estimates) == 0:
        return np.sqrt(c * c / 2 * (len(truth) + len(estimates))), len(truth)
    d = np.linalg.norm(truth[:, None, :] - estimates[None, :, :], axis=2)
    cost = np.minimum(d, c) ** 2
    rows, cols = linear_sum_assignment(cost)
    assigned = [(r, q) for r, q in zip(rows, cols) if d[r, q] < c]
    total = sum(cost[r, q] for r, q in assigned) + c * c / 2 * (len(truth) + len(estimates) - 2 * len(assigned))
    return np.sqrt(total), len(truth) - len(assigned)


def track(model, plots, max_speed, T):
    """Per scan: predict, gate (d² ≤ GATE) and assign, update or miss, confirm M of N, delete,
    then start tracks from pairs of leftover plots. Returns each scan's confirmed positions."""
    tracks, seeds, history = [], [], []
    for k, scan in enumerate(plots):
        z = np.array([p for p, _ in scan]).reshape(-1, 2)
        used = np.zeros(len(z), dtype=bool)
        cost = np.full((len(tracks), len(z)), 1e12)
        for i, tr in enumerate(tracks):
            if tr.filter.predict() == "ok" and len(z):
                _, d2 = tr.filter.candidates(z)
                cost[i] = np.where(d2 <= GATE, d2, 1e12)
        rows, cols = linear_sum_assignment(cost) if cost.size else ([], [])
        chosen = {r: q for r, q in zip(rows, cols) if cost[r, q] <= GATE}
        for i, tr in enumerate(tracks):
            hit = i in chosen and tr.filter.update(z[chosen[i]]) == "ok"
            if hit:
                used[chosen[i]] = True
            else:
                tr.filter.miss()
            tr.age += 1
            tr.hits += hit
            tr.misses = 0 if hit else tr.misses + 1
            tr.confirmed |= tr.hits >= CONFIRM_HITS and tr.age <= CONFIRM_SCANS
        tracks = [tr for tr in tracks if (tr.misses < MISSES_TO_DELETE if tr.confirmed else
                                          tr.hits + max(CONFIRM_SCANS - tr.age, 0) >= CONFIRM_HITS)]
        fresh = []
        for q in np.flatnonzero(~used):  # two-point starts from the last scan's leftovers
            near = [i for i, s in enumerate(seeds)
                    if np.linalg.norm(z[q] - s[1]) <= max_speed * T * (k - s[0])]
            if near:
                i = min(near, key=lambda i: np.linalg.norm(z[q] - seeds[i][1]))
                tracks.append(Track(model, seeds.pop(i), (k, z[q])))
            else:
                fresh.append((k, z[q]))
        seeds = fresh
        history.append(np.array([tr.position() for tr in tracks if tr.confirmed]).reshape(-1, 2))
    return history


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=os.path.join("models", "classical_imm_agile_air.h5"))
    parser.add_argument("--scans", type=int, default=60)
    parser.add_argument("--clutter", type=float, default=10.0, help="false plots per scan")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default="multi_target.png")
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args()

    probe = immtrain.Filter(args.model)
    if not probe.has_split_cycle or probe.measurement_kind != "cartesian":
        sys.exit(f"{args.model}: needs a kind that splits its cycle, with Cartesian plots")
    rng = np.random.default_rng(args.seed)
    truth, plots, (low, high) = scene(probe, args.scans, rng, args.clutter)
    T, sigma = probe.sample_period, np.sqrt(probe.measurement_covariance[0, 0])
    Track.count = 0
    history = track(args.model, plots, max_speed=15.0 * sigma / T, T=T)
    distances, held = [], 0
    for k in range(10, args.scans):
        d, missed = gospa(truth[k], history[k], c=10 * sigma)
        distances.append(d)
        held += missed == 0
    median = float(np.median(distances))
    print(f"{args.model}: {Track.count} tracks started, median GOSPA {median:.1f} "
          f"(plot σ {sigma:.1f}), both targets held on {held} of {len(distances)} scans")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    figure, axes = plt.subplots(figsize=(10, 6), dpi=100)
    clutter = np.array([p for scan in plots for p, source in scan if source < 0]).reshape(-1, 2)
    detections = np.array([p for scan in plots for p, source in scan if source >= 0]).reshape(-1, 2)
    axes.scatter(clutter[:, 0], clutter[:, 1], s=4, c="0.7", label="clutter")
    axes.scatter(detections[:, 0], detections[:, 1], s=6, c="tab:blue", label="target plots")
    for j in (0, 1):
        axes.plot(truth[:, j, 0], truth[:, j, 1], "k--", lw=1, label="truth" if j == 0 else None)
    estimates = np.concatenate([h for h in history if len(h)]) if any(len(h) for h in history) else np.zeros((0, 2))
    axes.scatter(estimates[:, 0], estimates[:, 1], s=10, c="tab:red", label="confirmed tracks")
    axes.set_xlim(low[0], high[0])
    axes.set_ylim(low[1], high[1])
    axes.set_title(f"GNN on {os.path.basename(args.model)}: median GOSPA {median:.1f}")
    axes.legend(loc="upper left")
    figure.savefig(args.out)
    print(f"wrote {args.out}")
    if args.check and (held < 0.9 * len(distances) or median > 3 * sigma):
        sys.exit(1)


if __name__ == "__main__":
    main()
