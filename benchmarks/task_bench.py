"""Benchmark: planning the whole two-finger task of Figure 9 (target <= 10 s).

Times :func:`planner.plan.hand_planner.plan_hand` on ``scenarios/data/figure9_task_hand.json``
(the best-first search over chains of guaranteed segments, every region over mu in [0, 0.2])
and, in the same run, the single first segment (``plan_hand``) for scale.  Records the machine
load.  Writes benchmarks/results/task_bench.json.

    python3 benchmarks/task_bench.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from pathlib import Path

from planner.files.atomic import atomic_write_json
from planner.plan.hand_planner import plan_hand
from scenarios.registry import DATA_DIR


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    task, seg = [], []
    plan = None
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        plan = plan_hand(DATA_DIR / "figure9_task_hand.json")
        task.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        plan_hand(DATA_DIR / "two_finger_hand.json", waypoints=21)
        seg.append(time.perf_counter() - t0)
    if plan is None:
        raise SystemExit("--repeats: expected >= 1")
    out = {
        "task_seconds": task, "task_median_s": statistics.median(task),
        "one_segment_seconds": seg, "ratio_task_to_segment": statistics.median(task)
        / statistics.median(seg),
        "reached": plan.reached, "segments": len(plan.segments),
        "expansions": plan.extra["expansions"],
        "segments_integrated": plan.extra["segments_integrated"],
        "target_s": 10.0, "load_1min": os.getloadavg()[0], "python": platform.python_version(),
    }
    path = Path(__file__).parent / "results" / "task_bench.json"
    atomic_write_json(path, out)
    print(f"whole task: median {out['task_median_s']:.2f} s over {args.repeats} "
          f"(target 10 s; {out['segments']} segments, reached {out['reached']}); one segment "
          f"{statistics.median(seg):.2f} s; load {out['load_1min']:.1f}; -> {path}")


if __name__ == "__main__":
    main()
