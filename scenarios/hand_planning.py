"""Scenarios: the Section 5.2 planning example (two-finger hand) -- plans and Figures 10-13, and
the whole Figure 9 task (``hand_task_plan``: the segment search to the goal grasp)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from scenarios.registry import Expect, Scenario, register, shipped_file


def _plan(out_dir: Path, policy: str, **options: Any) -> dict[str, Any]:
    from planner.files.atomic import atomic_write_json
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan
    from planner.plots.bounds import margin_summary, plot_bounds

    whole = plan_hand(shipped_file("two_finger_hand"), mu=tuple(options.get("mu", (0.0, 0.2))),
                      policy=policy, waypoints=options.get("waypoints"))
    out_dir = Path(out_dir)
    path = save_plan(whole, out_dir / "plan.json")
    plan = whole.segments[0]
    figs = plot_bounds(plan, out_dir)
    curves = plan.extra["curves"]["modes"]
    r2s = curves.get("R1 B2 S-3 S-4", {}).get("at_hi", [])
    travel = plan.extra["curves"]["travel"]
    last = max((i for i, x in enumerate(r2s) if x is not None), default=None)
    summary = {
        "scenario": "hand_plan" if policy == "midband" else "hand_plan_r2s",
        "status": "info", "plan": str(path), "figures": [str(f) for f in figs], "claim": plan.claim,
        "control": list(plan.control), "policy": plan.policy, "event": plan.event.to_dict(),
        "travel_mm": 1e3 * plan.travel(), "exact": plan.exact,
        "r2s_feasible_until_fraction_of_travel": (travel[last] / travel[-1]
                                                  if last is not None else None),
        "predicted_modes": sorted({m for w in plan.waypoints for m in w.predicted}),
        **margin_summary(plan),
    }
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


def run_hand_plan(out_dir: Path, **options: Any) -> dict[str, Any]:
    """Plan the 4S segment for mu in [0, 0.2] (Figs. 10-13)."""
    return _plan(out_dir, "midband", **options)


def run_hand_plan_negative(out_dir: Path, **options: Any) -> dict[str, Any]:
    """Negative control: torque in the R2S band while the plan still claims 4S."""
    return _plan(out_dir, "rival:R1 B2 S-3 S-4", **options)


#: What :func:`_plan` writes: the plan, its summary and Figures 10-13
#: (:func:`planner.plots.bounds.plot_bounds`).
PLAN_OUTPUTS = ("plan.json", "summary.json", "fig10_bounds_mu_lo.png", "fig11_bounds_mu_hi.png",
                "fig12_rival_bounds_mu_hi.png", "fig13_guaranteed.png")

register(Scenario(name="hand_plan", summary="two-finger hand: 4S torque bands for mu in [0, 0.2]",
                  reference="Sec. 5.2, Figs. 9-13", expect=Expect.INFO, run=run_hand_plan,
                  tags=("plan",), outputs=PLAN_OUTPUTS))
register(Scenario(name="hand_plan_r2s", summary="negative-control plan: R2S-band torque, claims 4S",
                  reference="Sec. 5.2, Fig. 12", expect=Expect.INFO, run=run_hand_plan_negative,
                  tags=("plan", "negative-control"), outputs=PLAN_OUTPUTS))


def run_hand_task_plan(out_dir: Path, **options: Any) -> dict[str, Any]:
    """Plan the whole Figure 9 task (docs/planning.md): the plan, the story figures
    and a summary (segments, claims, events, smallest margins, reached)."""
    from planner.files.atomic import atomic_write_json
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan
    from planner.plots.task import plot_task_regions, plot_task_story

    plan = plan_hand(shipped_file("figure9_task_hand"), mu=tuple(options.get("mu", (0.0, 0.2))))
    out_dir = Path(out_dir)
    path = save_plan(plan, out_dir / "plan_task.json")
    figs = [plot_task_story(plan, out_dir), plot_task_regions(plan, out_dir)]
    summary = {
        "scenario": "hand_task_plan", "status": "info", "plan": str(path),
        "figures": [str(f) for f in figs], "reached": plan.reached,
        "segments": [{"claim": seg.claim, "control": list(seg.control),
                      "event": seg.event.to_dict(), "start_s": float(t0),
                      "smallest_margin": min(w.margin for w in seg.waypoints)}
                     for seg, t0 in zip(plan.segments, plan.start_times())],
        "diagnosis": plan.diagnosis,
    }
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


register(Scenario(name="hand_task_plan",
                  summary="two-finger hand: the whole task from the initial to the goal grasp "
                          "(segment search, mu in [0, 0.2])",
                  reference="Sec. 5.2, Fig. 9 (reconstructed goal)", expect=Expect.INFO,
                  run=run_hand_task_plan, tags=("plan", "task"),
                  outputs=("plan_task.json", "summary.json", "task_story.png",
                           "task_regions.png")))
