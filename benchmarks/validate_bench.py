"""Benchmark: plan the two-finger hand segment with uncertain-mu torque bounds, then
validate the plan in pymunk and MuJoCo; writes ``benchmarks/results/validate_bench.json``.

Reports the best of 3 wall times of :func:`planner.plan.hand_planner.plan_hand` (mu in [0, 0.2],
exact bounds; target <= 5 s), and per engine and per ``mu.validate`` value the wall time of
:func:`scenarios.runs.validate_plan` on the full segment without drawing (target: one plan validated
in both engines <= 60 s), with the simulated-seconds-per-wall-second ratio and the outcome
(claimed-mode fraction, final position error / travel), all measured in the same run.

Run: ``PYTHONPATH=. python benchmarks/validate_bench.py [--mu 0.1]``
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

from planner.files.atomic import atomic_write_json
from planner.plan.hand_planner import plan_hand
from scenarios.registry import shipped_file
from sim.settings import ENGINES

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", default=None,
                    help="comma-separated mu values to validate (default: the plan's list)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" /
                                         "validate_bench.json"))
    args = ap.parse_args()
    from scenarios.runs import validate_plan

    times = []
    plan = None
    for _ in range(3):
        t = time.perf_counter()
        plan = plan_hand(shipped_file("two_finger_hand"), mu=(0.0, 0.2), policy="midband")
        times.append(time.perf_counter() - t)
    mus = ([float(x) for x in args.mu.split(",")] if args.mu else list(plan.validate_mu))
    plan = plan.segments[0]  # the plan's one segment
    runs = []
    for engine in ENGINES:
        for mu in mus:
            t = time.perf_counter()
            res = validate_plan(plan, engine, mu)
            wall = time.perf_counter() - t
            v = res.verdict
            pm = v.plan
            claim_fraction = pm.claim_fraction if pm else float("nan")
            final_error = pm.final_error_of_travel if pm else float("nan")
            runs.append({
                "engine": engine, "mu": mu, "wall_s": wall,
                "sim_wall_s": res.summary.wall_time_s,
                "simulated_s": plan.waypoints[-1].t,
                "realtime_factor": plan.waypoints[-1].t / wall,
                "steps": res.summary.parameters["steps"], "status": v.outcome.value,
                "claim_fraction": claim_fraction,
                "final_error_of_travel": final_error,
            })
            print(f"{engine:7s} mu={mu:<4g} {wall:6.2f} s  ({runs[-1]['realtime_factor']:.1f}x "
                  f"real time)  {v.outcome.value}  4S {claim_fraction:.1%}  final error "
                  f"{final_error:.2%} of travel", flush=True)
    both = {m: sum(r["wall_s"] for r in runs if r["mu"] == m) for m in mus}
    result = {
        "machine": {"python": platform.python_version(), "cpus": __import__("os").cpu_count()},
        "plan_s": {"best": min(times), "all": times, "target": 5.0},
        "validate_runs": runs,
        "validate_both_engines_s": {f"{m:g}": v for m, v in both.items()},
        "validate_target_s": 60.0,
        "ratio_validate_both_to_plan": {f"{m:g}": v / min(times) for m, v in both.items()},
    }
    atomic_write_json(args.out, result)
    print(f"plan: best {min(times):.2f} s of {[round(x, 2) for x in times]}; validate in both "
          f"engines: " + ", ".join(f"mu={m:g} {v:.1f} s" for m, v in both.items()))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
