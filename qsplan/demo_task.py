"""The whole-task part of ``qsplan demo``: the Figure 9 task from the initial to the goal grasp.

* :func:`plan_task` -- plan ``figure9_task_hand`` (:func:`planner.plan.hand_planner.plan_hand`),
  write ``task/plan_task.json``, its negative control (every torque reversed, still
  claiming every segment's mode: ``negative_control/task/plan_task_negative.json``) and the
  story pictures (``story/task_story.png``: start, segments, goal; ``story/task_regions.png``:
  the torque regions);
* :func:`task_jobs` / :func:`task_job` -- one run of the whole plan per engine and friction value
  (:func:`sim.task_run.run_task`: the whole task in one continuous simulation)
  and the negative control per engine, each writing ``summary.json`` (whole verdict, then one
  row per segment);
* :func:`task_plan_checks`, :func:`task_run_checks` and :func:`task_report_lines` -- the
  demo's checks and the report's story.

Simulators are imported inside :func:`task_job` (it runs in a worker process).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from scenarios.registry import shipped_file

TASK_SCENARIO = "figure9_task_hand"
MODE_FRACTION = 0.95
POSE_OF_TRAVEL = 0.02


def plan_task(out: Path, render: bool) -> dict[str, Any]:
    """Plan the task and write its files below ``out``; returns ``plan``, ``path``,
    ``negative_path``, ``seconds``, ``goal`` (pose or None) and ``figures`` (names)."""
    from planner.files.hand_file import load_hand_file
    from planner.plan.hand_planner import plan_hand
    from planner.plan.model import negative_control
    from planner.plan.plan_file import save_plan

    t0 = time.perf_counter()
    plan = plan_hand(shipped_file(TASK_SCENARIO))
    seconds = time.perf_counter() - t0
    path = save_plan(plan, out / "task" / "plan_task.json")
    neg = save_plan(negative_control(plan),
                    out / "negative_control" / "task" / "plan_task_negative.json")
    goal = load_hand_file(shipped_file(TASK_SCENARIO)).goal
    pose = None if goal is None or goal.pose is None else goal.pose
    figures = []
    if render:
        from planner.plots.task import plot_task_regions, plot_task_story

        figures = [plot_task_story(plan, out / "story", pose).name,
                   plot_task_regions(plan, out / "story").name]
    return {"plan": plan, "path": path, "negative_path": neg, "seconds": seconds,
            "goal": pose, "figures": figures}


def task_jobs(path: Path, negative: Path, engines: list[str], mus: list[float], out: Path,
              negative_mu: float) -> list[dict[str, Any]]:
    """The whole plan per engine and ``mu``, and the negative control per engine."""
    jobs = [{"kind": "task", "plan": str(path), "engine": e, "mu": float(mu),
             "out": str(out / "task" / e / f"mu_{mu:g}"), "expect": "agree",
             "name": f"whole task, {e}, mu={mu:g}"} for e in engines for mu in mus]
    jobs += [{"kind": "task", "plan": str(negative), "engine": e, "mu": float(negative_mu),
              "out": str(out / "negative_control" / "task" / e), "expect": "disagree",
              "name": f"negative control (torques reversed), whole task, {e}, "
                      f"mu={negative_mu:g}"} for e in engines]
    return jobs


def task_job(job: dict[str, Any]) -> dict[str, Any]:
    """One run of a task plan in a worker process; writes and returns its summary."""
    from planner.files.atomic import atomic_write_json
    from planner.plan.plan_file import load_plan
    from sim.compare import Expect
    from sim.task_run import run_task

    plan = load_plan(job["plan"])
    run = run_task(plan, job["engine"], job["mu"])
    summary = {**run.summary, "scenario": job["name"], "expect": job["expect"],
               "passed": run.whole.held(Expect.parse(job["expect"])), "kind": "task",
               "wall_time_s": run.summary["settings"]["wall_time_s"]}
    atomic_write_json(Path(job["out"]) / "summary.json", summary)
    return {**summary, "folder": job["out"]}


def _check(name: str, expected: str, measured: str, held: bool) -> dict[str, Any]:
    return {"check": name, "expected": expected, "measured": measured, "held": bool(held)}


def task_plan_checks(task: dict[str, Any]) -> list[dict[str, Any]]:
    """Checks of the task plan: >= 3 segments to the goal; the planning time (info)."""
    plan = task["plan"]
    n = len(plan.segments)
    return [
        _check("whole task planned to its goal (Figure 9, mu in [0, 0.2])",
               ">= 3 segments, goal reached",
               f"{n} segments ({', '.join(s.claim for s in plan.segments)}), reached "
               f"{plan.reached}", plan.reached and n >= 3),
        _check("whole task planning time (info)", "(benchmark: benchmarks/task_bench.py, "
               "target <= 10 s)", f"{task['seconds']:.2f} s", True)]


def task_run_checks(task: dict[str, Any], results: list[dict[str, Any]]
                    ) -> list[dict[str, Any]]:
    """Checks of the runs: every segment of every run, the whole task, the negatives."""
    n = len(task["plan"].segments)
    checks: list[dict[str, Any]] = []
    for r in results:
        if r.get("kind") != "task":
            continue
        where = f"{r['engine']}, mu={r['mu']:g}"
        if r["expect"] == "agree":
            for row in r["segments"]:
                frac = row.get("claim_fraction", float("nan"))
                err = row.get("final_error_of_travel", float("nan"))
                checks.append(_check(
                    f"task segment {row['segment']} in {where}: claimed mode and final position",
                    f">= {MODE_FRACTION:.0%} of the segment, <= {POSE_OF_TRAVEL:.0%} of its "
                    "travel", f"{row['status']}: {frac:.1%}, {err:.2%}",
                    row["status"] == "agreed"))
            checks.append(_check(f"whole task in {where}", "every segment agreed, final "
                                 f"position <= {POSE_OF_TRAVEL:.0%} of the task's travel",
                                 f"{r['status']} ({len(r['segments'])} of {n} segments ran)",
                                 r["status"] == "agreed"))
        else:
            checks.append(_check(f"negative control (torques reversed) in {where}",
                                 "fails validation", f"{r['status']}: {r['reason'][:120]}",
                                 r["status"] == "disagreed"))
    return checks


def task_report_lines(task: dict[str, Any], results: list[dict[str, Any]]) -> list[str]:
    """The report's story: the task in pictures, its segments, then its runs (markdown)."""
    plan = task["plan"]
    L = ["## The task: from the initial to the goal grasp (Figure 9, reconstructed)\n",
         *(["![start, segments and goal](story/task_story.png)\n"] if task["figures"] else []),
         f"Planned by the segment search (docs/planning.md) in {task['seconds']:.2f} s: "
         f"{len(plan.segments)} segments, goal reached: {plan.reached}. Plan: "
         "`task/plan_task.json`.\n",
         "| segment | starts | claim | control | contacts kept | released | ends | smallest "
         "margin [N m] |", "|---|---|---|---|---|---|---|---|"]
    names = [f.get("name", f"finger {k}") for k, f in enumerate(plan.hand.get("fingers", []))]
    for k, (seg, t0) in enumerate(zip(plan.segments, plan.start_times())):
        kept = "; ".join(_contact_text(c, names) for c in plan.contacts[k])
        rel = "; ".join(_contact_text(c, names) for c in plan.released[k]) or "-"
        m = min(w.margin for w in seg.waypoints)
        L.append(f"| {k + 1} | {t0:.1f} s | `{seg.claim}` | {', '.join(seg.control)} | {kept} "
                 f"| {rel} | {seg.event.kind} ({seg.event.detail}) | {m:.2e} |")
    L.append("")
    if task["figures"]:
        L.append("Torque regions along the task (commanded torque and its guaranteed ball):\n")
        L.append("![torque regions](story/task_regions.png)\n")
    L.append("### Runs of the whole task\n")
    L.append("| run | whole | segments (claimed mode, final error / travel) | wall [s] |")
    L.append("|---|---|---|---|")
    for r in results:
        if r.get("kind") != "task":
            continue
        segs = "; ".join(f"{row['segment']}: {row['status']} "
                         f"({row.get('claim_fraction', float('nan')):.0%}, "
                         f"{row.get('final_error_of_travel', float('nan')):.2%})"
                         for row in r["segments"])
        L.append(f"| {r['scenario']} | {r['status']} | {segs} | {r['wall_time_s']:.1f} |")
    L.append("")
    return L


def _contact_text(c: dict[str, Any], names: list[str]) -> str:
    """``vertex 3 on left``, ``right tip on edge 1``, ``vertex 0 on palm`` (``names``: the
    fingers' names)."""
    k = c.get("finger")
    finger = names[k] if isinstance(k, int) and 0 <= k < len(names) else f"finger {k}"
    if c.get("kind") == "tip":
        return f"{finger} tip on edge {c.get('edge')}"
    if c.get("kind") == "side":
        return f"vertex {c.get('vertex')} on {finger}"
    return f"vertex {c.get('vertex')} on {c.get('surface', c.get('kind'))}"
