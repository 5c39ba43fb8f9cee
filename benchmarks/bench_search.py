"""Benchmark: exact pruned search vs exhaustive batched enumeration vs a per-mode loop.

On seeded random systems (``planner.sweeps.random_systems``, ``|tau_I| = n_c - 3``, planted loads)
with ``n_c = 3..20``: time per configuration of :func:`planner.predict.search.search_modes`, the eq.
(49) candidate count vs the candidates actually tested, and ratios against

(a) exhaustive batched enumeration (``planner.predict.feasibility.feasible_modes``; for
    ``n_c > --exhaustive-max`` the time is *extrapolated* from a timed chunk of
    ``--sample`` candidates run through the same batched stages), and
(b) a per-mode loop (``bench_modes.per_mode_loop``; timed on ``--sample`` random candidates and
    extrapolated to all candidates when ``n_c > --loop-max``),

all measured in the same run.  Exactness: the search's modes are compared with exhaustive
enumeration for ``n_c <= --check-max`` (chunked through the executor above
``--exhaustive-max``; ``--dask tcp://host:8786`` sends the chunks to a Dask scheduler).

    PYTHONPATH=. python benchmarks/bench_search.py --out benchmarks/results/bench_search.json
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
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_modes import per_mode_loop  # noqa: E402

from planner.files.atomic import atomic_write_json  # noqa: E402
from planner.model.modes import candidate_count, enumerate_modes  # noqa: E402
from planner.predict.feasibility import feasible_modes
from planner.predict.search import candidates_from_codes, canonical_order, search_modes  # noqa: E402
from planner.predict.stages import force_stage, kinematic_stage  # noqa: E402
from planner.sweeps.executor import enumerate_modes_slice, exhaustive_modes, make_executor  # noqa: E402
from planner.sweeps.random_systems import random_system  # noqa: E402


def sample_codes(n_c: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """``size`` candidate codes of eq. (49) at random positions (for extrapolated timings)."""
    total = candidate_count(n_c, n_c)
    if total <= size:
        return enumerate_modes_slice(n_c, n_c, 0, total)
    start = int(rng.integers(0, total - size))
    return enumerate_modes_slice(n_c, n_c, start, start + size)


def batched_time_per_candidate(system, codes: np.ndarray) -> float:
    cand = candidates_from_codes(canonical_order(codes), system.dof)
    t0 = time.perf_counter()
    kin = kinematic_stage(system, cand)
    idx = np.flatnonzero(kin.ok)
    force_stage(system, cand, idx, kin.xi[idx], system.mu)
    return (time.perf_counter() - t0) / len(codes)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nc", default="3-20", help="range of n_c, e.g. 3-20")
    ap.add_argument("--seeds", type=int, default=3, help="random systems per n_c")
    ap.add_argument("--exhaustive-max", type=int, default=12,
                    help="largest n_c timed with feasible_modes in one batch")
    ap.add_argument("--loop-max", type=int, default=10, help="largest n_c with a full loop")
    ap.add_argument("--check-max", type=int, default=14,
                    help="largest n_c whose modes are checked against exhaustive enumeration")
    ap.add_argument("--sample", type=int, default=20_000, help="candidates for extrapolation")
    ap.add_argument("--dask", default=None, help="Dask scheduler address for chunked checks")
    ap.add_argument("--first-seed", type=int, default=0, help="seeds first-seed .. + seeds - 1")
    ap.add_argument("--workers", type=int, default=None, help="local worker processes")
    ap.add_argument("--search-workers", type=int, default=1,
                    help="also time search_modes with subtrees on this many local processes")
    ap.add_argument("--parallel-min", type=int, default=17,
                    help="smallest n_c timed with --search-workers")
    ap.add_argument("--relaxation", default="auto", choices=["auto", "coupled", "forces"],
                    help="pruning LP of search_modes (default auto)")
    ap.add_argument("--compare-forces", action="store_true",
                    help="also time the forces-only relaxation in the same run (A/B)")
    ap.add_argument("--out", default="benchmarks/results/bench_search.json")
    args = ap.parse_args(argv)
    load_start = os.getloadavg()  # other jobs on the machine inflate absolute times
    lo, hi = (int(x) for x in args.nc.split("-"))
    executor = make_executor(args.dask, args.workers)
    search_pool = make_executor(workers=args.search_workers)
    rng = np.random.default_rng(0)
    rows = []
    search_modes(random_system(0, 6))  # warm-up: imports and HiGHS initialisation
    head = (f"{'n_c':>4} {'seed':>4} {'candidates':>11} {'tested':>8} {'LPs':>6} {'search[s]':>9}"
            f" {'exh[s]':>9} {'exh/srch':>8} {'loop[s]':>9} {'loop/srch':>9} {'modes':>5} exact")
    print(head)
    try:
        for n_c in range(lo, hi + 1):
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                system = random_system(seed, n_c)
                t0 = time.perf_counter()
                res = search_modes(system, indeterminate=False, relaxation=args.relaxation)
                t_s = time.perf_counter() - t0
                n_cand = res.stats.candidates
                row = {"n_contacts": n_c, "seed": seed, "search_s": t_s,
                       "modes": res.prediction.labels, **res.stats.to_dict()}
                if args.compare_forces:
                    t0 = time.perf_counter()
                    alt = search_modes(system, indeterminate=False, relaxation="forces")
                    row["forces_only"] = {"search_s": time.perf_counter() - t0,
                                          "same_modes": alt.prediction.labels
                                          == res.prediction.labels, **alt.stats.to_dict()}
                if args.search_workers > 1 and n_c >= args.parallel_min:
                    t0 = time.perf_counter()
                    par = search_modes(system, indeterminate=False, executor=search_pool,
                                       relaxation=args.relaxation)
                    row["search_parallel_s"] = time.perf_counter() - t0
                    row["search_workers"] = args.search_workers
                    row["parallel_same_modes"] = par.prediction.labels == res.prediction.labels
                # (a) exhaustive batched enumeration
                exhaustive_labels = None
                if n_c <= args.exhaustive_max:
                    enumerate_modes(n_c, system.dof)  # cached candidate set: built untimed
                    t0 = time.perf_counter()
                    pred = feasible_modes(system, indeterminate=False)
                    row["exhaustive_s"] = time.perf_counter() - t0
                    row["exhaustive_measured"] = True
                    exhaustive_labels = pred.labels
                else:
                    per = batched_time_per_candidate(system, sample_codes(n_c, args.sample, rng))
                    row["exhaustive_s"] = per * n_cand
                    row["exhaustive_measured"] = False
                    if n_c <= args.check_max:
                        exhaustive_labels = exhaustive_modes(system, executor, progress=True)
                # (b) per-mode loop
                if n_c <= args.loop_max:
                    t0 = time.perf_counter()
                    per_mode_loop(system)
                    row["loop_s"] = time.perf_counter() - t0
                    row["loop_measured"] = True
                else:
                    codes = sample_codes(n_c, min(args.sample, 5000), rng)
                    t0 = time.perf_counter()
                    per_mode_loop(system, codes=codes)
                    row["loop_s"] = (time.perf_counter() - t0) / len(codes) * n_cand
                    row["loop_measured"] = False
                row["exhaustive_over_search"] = row["exhaustive_s"] / t_s
                row["loop_over_search"] = row["loop_s"] / t_s
                if exhaustive_labels is not None:
                    row["exact"] = exhaustive_labels == res.prediction.labels
                rows.append(row)
                ex_mark = "" if row["exhaustive_measured"] else "~"
                lp_mark = "" if row["loop_measured"] else "~"
                print(f"{n_c:>4} {seed:>4} {n_cand:>11} {res.stats.tested:>8} "
                      f"{res.stats.lp_solves:>6} {t_s:>9.3f} "
                      f"{ex_mark:>1}{row['exhaustive_s']:>8.2f}"
                      f" {row['exhaustive_over_search']:>8.1f} {lp_mark:>1}{row['loop_s']:>8.1f}"
                      f" {row['loop_over_search']:>9.0f} {len(res.prediction.labels):>5}"
                      f" {row.get('exact', '-')}"
                      + (f"  parallel {row['search_parallel_s']:.3f}s"
                         if "search_parallel_s" in row else "")
                      + (f"  forces-only {row['forces_only']['search_s']:.3f}s"
                         f" ({row['forces_only']['tested']} tested)"
                         if "forces_only" in row else ""), flush=True)
    finally:
        executor.close()
        search_pool.close()
    summary = []
    for n_c in range(lo, hi + 1):
        sel = [r for r in rows if r["n_contacts"] == n_c]
        summary.append({
            "n_contacts": n_c,
            "candidates": sel[0]["candidates"],
            "median_tested": median(r["tested"] for r in sel),
            "median_search_s": median(r["search_s"] for r in sel),
            "max_search_s": max(r["search_s"] for r in sel),
            "median_search_parallel_s": median(r["search_parallel_s"] for r in sel)
            if all("search_parallel_s" in r for r in sel) else None,
            "max_search_parallel_s": max(r["search_parallel_s"] for r in sel)
            if all("search_parallel_s" in r for r in sel) else None,
            "median_lp_solves": median(r["lp_solves"] for r in sel),
            "max_forces_only_s": max(r["forces_only"]["search_s"] for r in sel)
            if all("forces_only" in r for r in sel) else None,
            "median_exhaustive_over_search": median(r["exhaustive_over_search"] for r in sel),
            "median_loop_over_search": median(r["loop_over_search"] for r in sel),
            "exact": all(r.get("exact", True) for r in sel)
            if any("exact" in r for r in sel) else None,
        })
    out = {
        "benchmark": "bench_search",
        "command": "PYTHONPATH=. python benchmarks/bench_search.py " + " ".join(sys.argv[1:]),
        "load_average_1_5_15": {"start": list(load_start), "end": list(os.getloadavg())},
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "cpus": os.cpu_count(), "numpy": np.__version__},
        "relaxation": args.relaxation,
        "note": "'~' / *_measured = false: extrapolated from a timed sample of candidates",
        "summary": summary,
        "rows": rows,
    }
    atomic_write_json(args.out, out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
