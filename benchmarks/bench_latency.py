"""Benchmark: mode prediction is correct at any size and fast inside a planning loop.

Measures in one run, with the machine's load average before and after (other jobs inflate
absolute times; the ratios are measured in the same run):

* ``latency``: one ``feasible_modes`` call (relaxed utility included) on seeded random systems
  (``planner.sweeps.random_systems``, ``3 + |tau_I| = n_c``) at ``n_c = 4`` and ``8``, each call
  on a fresh System object (no per-system cache reused), against a batched
  ``numpy.linalg.solve`` of as many ``n_c x n_c`` systems as the call has candidates (target:
  within 20x), the two timed in alternating blocks of :data:`BLOCK` calls (warm loops, and a
  burst of other work slows both sides of the ratio);
* ``batch``: ``feasible_modes_batch`` against a loop of single calls over 1,000 waypoints of
  the two-finger segment (target: >= 10x), and that both give the same predictions;
* ``map``: ``mu_grid`` 200 x 200 of a box on a table with force-indeterminate modes
  (target: <= 3 s);
* ``boxes``: boxes on 8 and 12 supports pushed low by one finger (expected: the sliding mode,
  never jammed);
* ``search`` (with ``--search``): ``search_modes`` at ``n_c = 20`` (``--search-nc 20,24``) on
  ten seeded systems, serial, one process per system with a timeout (the latency targets: worst
  of ten at ``n_c = 20`` <= 10 s, median at 24 <= 60 s), with the native core and with the
  Python engine on the same system one after the other (``--search-engines``,
  ``--engine-seeds``); ``--search-baseline DIR`` times another checkout (e.g. ``git worktree
  add /tmp/old <commit>``) on the same system right before, in the same run.

    PYTHONPATH=. python benchmarks/bench_latency.py [--search] [--out FILE]
    PYTHONPATH=. python benchmarks/bench_latency.py --only-search --search-nc 20 \\
        --search-baseline /tmp/old --out benchmarks/results/bench_latency_search.json
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import platform
import sys
import time
from pathlib import Path
from statistics import median

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planner.files.atomic import atomic_write_json  # noqa: E402
from planner.friction.muspace import mu_grid  # noqa: E402
from planner.model.modes import candidate_count  # noqa: E402
from planner.model.system import System  # noqa: E402
from planner.predict.batch import feasible_modes_batch  # noqa: E402
from planner.predict.feasibility import feasible_modes  # noqa: E402
from planner.sweeps.random_systems import random_system  # noqa: E402

#: Timed calls per block of the latency measurement (the two sides alternate by blocks).
BLOCK = 20


def latency(seeds: int, repeat: int) -> list[dict]:
    rows = []
    for n_c in (4, 8):
        for seed in range(seeds):
            system = random_system(seed, n_c)
            feasible_modes(system)  # warm-up (imports, enumerate_modes cache)
            fresh = [copy.copy(system) for _ in range(repeat)]
            m = candidate_count(n_c, system.dof)
            rng = np.random.default_rng(seed)
            A, b = rng.normal(size=(m, n_c, n_c)), rng.normal(size=(m, n_c, 1))
            np.linalg.solve(A, b)
            # Blocks of BLOCK calls of each side in turn (warm loops, as a planner's; a burst of
            # other work on the machine slows both sides of the ratio, not one).
            times, solve = [], []
            for start in range(0, repeat, BLOCK):
                block = fresh[start:start + BLOCK]
                for s in block:
                    t0 = time.perf_counter()
                    pred = feasible_modes(s)
                    times.append(time.perf_counter() - t0)
                for _ in block:
                    t0 = time.perf_counter()
                    np.linalg.solve(A, b)
                    solve.append(time.perf_counter() - t0)
            t, ts = median(times), median(solve)
            rows.append({"n_c": n_c, "seed": seed, "candidates": m, "predict_s": t,
                         "batched_solve_s": ts, "ratio": t / ts, "complete": pred.complete,
                         "modes": pred.labels})
            print(f"latency n_c={n_c} seed={seed}: {1e3 * t:.3f} ms vs solve {1e3 * ts:.4f} ms "
                  f"({t / ts:.1f}x)")
    return rows


def two_finger_systems(n: int) -> list[System]:
    from planner.files.hand_file import load_hand
    from planner.plan.trajectory import integrate_segment
    from scenarios.registry import shipped_file

    hand, q0, data = load_hand(shipped_file("two_finger_hand"))
    spec = data["segment"]
    seg = integrate_segment(hand, q0, drive=spec["drive"], speed=spec["speed"],
                            mode=spec["mode"], max_time=spec["max_time"]).resample(hand, n)
    return [hand.system(seg.q[i], 0.1, [{"effort": 0.0},
                                        {"velocity": float(seg.thetadot[i, 1])}])
            for i in range(n)]


def batch(n: int, repeat: int) -> dict:
    systems = two_finger_systems(n)
    loop_t, batch_t = [], []
    for _ in range(repeat):
        fresh = [copy.copy(s) for s in systems]
        t0 = time.perf_counter()
        single = [feasible_modes(s) for s in fresh]
        loop_t.append(time.perf_counter() - t0)
        fresh = [copy.copy(s) for s in systems]
        t0 = time.perf_counter()
        many = feasible_modes_batch(fresh)
        batch_t.append(time.perf_counter() - t0)
    same = all(a.labels == b.labels and a.status == b.status for a, b in zip(single, many))
    lt, bt = median(loop_t), median(batch_t)
    print(f"batch {n} waypoints: loop {lt:.3f} s, batch {bt:.3f} s ({lt / bt:.1f}x), same {same}")
    return {"waypoints": n, "loop_s": lt, "batch_s": bt, "ratio": lt / bt, "same": same}


def box(mu, h: float, load, push=(0.01, 0.0)) -> System:
    return System.from_contacts(
        points=[[-0.5, 0.0], [0.5, 0.0], [-0.5, h]], normals=[[0, 1], [0, 1], [1, 0]], mu=mu,
        external_wrench=load, contact_velocities=[[0, 0], [0, 0], list(push)])


def maps(n: int) -> list[dict]:
    cases = [
        ("box pushed low, S-1 S-2 R3 everywhere", 0.1, (0.0, -1.0, 0.0), (0.01, 0.0),
         [0.3, 0.3, 0.2], (0, 1)),
        ("box pushed, S-1 S-2 R3 on part of the map", 0.515, (0.261, -1.0, -0.339),
         (0.01, 0.0), [0.291, 0.541, 0.388], (0, 1)),
        ("box at rest under a side load, R1 R2 B3 (rolling: up-set)", 0.5, (0.3, -1.0, 0.0),
         (-0.01, 0.0), [0.3, 0.3, 0.2], (0, 1)),
    ]
    out = []
    for name, h, load, push, base, vary in cases:
        system = box(base, h, load, push)
        t0 = time.perf_counter()
        grid = mu_grid(system, vary, base, (0.0, 1.0), n=n)
        dt = time.perf_counter() - t0
        frac = {lab: float(grid.feasible[:, i].mean()) for i, lab in enumerate(grid.labels)}
        print(f"map {n}x{n} {name}: {dt:.3f} s, {frac}")
        out.append({"case": name, "grid": [n, n], "seconds": dt, "fractions": frac})
    return out


def boxes() -> list[dict]:
    out = []
    for n_s in (8, 12):
        xs = np.linspace(-1.0, 1.0, n_s)
        system = System.from_contacts(
            points=[[x, 0.0] for x in xs] + [[-1.0, 0.1]],
            normals=[[0.0, 1.0]] * n_s + [[1.0, 0.0]], mu=0.5,
            external_wrench=[0.0, -1.0, 0.0],
            contact_velocities=[[0.0, 0.0]] * n_s + [[0.01, 0.0]])
        t0 = time.perf_counter()
        pred = feasible_modes(system)
        dt = time.perf_counter() - t0
        print(f"box on {n_s} supports pushed low: {pred.status.value} {pred.labels} "
              f"({1e3 * dt:.1f} ms, complete {pred.complete})")
        out.append({"supports": n_s, "status": pred.status.value, "modes": pred.labels,
                    "seconds": dt, "complete": pred.complete})
    return out


#: Child process of :func:`search`: one system, wall and CPU time, statistics, modes (JSON).
#: Imports both package layouts, so a checkout of an older version can be the baseline.
_SEARCH_CHILD = """
import json, os, sys, time
try:
    from planner.predict.search import search_modes
    from planner.sweeps.random_systems import random_system
