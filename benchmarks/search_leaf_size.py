"""Leaf size of the exact search: CPU time of ``search_modes`` for several ``batch_size /
lp_min_size`` pairs on the same seeded random systems, one engine.

How the native engine's defaults (8 / 4, ``planner.predict.search.NATIVE_BATCH_SIZE``) were
chosen: on seeds ``bench_latency.py`` does not use (it uses 0-9), docs/scaling.md ("The
native core").

    PYTHONPATH=. python benchmarks/search_leaf_size.py --n-c 20 --seeds 10-19 \\
        --sizes 128/64,32/16,16/8,8/4 [--engine native]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planner.predict.search import search_modes  # noqa: E402
from planner.sweeps.random_systems import random_system  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n-c", type=int, default=20)
    ap.add_argument("--seeds", default="10-19", help="LO-HI or a,b,c")
    ap.add_argument("--sizes", default="128/64,32/16,16/8,8/4", help="batch/lp_min pairs")
    ap.add_argument("--engine", default="native", choices=["native", "python"])
    args = ap.parse_args(argv)
    if "-" in args.seeds:
        lo, hi = (int(v) for v in args.seeds.split("-"))
        seeds = list(range(lo, hi + 1))
    else:
        seeds = [int(v) for v in args.seeds.split(",")]
    sizes = [tuple(int(v) for v in pair.split("/")) for pair in args.sizes.split(",")]
    search_modes(random_system(0, 6), engine=args.engine)  # warm-up (and the native build)
    total = dict.fromkeys(sizes, 0.0)
    worst = dict.fromkeys(sizes, 0.0)
    for seed in seeds:
        system = random_system(seed, args.n_c)
        cells = []
        for batch, lp_min in sizes:
            t0 = time.process_time()
            res = search_modes(system, indeterminate=False, batch_size=batch,
                               lp_min_size=lp_min, engine=args.engine)
            dt = time.process_time() - t0
            total[(batch, lp_min)] += dt
            worst[(batch, lp_min)] = max(worst[(batch, lp_min)], dt)
            cells.append(f"{batch}/{lp_min}: {dt:.2f} s, {res.stats.lp_solves} LPs, "
                         f"{res.stats.tested} tested")
        print(f"seed {seed}: " + " | ".join(cells), flush=True)
    for key in sizes:
        print(f"{key[0]}/{key[1]}: total {total[key]:.2f} s CPU, worst {worst[key]:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
