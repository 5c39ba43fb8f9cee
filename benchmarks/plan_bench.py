"""Benchmark: planning the two-finger segment with uncertain-friction torque bounds.

Measures, in one run: the full planner (`plan_hand`: trajectory, both control partitions,
exact bounds over mu in [0, 0.2], Figure 10-13 curves) and, per waypoint, the exact guaranteed
band against the paper's method (intersection of 21 sampled coefficients 0, 0.01, ..., 0.2).
Writes benchmarks/results/plan_bench.json.  Target: planning <= 5 s.

    python3 benchmarks/plan_bench.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from pathlib import Path

import numpy as np

from planner.files.atomic import atomic_write_json
from planner.files.hand_file import load_hand
from planner.plan.bounds import intervals, mode_rows
from planner.plan.guarantee import guarantee
from planner.plan.hand_planner import plan_hand
from planner.plan.trajectory import integrate_segment
from scenarios.registry import DATA_DIR


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    times = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        plan = plan_hand(DATA_DIR / "two_finger_hand.json", mu=(0.0, 0.2)).segments[0]
        times.append(time.perf_counter() - t0)
    hand, q0, data = load_hand(DATA_DIR / "two_finger_hand.json")
    seg_spec = data["segment"]
    t0 = time.perf_counter()
    seg = integrate_segment(hand, q0, drive=seg_spec["drive"], speed=seg_spec["speed"],
                            mode=seg_spec["mode"], max_time=seg_spec["max_time"])
    t_traj = time.perf_counter() - t0
    seg = seg.resample(hand, 41)
    t_exact, t_sampled, diffs = [], [], []
    mus = np.round(np.arange(0.0, 0.2001, 0.01), 10)
    for k in range(len(seg.t)):
        system = hand.system(seg.q[k], 0.0, [{"effort": 0.0},
                                             {"velocity": float(seg.thetadot[k, 1])}])
        t0 = time.perf_counter()
        g = guarantee(system, "4S", (0.0, 0.2))
        t_exact.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rows = mode_rows(system, np.repeat(mus[:, None], 4, 1))
        lo, hi = intervals(rows)
        j = [m.label for m in rows.modes].index(g.claim)
        s_lo, s_hi = float(lo[:, j].max()), float(hi[:, j].min())
        t_sampled.append(time.perf_counter() - t0)
        band = g.claim_band.guaranteed
        diffs.append(max(band.lower - s_lo, s_hi - band.upper))
    out = {
        "machine": platform.platform(), "python": platform.python_version(),
        "plan_seconds_median": statistics.median(times), "plan_seconds_all": times,
        "waypoints": len(plan.waypoints), "trajectory_seconds": t_traj,
        "exact_band_ms_per_waypoint": 1e3 * statistics.median(t_exact),
        "sampled_21_band_ms_per_waypoint": 1e3 * statistics.median(t_sampled),
        "exact_over_sampled_time_ratio": statistics.median(t_exact) / statistics.median(t_sampled),
        "exact_minus_sampled_tightening_Nm_max": float(max(diffs)),
        "exact_never_looser": bool(min(diffs) >= -1e-12),
        "target_plan_seconds": 5.0,
    }
    path = Path(__file__).resolve().parent / "results" / "plan_bench.json"
    atomic_write_json(path, out)
    for k, v in out.items():
        print(f"{k:40s} {v}")


if __name__ == "__main__":
    main()