except ImportError:
    from planner.search import search_modes
    from planner.random_systems import random_system
kw = {"engine": sys.argv[3]} if sys.argv[3] != "default" else {}
search_modes(random_system(0, 6), **kw)  # warm-up: imports, HiGHS, the native core's build
system = random_system(int(sys.argv[2]), int(sys.argv[1]))
t0, c0 = time.perf_counter(), time.process_time()
res = search_modes(system, indeterminate=False, **kw)
print(json.dumps({"seconds": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
                  "modes": res.prediction.labels, **res.stats.to_dict()}))
"""


def search(n_cs: list[int], seeds: int, timeout: float, baseline: str | None,
           engines: list[str], engine_seeds: int | None = None) -> list[dict]:
    """``search_modes`` on ``seeds`` random systems per ``n_c``, serial, one process per system
    (BLAS on one thread), killed after ``timeout`` s, once per engine in ``engines`` (the
    native core, the Python engine: the same system right after each other, in the same run;
    engines after the first only on the first ``engine_seeds`` seeds); with ``baseline`` (the
    root of another checkout) the same system is searched by that version right before."""
    import subprocess

    here = str(Path(__file__).resolve().parents[1])
    versions = ([("baseline", baseline, "default")] if baseline else []) + [
        (e if len(engines) > 1 else "this", here, e) for e in engines]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1"}
    out = []
    for n_c in n_cs:
        for seed in range(seeds):
            row: dict = {"n_c": n_c, "seed": seed}
            for j, (name, root, engine) in enumerate(versions):
                if engine_seeds is not None and seed >= engine_seeds and j > 0:
                    continue
                try:
                    proc = subprocess.run(
                        [sys.executable, "-c", _SEARCH_CHILD, str(n_c), str(seed), engine],
                        cwd=root,
                        env={**env, "PYTHONPATH": root}, capture_output=True, text=True,
                        timeout=timeout, check=True)
                    res = json.loads(proc.stdout.strip().splitlines()[-1])
                except subprocess.TimeoutExpired:
                    res = {"timeout_s": timeout}
                except subprocess.CalledProcessError as err:
                    res = {"error": err.stderr.strip().splitlines()[-1:]}
                res["load_1min"] = os.getloadavg()[0]
                row[name] = res
                print(f"search n_c={n_c} seed={seed} {name}: "
                      + (f"{res['seconds']:.2f} s (CPU {res['cpu_s']:.2f} s), "
                         f"{res['lp_solves']} LPs, engine {res.get('engine', '-')}"
                         if "seconds" in res
                         else f"failed: {res['error']}" if "error" in res
                         else f"over {timeout:.0f} s") + f", load {res['load_1min']:.1f}",
                      flush=True)
            runs = [row[name] for name, _, _ in versions if "modes" in row.get(name, {})]
            if len(runs) > 1:
                row["same_modes"] = all(r["modes"] == runs[0]["modes"] for r in runs)
            out.append(row)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5, help="random systems per n_c (latency)")
    ap.add_argument("--repeat", type=int, default=30, help="timing repeats (median)")
    ap.add_argument("--waypoints", type=int, default=1000)
    ap.add_argument("--map-n", type=int, default=200)
    ap.add_argument("--search", action="store_true", help="also the n_c = 20 search (slow)")
    ap.add_argument("--search-nc", default="20", help="n_c values of --search, e.g. 20,24")
    ap.add_argument("--search-seeds", type=int, default=10)
    ap.add_argument("--search-timeout", type=float, default=300.0, help="per system [s]")
    ap.add_argument("--search-baseline", default=None,
                    help="root of another checkout, timed alternately in the same run")
    ap.add_argument("--search-engines", default="native,python",
                    help="engines of search_modes to time on the same systems (first: all "
                    "seeds; the others: --engine-seeds)")
    ap.add_argument("--engine-seeds", type=int, default=None,
                    help="seeds on which the engines after the first are timed too")
    ap.add_argument("--only-search", action="store_true", help="skip the other parts")
    ap.add_argument("--out", default="benchmarks/results/bench_latency.json")
    args = ap.parse_args(argv)
    load_start = os.getloadavg()
    out: dict = {
        "benchmark": "bench_latency",
        "command": "PYTHONPATH=. python benchmarks/bench_latency.py " + " ".join(sys.argv[1:]),
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "cpus": os.cpu_count(), "numpy": np.__version__},
    }
    if not args.only_search:
        out["latency"] = latency(args.seeds, args.repeat)
        out["batch"] = batch(args.waypoints, 3)
        out["map"] = maps(args.map_n)
        out["boxes"] = boxes()
    if args.search or args.only_search:
        out["search"] = search([int(x) for x in args.search_nc.split(",")], args.search_seeds,
                               args.search_timeout, args.search_baseline,
                               args.search_engines.split(","), args.engine_seeds)
    out["load_average_1_5_15"] = {"start": list(load_start), "end": list(os.getloadavg())}
    print(f"load average at start {load_start}, at end {os.getloadavg()}")
    atomic_write_json(args.out, out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
