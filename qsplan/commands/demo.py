"""``qsplan demo --out report [--quick]``: the two-finger hand task end to end (Section 5.2,
Figs. 9-13), from the initial to the goal grasp.

1. plan the whole Figure 9 task (``figure9_task_hand``: a chain of guaranteed 4S segments to the
   goal grasp, :mod:`qsplan.demo_task`) and its negative control (every torque reversed, still
   claiming each mode); the story pictures (start, segments, goal; torque regions); plan the
   first segment alone for friction in [0, 0.2] (``policy midband``, Figures 10-13) and its
   negative control that puts the torque in the R2S band during the first half while still
   claiming 4S (``policy rival:R2S``); check that the plan file reloads to the same plan and
   that a tampered copy is rejected;
2. validate the whole task in every installed engine (pymunk, MuJoCo and, with the ``dart``
   extra, DART; ``--engines`` names others) at the friction interval's ends and middle
   (``mu.validate``: 0, 0.1, 0.2; the whole task in one continuous run judged per segment,
   :func:`scenarios.runs.validate_plan`), and the negative controls: the reversed-torque task
   and the R2S segment at mu = 0.2 (two worker processes);
3. write ``report/``: the story (``story/``), the plans, one folder per run (summary.json; the
   R2S runs also timeline.png and animation.gif), ``checks.json``, ``REPORT.md`` (one page: the
   task in pictures, the torque regions, the engines side by side with their consensus, then
   what held, with numbers) and ``index.html`` (:mod:`qsplan.report`).

Exit 0 only when every expectation held: the task is planned to its goal in >= 3 segments within
10 s, every segment of every run agrees (claimed mode >= 95 % of the segment, final position
within 2 % of its travel) and the whole task ends within 2 % of its travel, both negative
controls fail validation in every engine (R2S observed in the first half), the plan
round-trips and tampering is caught -- where the engines disagree with each other, a run check
of the odd engine holds when its run measured an engine artefact (:mod:`qsplan.demo_engines`,
:mod:`sim.consensus`): an engine artefact is not a model error.  ``--quick`` runs the task
at the middle friction value only and the R2S control over the first quarter of its segment
(else its first half).
Simulators are imported lazily (in the worker processes).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from planner.errors import InputError
from qsplan.demo_engines import consensus_table, excuse_checks, side_by_side_lines
from qsplan.demo_task import (
    Check,
    DemoRun,
    plan_task,
    run_demo_job,
    task_jobs,
    task_plan_checks,
    task_report_lines,
    task_run_checks,
)
from qsplan.options import check_int
from scenarios.registry import shipped_file
from sim.backends import ENGINES, installed_engines, require_engine

SCENARIO = "two_finger_hand"
NEGATIVE_MU = 0.2
RIVAL = "R2S"
MAX_JOBS = 64
TASK = "two-finger hand, guaranteed 4S under uncertain friction (Sec. 5.2)"
OUTPUTS = ("plan.json", "negative_control/", "task/", "figures/", "story/", "checks.json",
           "REPORT.md", "index.html")
"""The entries ``--out`` gets (module docstring, step 3), checked before any work; the folders
of :data:`RENDERED` only without ``--no-render``."""
RENDERED = ("figures/", "story/")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="plan the two-finger hand's whole task, validate it in every installed engine, "
             "write a report",
        description=(
            "The two-finger hand task (Sec. 5.2, Fig. 9): plan the whole task from the initial "
            "to the goal grasp (guaranteed 4S segments for mu in [0, 0.2]), validate it in "
            "every installed engine (pymunk, MuJoCo; DART with `pip install 'qsplan[dart]'`) "
            "at mu = 0, 0.1, 0.2, run two negative controls (reversed torques; the first "
            "segment's R2S torque), and write a report folder (the task in pictures, plans, "
            "Figures 10-13, summaries, the engines side by side with their consensus, "
            "REPORT.md, index.html). Exit 0 only if every expectation held, 1 otherwise, 2 bad "
            "input, 3 simulator fault."
        ),
        epilog="example: qsplan demo --out report",
    )
    p.add_argument("--out", default="report",
                   help="report folder; its contents are replaced only when the demo has "
                        "finished (a failed run leaves the old report whole)")
    p.add_argument("--quick", action="store_true",
                   help="simulate the task at the middle friction value only, the R2S control "
                        "over the first quarter of its segment")
    p.add_argument("--scenario", default=SCENARIO, help="hand file or name")
    p.add_argument("--engines", default=None,
                   help=f"comma-separated engines from {', '.join(ENGINES)} (default: every "
                        f"installed one)")
    p.add_argument("--jobs", type=int, default=2, help=f"worker processes, 1..{MAX_JOBS}")
    p.add_argument("--no-render", action="store_true", help="skip timelines and GIFs")
    p.set_defaults(func=run)


def _check(name: str, expected: str, measured: str, held: bool) -> dict[str, Any]:
    return Check(name, expected, measured, bool(held)).to_dict()


def chosen_engines(text: str | None) -> list[str]:
    """The engines of ``--engines`` (comma-separated names, each installed), or every
    installed engine when none is named (:func:`sim.backends.installed_engines`)."""
    if text is None:
        return list(installed_engines())
    engines = [e.strip() for e in str(text).split(",") if e.strip()]
    bad = [e for e in engines if e not in ENGINES]
    if bad or not engines:
        raise InputError(f"--engines: expected names from {', '.join(ENGINES)}, got {text!r}")
    for engine in engines:
        require_engine(engine, "--engines")
    return list(dict.fromkeys(engines))


def run(args: argparse.Namespace) -> int:
    engines = chosen_engines(args.engines)
    check_int(args.jobs, "--jobs", 1, MAX_JOBS)
    from planner.files.outputs import output_set

    entries = OUTPUTS if not args.no_render else tuple(
        e for e in OUTPUTS if e not in RENDERED)
    # the destination and every entry are checked before any work
    with output_set(args.out, "dir", entries=entries) as work:
        lines, faults, code = _run(args, engines, work)
    if not getattr(args, "quiet", False):  # printed once the report is in place
        print("\n".join(lines))
    for line in faults:
        print(line, file=sys.stderr)
    return code


def _run(args: argparse.Namespace, engines: list[str], out: Path
         ) -> tuple[list[str], list[str], int]:
    """The demo with every output written below ``out`` (the staging folder of --out).
    Returns the result lines, the simulator faults (for stderr) and the exit code."""
    from planner.errors import FileFormatError
    from planner.files.atomic import atomic_write_json, atomic_write_text
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import load_plan, plans_equal, save_plan

    final = Path(args.out)
    t_start = time.perf_counter()
    checks: list[dict[str, Any]] = []

    # 1. plans --------------------------------------------------------------------------------
    t0 = time.perf_counter()
    plan = plan_hand(shipped_file(args.scenario), mu=(0.0, 0.2), policy="midband")
    t_plan = time.perf_counter() - t0
    neg = plan_hand(shipped_file(args.scenario), mu=(0.0, 0.2), policy=f"rival:{RIVAL}")
    plan_path = save_plan(plan, out / "plan.json")
    neg_path = save_plan(neg, out / "negative_control" / "plan_negative.json")
    checks.append(_check("planning time, mu interval [0, 0.2], exact bounds (info)",
                         "(benchmark: benchmarks/plan_bench.py)", f"{t_plan:.2f} s", True))
    same = plans_equal(load_plan(plan_path), plan)
    checks.append(_check("plan.json reloads to the same plan", "identical canonical content",
                         "identical" if same else "different", same))
    from planner.files.reader import read_json

    tampered = read_json(plan_path, "plan file")
    tampered["segments"][0]["waypoints"][1]["torque_commands"] = list(
        neg.segments[0].waypoints[1].torque_commands)
    tpath = out / "negative_control" / "tampered_copy.json"
    atomic_write_text(tpath, json.dumps(tampered))
    try:
        load_plan(tpath)
        msg, caught = "accepted", False
    except FileFormatError as exc:
        msg, caught = str(exc).split(": ", 1)[-1].split(" (")[0], True
    tpath.unlink()
    checks.append(_check("a plan with one torque edited by hand is rejected", "FileFormatError",
                         msg, caught))
    figures = []
    if not args.no_render:
        from planner.plots.bounds import plot_bounds

        figures = [p.name for p in plot_bounds(plan.segments[0], out / "figures")]
    task = plan_task(out, render=not args.no_render)
    checks += task_plan_checks(task)

    # 2. simulations --------------------------------------------------------------------------
    # the R2S control: the first quarter (--quick) or the first half, where R2S is the rival
    n_wp = max(2, (len(plan.segments[0].waypoints) + (3 if args.quick else 1))
               // (4 if args.quick else 2))
    # the whole task at the friction interval's ends and middle (--quick: the middle only)
    mus = [float(m) for m in task["plan"].validate_mu] or [0.0, 0.1, 0.2]
    if args.quick:
        mus = [mus[len(mus) // 2]]
    jobs = task_jobs(task["path"], task["negative_path"], engines, mus, out, NEGATIVE_MU)
    jobs += [DemoRun(plan=str(neg_path), engine=engine, mu=NEGATIVE_MU,
                     out=str(out / "negative_control" / engine),
                     folder=f"negative_control/{engine}", waypoints=n_wp,
                     render=not args.no_render,
                     name=f"negative control (R2S torque, claims 4S), {engine}, "
                          f"mu={NEGATIVE_MU:g}", expect="disagree") for engine in engines]
    t0 = time.perf_counter()
    if args.jobs > 1 and len(jobs) > 1:
        with ProcessPoolExecutor(max_workers=min(args.jobs, len(jobs), os.cpu_count() or 1)) as ex:
            results = list(ex.map(run_demo_job, jobs))
    else:
        results = [run_demo_job(j) for j in jobs]
    t_sims = time.perf_counter() - t0
    for r in results:  # a faulted or inconclusive run measured no plan quantities
        for key in ("claim_fraction", "predicted_fraction", "final_error_of_travel", "travel_m",
                    "final_angle_error_rad"):
            r.setdefault(key, float("nan"))
    faults = [r for r in results if r["status"] == "fault"]
    checks += task_run_checks(task, results)
    for r in results:  # the single-segment runs: the R2S negative control
        if r["task"]:
            continue
        where = f"{r['engine']}, mu={r['parameters']['mu'][0]:g}"
        checks.append(_check(
            f"negative control in {where}: validation", "fails (claim not observed)",
            f"{r['status']}: 4S on {r['claim_fraction']:.1%}", r["status"] == "disagreed"))
        first = r.get("rival_first_observed_s")
        ok = (r["status"] == "disagreed" and first is not None
              and r.get("rival_first_interval_majority") in r.get("rival_predicted", []))
        stretch = r.get("rival_stretch_s") or [0, 0]
        checks.append(_check(
            f"negative control in {where}: {RIVAL} observed where predicted",
            f"predicted {', '.join(r.get('rival_predicted', []))} observed in the first "
            f"half ({stretch[0]:.1f}-{stretch[1]:.1f} s)",
            (f"observed from {first:.2f} s for {r['rival_observed_s']:.2f} s "
             f"({r['rival_observed_fraction']:.0%} of the stretch); majority of the first "
             f"interval: {r.get('rival_first_interval_majority')}") if first is not None
            else "not observed", ok))
    for engine in engines:
        wall = sum(r["wall_time_s"] for r in results
                   if r["engine"] == engine and r["expect"] == "agree")
        checks.append(_check(f"simulation wall time, {engine}, whole task, all mu (info)",
                             "(benchmark: see benchmarks/validate_bench.py)", f"{wall:.1f} s",
                             True))
    checks = excuse_checks(checks, results)
    total = time.perf_counter() - t_start
    held = all(c["held"] for c in checks)
    status = "all expectations held" if held else "SOME EXPECTATIONS FAILED"
    atomic_write_json(out / "checks.json", {
        "task": TASK,
        "quick": bool(args.quick), "held": held, "checks": checks,
        "plan_seconds": t_plan, "task_plan_seconds": task["seconds"],
        "simulation_seconds": t_sims, "total_seconds": total,
        "engines": engines, "consensus": consensus_table(results),
        "runs": results,
    })
    atomic_write_text(out / "REPORT.md", _report_md(plan, neg, checks, results, figures,
                                                    args.quick, n_wp, t_plan, t_sims, total,
                                                    status, task))
    from qsplan.report import write_report

    write_report(out, out / "index.html")
    lines = [f"[{'ok' if c['held'] else 'FAIL'}] {c['check']}: {c['measured']} "
             f"(expected {c['expected']})" for c in checks]
    lines.append(f"qsplan demo: {status}; report in {final} ({total:.0f} s)")
    fault_lines = [f"simulator fault: {r['engine']}: {r['fault']}" for r in faults]
    return lines, fault_lines, 3 if faults else 0 if held else 1


def _report_md(whole, neg, checks, results, figures, quick, n_wp, t_plan, t_sims, total,
               status, task) -> str:
    import numpy as np

    plan, neg = whole.segments[0], neg.segments[0]  # the one segment of the two-finger plans
    bands = np.array([w.bands[0] for w in plan.waypoints])
    tau = plan.torques()[:, 0]
    L = []
    L.append("# Two-finger hand: the whole task of Figure 9, guaranteed 4S segments under "
             "uncertain friction (Sec. 5.2)\n")
    L.append(f"**Result: {status}.** "
             f"{sum(c['held'] for c in checks)} of {len(checks)} checks held"
             + (" (quick run: the task at one friction value)." if quick else ".")
             + f" The R2S control runs the first {n_wp} of {len(plan.waypoints)} waypoints of "
               "its segment, where R2S is the rival.\n")
    L += task_report_lines(task, results)
    L += side_by_side_lines(results)
    L.append("## The first segment in detail: torque regions (Figures 10-13)\n")
    L.append(f"Plan: `plan.json` - claim `{plan.claim}` (contacts in file order: 1, 2 palm "
             f"vertices, 3 left finger side, 4 right finger tip), control "
             f"{', '.join(f'{n}={c}' for n, c in zip(['left', 'right'], plan.control))}, friction "
             f"interval {list(plan.mu_intervals[0])} ({whole.mu_model}), "
             f"{len(plan.waypoints)} waypoints over {plan.waypoints[-1].t:.2f} s, travel "
             f"{1e3 * plan.travel():.2f} mm; segment ends: {plan.event.kind} "
             f"({plan.event.detail}). Effort joint torque {tau[0]:.2e} -> {tau[-1]:.2e} N m "
             f"inside the guaranteed band (start [{bands[0][0]:.2e}, {bands[0][1]:.2e}], end "
             f"[{bands[-1][0]:.2e}, {bands[-1][1]:.2e}] N m; smallest margin "
             f"{np.min(plan.margins()):.2e} N m).\n")
    L.append("Negative control: `negative_control/plan_negative.json` - the same segment with "
             f"the torque in the {RIVAL} band where it has one (first half) while still "
             f"claiming `{neg.claim}`.\n")
    L.append("## Checks\n")
    L.append("| check | expected | measured | held |")
    L.append("|---|---|---|---|")
    for c in checks:
        L.append(f"| {c['check']} | {c['expected']} | {c['measured']} | "
                 f"{'yes' if c['held'] else '**NO**'} |")
    L.append("")
    L.append("## Runs\n")
    L.append("| run | status | claimed mode | predicted modes | final error / travel | "
             "observed (most frequent) | wall [s] | folder |")
    L.append("|---|---|---|---|---|---|---|---|")
    for r in results:
        if r["task"]:
            continue
        top = sorted(r["observed_counts"].items(), key=lambda kv: -kv[1])[:2]
        n = max(1, sum(r["observed_counts"].values()))
        obs = "; ".join(f"{k} {v / n:.0%}" for k, v in top)
        folder = r.get("folder", "")
        L.append(f"| {r['name']} | {r['status']} | {r['claim_fraction']:.1%} | "
                 f"{r['predicted_fraction']:.1%} | {r['final_error_of_travel']:.2%} | {obs} | "
                 f"{r['wall_time_s']:.1f} | {folder} |")
    L.append("")
    negs = [r for r in results if r["expect"] == "disagree" and not r["task"]]
    if negs:
        L.append("### What the negative control shows\n")
        for r in negs:
            segs = [s for s in r["observed"]["segments"] if s["end_s"] - s["start_s"] >= 0.1]
            text = ", ".join(f"{s['mode']} {s['start_s']:.2f}-{s['end_s']:.2f} s"
                             for s in segs[:6])
            L.append(f"- {r['engine']}: {text}")
        L.append("\nThe planner's prediction of the rival holds at the planned configuration: "
                 "R2S (left palm vertex rolling, workpiece turning counter-clockwise, right palm "
                 "vertex lifting) starts at once. As the workpiece turns it leaves the planned "
                 "4S path, and from there the plan's geometry (and so its prediction) no longer "
                 "applies; in the runs above the tilted workpiece then slides on the left vertex "
                 "(and returns to 4S once the torque is back in the 4S band, second half). "
                 "Either way the plan's claim is not observed and validation fails, as it "
                 "must.\n")
    L.append("## Figures and files\n")
    L.append("- `figures/`: " + (", ".join(figures) if figures else "(not rendered)")
             + " (torque bounds along the segment: Figs. 10-13)")
    L.append("- `story/`: the task in pictures; `task/plan_task.json`: the task plan; "
             "`task/<engine>/mu_<mu>/summary.json`: the whole task's runs (a row per segment); "
             "`negative_control/task/`: the reversed-torque control")
    L.append("- `negative_control/<engine>/`: summary.json, "
             "timeline.png (predicted per waypoint vs observed per contact), animation.gif "
             "(dashed: predicted workpiece)")
    L.append("- `checks.json`: every check and run summary; `index.html`: this report with all "
             "figures embedded")
    L.append(f"\nTimes: planning {t_plan:.2f} s, simulations {t_sims:.1f} s (parallel workers), "
             f"total {total:.1f} s. Reproduce: `qsplan demo --out report"
             + (" --quick" if quick else "") + "`.")
    return "\n".join(L) + "\n"
