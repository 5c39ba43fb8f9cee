"""Benchmark: field tasks planned over the workpiece's uncertain mass, centre of mass and contacts.

For each task (default ``block_tilting`` and ``box_pivot_up``, scenarios/data):

* plans it friction-only (the shipped file) and with an ``uncertainty`` section of mass
  ``+-MASS`` (a fraction) and centre of mass ``+-COM`` m in both body coordinates
  (docs/planning.md, "Uncertainty beyond friction"), ``margins=False`` so both times are the
  planner's alone; the ratio is taken in the same run (median of ``--repeats``);
* shows the guaranteed set shrinking: at every waypoint of the friction-only plan, the band of
  its claim (one effort joint) over the friction box and growing sets (fractions 0, 1/2 and 1 of
  both axes): the finite ends and the widest piece's width, and whether the friction-only
  commands stay guaranteed (:func:`planner.plan.load_margins.holds`);
* the uncertainty each plan's commands tolerate (:func:`planner.plan.load_margins.tolerated`)
  and its time;
* the whole set: the same task planned with mass, centre of mass *and* every contact's position
  ``+-CONTACTS`` m along its feature (docs/planning.md, "Contact positions"), its time over the
  friction-only time in the same run, and the band along the friction-only plan over that set.

Writes benchmarks/results/load_uncertainty.json.

    python3 benchmarks/load_uncertainty.py [--tasks block_tilting,box_pivot_up]
        [--mass 0.2] [--com 0.005] [--contacts 0.002] [--repeats 1] [--times-only]

``--times-only``: the three plans' times, ratios and what each reached, nothing else.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import time
from dataclasses import replace
from typing import Any

import numpy as np

from planner.errors import DegenerateError
from planner.files.atomic import atomic_write_json
from planner.files.hand_file import hand_file_from_dict
from planner.plan.guarantee import guarantee
from planner.plan.hand_planner import plan_hand
from planner.plan.load_margins import holds, tolerated
from planner.plan.offset_bounds import offset_box
from planner.plan.partition import joint_inputs
from planner.sweeps.set_samples import with_uncertainty
from scenarios.registry import DATA_DIR


def bands_along(plan: Any, data: dict[str, Any], mass: float, com: float,
                contacts: float = 0.0) -> dict[str, Any]:
    """The claim's band at every waypoint of ``plan`` over the set of ``mass``, ``com`` and
    ``contacts`` (a waypoint where the box changes the modes counts as without a band)."""
    hf = hand_file_from_dict(with_uncertainty(data, mass, com, contacts))
    lows, widths, n = [], [], 0
    for seg in plan.segments:
        if len(seg.effort_joints) != 1:
            continue
        hand = replace(seg.hand_model[0], load_set=hf.hand.load_set)
        for w in seg.waypoints:
            q = np.concatenate([w.pose, w.angles])
            joints = joint_inputs(hand, seg.velocity_joints, w.velocity_commands)
            system = hand.system(q, 0.0, joints)
            n += 1
            try:
                g = guarantee(system, seg.claim, list(seg.mu_intervals), model=plan.mu_model,
                              loads=hand.load_vertices(q), box=offset_box(hand, q, joints))
            except DegenerateError:
                continue
            if g.pieces:
                best = g.best()
                widths.append(best.upper - best.lower)
                lows.append(best.lower if math.isfinite(best.lower) else best.upper)
    fin = [x for x in widths if math.isfinite(x)]
    return {"mass_fraction": mass, "com_m": com, "contacts_m": contacts, "waypoints": n,
            "waypoints_with_a_band": len(widths),
            "finite_end_mean": statistics.fmean(lows) if lows else None,
            "finite_width_min": min(fin) if fin else None,
            "unbounded_pieces": len(widths) - len(fin),
            "friction_only_commands_hold": holds(plan, hf.hand.load_set)}


def run_task(name: str, mass: float, com: float, contacts: float,
             repeats: int, times_only: bool = False) -> dict[str, Any]:
    path = DATA_DIR / f"{name}.json"
    data = json.loads(path.read_text())
    hf_set = hand_file_from_dict(with_uncertainty(data, mass, com))
    hf_all = hand_file_from_dict(with_uncertainty(data, mass, com, contacts))
    t_plain, t_set, t_all = [], [], []
    plain = robust = full = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        plain = plan_hand(path, margins=False)
        t_plain.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        robust = plan_hand(hf_set, margins=False)
        t_set.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        try:
            full = plan_hand(hf_all, margins=False)
        except DegenerateError as exc:  # no guaranteed plan over the whole set
            full = str(exc)
        t_all.append(time.perf_counter() - t0)
    assert plain is not None and robust is not None
    if times_only:
        return planning_times(name, hf_set, hf_all, plain, robust, full, t_plain, t_set, t_all)
    t0 = time.perf_counter()
    tol = tolerated(robust)
    t_tol = time.perf_counter() - t0
    shrink = [bands_along(plain, data, f * mass, f * com) for f in (0.0, 0.5, 1.0)]
    mp, ms, ma = (statistics.median(t_plain), statistics.median(t_set),
                  statistics.median(t_all))
    whole: dict[str, Any] = {"set": hf_all.hand.load_set.to_dict(), "plan_seconds": ma,
                             "ratio_to_friction_only": ma / mp,
                             "bands_along_friction_only_plan": [
                                 bands_along(plain, data, f * mass, f * com, f * contacts)
                                 for f in (0.5, 1.0)]}
    if isinstance(full, str):
        whole["planned"] = False
        whole["reason"] = full
    else:
        t0 = time.perf_counter()
        whole.update(planned=True, reached=full.reached, exact=full.exact,
                     segments=[s.claim for s in full.segments],
                     tolerated=tolerated(full).to_dict())
        whole["tolerated_seconds"] = time.perf_counter() - t0
    return {
        "task": name, "set": hf_set.hand.load_set.to_dict(),
        "plan_seconds_friction_only": mp, "plan_seconds_with_set": ms, "ratio": ms / mp,
        "reached": {"friction_only": plain.reached, "with_set": robust.reached},
        "segments": {"friction_only": [s.claim for s in plain.segments],
                     "with_set": [s.claim for s in robust.segments]},
        "exact": {"friction_only": plain.exact, "with_set": robust.exact},
        "smallest_margin": {"friction_only": float(min(s.margins().min()
                                                       for s in plain.segments)),
                            "with_set": float(min(s.margins().min() for s in robust.segments))},
        "tolerated": tol.to_dict(), "tolerated_seconds": t_tol,
        "shrinking_along_friction_only_plan": shrink,
        "whole_set": whole,
    }


def planning_times(name: str, hf_set: Any, hf_all: Any, plain: Any, robust: Any, full: Any,
                   t_plain: list[float], t_set: list[float], t_all: list[float]
                   ) -> dict[str, Any]:
    """``--times-only``: the three plans' times (medians), ratios and what each reached, without
    the tolerated margins and the bands (which can take far longer than the plans)."""
    mp, ms, ma = (statistics.median(t_plain), statistics.median(t_set),
                  statistics.median(t_all))
    whole: dict[str, Any] = {"set": hf_all.hand.load_set.to_dict(), "plan_seconds": ma,
                             "ratio_to_friction_only": ma / mp}
    if isinstance(full, str):
        whole.update(planned=False, reason=full)
    else:
        whole.update(planned=bool(full.segments), reached=full.reached,
                     segments=[s.claim for s in full.segments])
    return {"task": name, "times_only": True, "set": hf_set.hand.load_set.to_dict(),
            "plan_seconds_friction_only": mp, "plan_seconds_with_set": ms, "ratio": ms / mp,
            "reached": {"friction_only": plain.reached, "with_set": robust.reached},
            "segments": {"friction_only": [s.claim for s in plain.segments],
                         "with_set": [s.claim for s in robust.segments]},
            "whole_set": whole}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default="block_tilting,box_pivot_up")
    ap.add_argument("--mass", type=float, default=0.2, help="mass +- fraction (default 0.2)")
    ap.add_argument("--com", type=float, default=0.005, help="centre of mass +- m (0.005)")
    ap.add_argument("--contacts", type=float, default=0.002,
                    help="every contact +- m along its feature (0.002)")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--times-only", action="store_true",
                    help="only the three plans' times and what they reach (no margins, bands)")
    ap.add_argument("--out", default="benchmarks/results/load_uncertainty.json")
    args = ap.parse_args()
    rows = []
    for name in args.tasks.split(","):
        r = run_task(name, args.mass, args.com, args.contacts, args.repeats, args.times_only)
        rows.append(r)
        if args.times_only:
            w = r["whole_set"]
            print(f"{name}: plan {r['plan_seconds_friction_only']:.2f} s friction only "
                  f"(reached {r['reached']['friction_only']}), "
                  f"{r['plan_seconds_with_set']:.2f} s with mass and centre of mass (ratio "
                  f"{r['ratio']:.2f}, reached {r['reached']['with_set']}), "
                  f"{w['plan_seconds']:.2f} s with contacts too (ratio "
                  f"{w['ratio_to_friction_only']:.2f}, segments {w.get('segments')}, reached "
                  f"{w.get('reached')})", flush=True)
            continue
        print(f"{name}: plan {r['plan_seconds_friction_only']:.2f} s friction only, "
              f"{r['plan_seconds_with_set']:.2f} s with mass +-{100 * args.mass:g} % and "
              f"centre of mass +-{1000 * args.com:g} mm (ratio {r['ratio']:.2f}); reached "
              f"{r['reached']}; smallest margin {r['smallest_margin']}; tolerated "
              f"{r['tolerated']} in {r['tolerated_seconds']:.1f} s", flush=True)
        for s in r["shrinking_along_friction_only_plan"]:
            print(f"   set x{s['mass_fraction'] / args.mass if args.mass else 0:.1f}: "
                  f"{s['waypoints_with_a_band']}/{s['waypoints']} waypoints with a band, mean "
                  f"finite end {s['finite_end_mean']}, smallest finite width "
                  f"{s['finite_width_min']}, friction-only commands hold: "
                  f"{s['friction_only_commands_hold']}", flush=True)
        w = r["whole_set"]
        print(f"   whole set (contacts +-{1000 * args.contacts:g} mm too): plan "
              f"{w['plan_seconds']:.2f} s (ratio {w['ratio_to_friction_only']:.2f} to friction "
              f"only); " + (f"reached {w['reached']}, exact {w['exact']}, tolerated "
                            f"{w['tolerated']}" if w["planned"] else f"no plan: {w['reason']}"),
              flush=True)
        for s in w["bands_along_friction_only_plan"]:
            print(f"   whole set x{s['mass_fraction'] / args.mass if args.mass else 0:.1f}: "
                  f"{s['waypoints_with_a_band']}/{s['waypoints']} waypoints with a band, mean "
                  f"finite end {s['finite_end_mean']}, friction-only commands hold: "
                  f"{s['friction_only_commands_hold']}", flush=True)
    atomic_write_json(args.out, {
        "command": "python3 benchmarks/load_uncertainty.py " + " ".join(
            f"--{k} {v}" for k, v in vars(args).items() if k != "out"),
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                    "load": os.getloadavg()},
        "tasks": rows})


if __name__ == "__main__":
    main()
