"""Benchmark: all feasible modes by exhaustive batched enumeration vs a per-mode loop.

On seeded random systems (``planner.sweeps.random_systems``: contacts on a random convex workpiece,
random manipulator Jacobian, ``|tau_I| = n_c - 3``) with ``n_c = 3..12``, time
``planner.predict.feasibility.feasible_modes`` (all eq. 49 candidates, batched eqs. 23-28) and a
straightforward per-mode Python loop (one ``numpy.linalg.solve`` per candidate and stage),
both in the same run, and report time per configuration and their ratio.

    PYTHONPATH=. python benchmarks/bench_modes.py --out benchmarks/results/bench_modes.json

Writes JSON (atomic) and prints a table.  Timings are medians over ``--repeat`` runs.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from statistics import median

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planner.files.atomic import atomic_write_json  # noqa: E402
from planner.model.modes import BREAK, ROLL, SLIDE, Mode, enumerate_modes  # noqa: E402
from planner.predict.feasibility import feasible_modes
from planner.predict.stages import DEFAULT_TOL  # noqa: E402
from planner.sweeps.random_systems import random_system  # noqa: E402


def per_mode_loop(system, mu=None, codes=None, tol: float = DEFAULT_TOL) -> list[str]:
    """The straightforward method: loop over candidates, solve eq. (24) then eq. (26) per mode.

    ``codes`` (M, n_c) restricts the loop to some candidates (default: all of eq. 49).
    Returns the labels of the feasible modes (determinate ones, candidate order).
    """
    mu = system.mu if mu is None else np.asarray(mu, dtype=float)
    n_c = system.n_contacts
    E, V = system.effort_joints, system.velocity_joints
    K = np.concatenate([system.W.T, -system.J[:, E]], axis=1)
    G = np.concatenate([system.W.T, system.J[:, E]], axis=1)
    b = system.J[:, V] @ system.joint_inputs[V]
    scale = float(np.max(np.abs(b))) or 1.0
    rhs_f = np.concatenate([-system.g_obj, system.joint_inputs[E] - system.g_man[E]])
    if codes is None:
        codes = enumerate_modes(n_c, system.dof).codes
    out = []
    for code in codes:
        r_set = [i for i in range(n_c) if code[i] == ROLL]
        s_set = [i for i in range(n_c) if code[i] == SLIDE]
        rows = [2 * i for i in r_set] + [2 * i + 1 for i in r_set] + [2 * i for i in s_set]
        P = K[rows]
        try:
            z = np.linalg.solve(P, b[rows])
        except np.linalg.LinAlgError:
            continue
        v = K @ z - b
        ok, xi = True, [0] * n_c
        for i in range(n_c):
            if code[i] == BREAK and v[2 * i] <= tol * scale:
                ok = False
            elif code[i] == SLIDE:
                if abs(v[2 * i + 1]) <= tol * scale:
                    ok = False
                xi[i] = 1 if v[2 * i + 1] > 0 else -1
        if not ok:
            continue
        QT = G[rows].copy()
        for j, i in enumerate(s_set):
            QT[len(r_set) * 2 + j] -= mu[i] * xi[i] * G[2 * i + 1]
        try:
            c = np.linalg.solve(QT.T, rhs_f)
        except np.linalg.LinAlgError:
            continue
        f_scale = float(np.max(np.abs(c))) or 1.0
        n_r = len(r_set)
        for j, i in enumerate(r_set):
            if mu[i] * c[j] - abs(c[n_r + j]) < -tol * f_scale:
                ok = False
        for j in range(len(s_set)):
            if c[2 * n_r + j] < -tol * f_scale:
                ok = False
        if ok:
            out.append(Mode(tuple(int(x) for x in code), tuple(xi)).label)
    return out


def timed(fn, repeat: int):
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return median(times), result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nc", default="3-12", help="range of n_c, e.g. 3-12")
    ap.add_argument("--seeds", type=int, default=3, help="random systems per n_c")
    ap.add_argument("--repeat", type=int, default=3, help="timing repeats (median)")
    ap.add_argument("--loop-max-nc", type=int, default=12, help="largest n_c for the loop")
    ap.add_argument("--out", default="benchmarks/results/bench_modes.json")
    args = ap.parse_args(argv)
    load_start = os.getloadavg()  # other jobs on the machine inflate absolute times
    lo, hi = (int(x) for x in args.nc.split("-"))
    rows = []
    print(f"{'n_c':>4} {'candidates':>10} {'batched [s]':>12} {'loop [s]':>10} {'ratio':>7} agree")
    for n_c in range(lo, hi + 1):
        enumerate_modes(n_c, n_c)  # build the cached candidate set outside the timing
        for seed in range(args.seeds):
            system = random_system(seed, n_c)
            t_b, pred = timed(
                lambda s=system: feasible_modes(s, indeterminate=False), args.repeat
            )
            row = {"n_contacts": n_c, "seed": seed, "candidates": pred.candidates,
                   "batched_s": t_b, "modes": pred.labels}
            if n_c <= args.loop_max_nc:
                t_l, labels = timed(lambda s=system: per_mode_loop(s), 1)
                row.update(loop_s=t_l, loop_over_batched=t_l / t_b,
                           loop_agrees=labels == pred.labels)
            rows.append(row)
            nan = float("nan")
            print(f"{n_c:>4} {pred.candidates:>10} {t_b:>12.4f} {row.get('loop_s', nan):>10.3f}"
                  f" {row.get('loop_over_batched', nan):>7.1f} {row.get('loop_agrees')}")
    out = {
        "benchmark": "bench_modes",
        "command": "PYTHONPATH=. python benchmarks/bench_modes.py " + " ".join(sys.argv[1:]),
        "load_average_1_5_15": {"start": list(load_start), "end": list(os.getloadavg())},
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "cpus": os.cpu_count(), "numpy": np.__version__},
        "rows": rows,
    }
    atomic_write_json(args.out, out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
