#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""W2a (or W2b) on PyTorch, for a side-by-side figure (docs/performance.md): the 2-10-10-1 network
of tools/workloads/inputs/ (sigmoid hidden units, linear output, float64), 6000 full-batch epochs
of plain gradient descent, learning rate 0.1 on the mean squared error, one thread; with
--per-sample, W2b: one sample per step in the fixed order 0 … 999, 100 epochs by default. Prints
the median wall time of --rounds runs, the final MSE (which must equal imm-train-bench's W2a or
W2b figure), the torch version and the BLAS it was built with.

    python3 scripts/peers/w2a_pytorch.py [--rounds 3] [--epochs 6000] [--per-sample]
"""
import argparse
import csv
import json
import os
import statistics
import time

import torch

HERE = os.path.dirname(os.path.abspath(__file__))
INPUTS = os.path.join(HERE, "..", "..", "tools", "workloads", "inputs")


def load():
    with open(os.path.join(INPUTS, "w2_samples.csv")) as f:
        rows = list(csv.DictReader(f))
    x = torch.tensor([[float(r["x1"]), float(r["x2"])] for r in rows], dtype=torch.float64)
    t = torch.tensor([[float(r["t"])] for r in rows], dtype=torch.float64)
    with open(os.path.join(INPUTS, "w2_init_weights.json")) as f:
        w = json.load(f)
    return x, t, w


def network(w):
    net = torch.nn.Sequential(torch.nn.Linear(2, 10), torch.nn.Sigmoid(),
                              torch.nn.Linear(10, 10), torch.nn.Sigmoid(),
                              torch.nn.Linear(10, 1)).double()
    with torch.no_grad():
        for i in (0, 2, 4):
            net[i].weight.copy_(torch.tensor(w[f"{i}.weight"], dtype=torch.float64))
            net[i].bias.copy_(torch.tensor(w[f"{i}.bias"], dtype=torch.float64))
    return net


def run(x, t, w, epochs, batches):
    """`epochs` passes over `batches` (pairs of inputs and targets), a gradient step per batch:
    [(x, t)] for W2a's full batch, one pair per sample for W2b."""
    net = network(w)
    optimizer = torch.optim.SGD(net.parameters(), lr=0.1)
    loss_fn = torch.nn.MSELoss()
    start = time.perf_counter()
    for _ in range(epochs):
        for xb, tb in batches:
            optimizer.zero_grad()
            loss = loss_fn(net(xb), tb)
            loss.backward()
            optimizer.step()
    seconds = time.perf_counter() - start
    with torch.no_grad():
        mse = loss_fn(net(x), t).item()
    return seconds, mse


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--epochs", type=int, default=None,
                        help="6000 (W2a) or 100 (W2b, --per-sample)")
    parser.add_argument("--per-sample", action="store_true", help="W2b: one sample per step")
    args = parser.parse_args()
    epochs = args.epochs if args.epochs is not None else (100 if args.per_sample else 6000)
    torch.set_num_threads(1)
    x, t, w = load()
    batches = [(x[i:i + 1], t[i:i + 1]) for i in range(x.shape[0])] if args.per_sample else [(x, t)]
    times, mse = [], None
    for _ in range(args.rounds):
        seconds, mse = run(x, t, w, epochs, batches)
        times.append(seconds)
    blas = [line.strip() for line in torch.__config__.show().splitlines() if "BLAS" in line]
    print(json.dumps({"workload": "W2b" if args.per_sample else "W2a", "torch": torch.__version__,
                      "threads": 1, "median_seconds": statistics.median(times), "seconds": times,
                      "final_mse": mse, "blas": blas}, indent=1))


if __name__ == "__main__":
    main()
