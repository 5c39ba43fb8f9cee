"""Benchmark: every feasible mode of n_b = 3 workpieces with n_c = 12 contacts.

Seeded random multi-body systems (``planner.sweeps.random_systems.random_multibody_system``:
three random polygons, 12 contacts, about 40 % of them between two workpieces, two
velocity-controlled joints, planted loads), so ``2 n_R + n_S = 3 n_b = 9`` and eq. (49) gives
43,252 candidate modes. Per system, each on a fresh System object (no per-system cache reused):

* ``exhaustive``: ``feasible_modes(system, indeterminate=False)``: every eq. (49) candidate
  through both stages;
* ``search``: ``search_modes(system)`` (the pruned search, same determinate modes);
* ``complete``: ``feasible_modes(system, indeterminate=True)``: the eq. (49) candidates and the
  relaxed-utility (force-indeterminate) modes: the ``k``-row subsets of ``C(24, 9) =
  1,307,504`` that pass the structural pre-filter (:mod:`planner.predict.row_subsets`) scanned.

To compare with an older checkout, run this script with that checkout on ``PYTHONPATH``
right before or after (same load).

Target: all modes <= 1 s. The load average is printed before and after (the machine
is shared; absolute times move with it).

    PYTHONPATH=. python benchmarks/bench_multibody.py [--seeds 10] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from statistics import median

from planner.predict.feasibility import feasible_modes
from planner.predict.search import search_modes
from planner.sweeps.random_systems import random_multibody_system


def timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--bodies", type=int, default=3)
    ap.add_argument("--contacts", type=int, default=12)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    rows = []
    for seed in range(args.seeds):
        make = (seed, args.bodies, args.contacts)  # a fresh System per call: no cache reused
        ex, t_ex = timed(feasible_modes, random_multibody_system(*make), indeterminate=False)
        se, t_se = timed(search_modes, random_multibody_system(*make))
        co, t_co = timed(feasible_modes, random_multibody_system(*make), indeterminate=True)
        same = sorted(m.label for m in ex.modes) == sorted(m.label for m in se.prediction.modes)
        rows.append({"seed": seed, "candidates": ex.candidates, "exhaustive_s": t_ex,
                     "search_s": t_se, "complete_s": t_co, "search_agrees": same,
                     "complete": co.complete, "status": co.status.value,
                     "modes": co.labels})
        print(f"seed {seed}: {ex.candidates} candidates  exhaustive {t_ex:.3f} s  "
              f"search {t_se:.3f} s (agrees: {same})  complete {t_co:.3f} s  "
              f"{co.status.value} {co.labels}", flush=True)
    load1 = os.getloadavg()[0]
    summary = {key: {"median": median(r[key] for r in rows), "max": max(r[key] for r in rows)}
               for key in ("exhaustive_s", "search_s", "complete_s")}
    print(f"n_b = {args.bodies}, n_c = {args.contacts}, {args.seeds} seeds; load "
          f"{load0:.1f} -> {load1:.1f}")
    for key, v in summary.items():
        print(f"  {key:13s} median {v['median']:.3f} s  max {v['max']:.3f} s")
    if args.out:
        args.out.write_text(json.dumps({"load": [load0, load1], "summary": summary,
                                        "rows": rows}, indent=1))
    return 0 if all(r["search_agrees"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
