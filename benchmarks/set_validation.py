"""Benchmark: validating a plan at the points of its mass / centre-of-mass set against the
nominal validation, in the same run.

Plans a hand file (default ``two_finger_hand``, cut to ``--max-time`` seconds) with an
``uncertainty`` section of mass ``+-MASS`` (a fraction) and centre of mass ``+-COM`` m in both body
coordinates (docs/planning.md, "Validating at points of the set"), then times, at one friction
value in one engine:

* the nominal validation (:func:`scenarios.runs.validate_plan`, what ``qsplan validate`` runs
  without ``--set``);
* the plan moved to each corner and the centre (:func:`planner.plan.set_points.plan_at`: the
  planner's prediction at every waypoint there) and its run
  (:func:`scenarios.set_runs.run_at_point`);
* what each uncertainty costs (:func:`planner.plan.set_cost.set_cost`) against the planning time.

Ratios are taken in the same run.  Writes benchmarks/results/set_validation.json.

    PYTHONPATH=. python3 benchmarks/set_validation.py [--hand two_finger_hand] [--engine pymunk]
        [--mu 0.1] [--mass 0.2] [--com 0.005] [--max-time 2]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

from planner.files.atomic import atomic_write_json
from planner.plan.hand_planner import plan_hand
from planner.plan.load_margins import plan_load_set
from planner.plan.set_cost import set_cost
from planner.plan.set_points import plan_at, set_axes, set_points
from planner.sweeps.set_samples import with_uncertainty
from scenarios.registry import shipped_file
from scenarios.runs import validate_plan
from scenarios.set_runs import run_at_point


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hand", default="two_finger_hand")
    ap.add_argument("--engine", default="pymunk")
    ap.add_argument("--mu", type=float, default=0.1)
    ap.add_argument("--mass", type=float, default=0.2)
    ap.add_argument("--com", type=float, default=0.005)
    ap.add_argument("--max-time", type=float, default=2.0)
    ap.add_argument("--out", default="benchmarks/results/set_validation.json")
    args = ap.parse_args()
    d = with_uncertainty(json.loads(Path(shipped_file(args.hand)).read_text()), args.mass,
                         args.com)
    d["segment"]["max_time"] = args.max_time
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hand.json"
        path.write_text(json.dumps(d))
        t = time.perf_counter()
        plan = plan_hand(path, margins=False)
        t_plan = time.perf_counter() - t
    t = time.perf_counter()
    nominal = validate_plan(plan, args.engine, args.mu)
    t_nominal = time.perf_counter() - t
    axes = set_axes(plan_load_set(plan))
    rows, t_predict, t_set = [], 0.0, 0.0
    for p in set_points(axes, ("corners", "centre")):
        t = time.perf_counter()
        plan_at(plan, axes, p, [args.mu])
        t_predict += time.perf_counter() - t
        t = time.perf_counter()
        run = run_at_point(plan, axes, p, args.engine, args.mu, name=p.name)
        t_set += time.perf_counter() - t
        rows.append({"point": p.name, "status": run.result.verdict.outcome.value,
                     "expect": run.expect.value, "matched": run.matched,
                     "sim_wall_s": run.result.summary.wall_time_s})
    t = time.perf_counter()
    set_cost(plan)
    t_cost = time.perf_counter() - t
    out = {
        "hand": args.hand, "engine": args.engine, "mu": args.mu, "mass": args.mass,
        "com_m": args.com, "max_time_s": args.max_time,
        "waypoints": len(plan.segments[0].waypoints), "points": len(rows),
        "nominal_status": nominal.verdict.outcome.value,
        "plan_s": t_plan, "nominal_validation_s": t_nominal, "set_validation_s": t_set,
        "set_over_nominal": t_set / t_nominal,
        "set_over_nominal_per_point": t_set / t_nominal / len(rows),
        "prediction_at_points_s": t_predict, "prediction_share_of_set": t_predict / t_set,
        "cost_curves_s": t_cost, "cost_over_plan": t_cost / t_plan,
        "runs": rows,
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                    "load": os.getloadavg()[0]},
    }
    atomic_write_json(args.out, out)
    print(json.dumps({k: v for k, v in out.items() if k != "runs"}, indent=1))


if __name__ == "__main__":
    main()
