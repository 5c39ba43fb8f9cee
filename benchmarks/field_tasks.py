"""The field's manipulation tasks, shipped as hand files: plan each to its goal with the default
options, validate every segment in each engine at the plan's validation frictions, and run a
negative control (the last segment's efforts moved just outside every waypoint's guaranteed
region, :func:`planner.plan.negative_controls.outside_torques`, judged expecting
disagreement).

Prints one row per task in the closing-note form (task | segments | modes | planning time |
friction box | engines agreed) and writes every run as a JSON list (atomically).  Nothing is
asserted here; tests/planner/test_any_mode.py holds the planning checks.

    PYTHONPATH=. python benchmarks/field_tasks.py --out benchmarks/results/field_tasks.json
    PYTHONPATH=. python benchmarks/field_tasks.py --tasks block_tilting --engines pymunk
    PYTHONPATH=. python benchmarks/field_tasks.py --tasks flip_against_wall --keep  # one task anew
    PYTHONPATH=. python benchmarks/field_tasks.py --tasks tests/data/own_tilt_small.json \
        --out own.json                      # a task given as a hand file path (named by its stem)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from planner.files.atomic import atomic_write_json
from planner.plan.hand_planner import plan_hand
from planner.plan.negative_controls import outside_torques
from scenarios.runs import validate_plan
from sim.consensus import artefact_texts
from sim.settings import ENGINES

ROOT = Path(__file__).resolve().parents[1]
TASKS = ("block_tilting", "box_pivot_up", "box_pivot_down", "flip_against_wall", "side_push")


def _measured(run: Any) -> dict[str, Any]:
    """The verdict's reasons and the engine artefacts the run measured
    (:func:`sim.consensus.artefact_texts`): why a run did not agree, in the row."""
    return {"reasons": list(run.verdict.reasons),
            "artefacts": list(artefact_texts(run.summary.to_dict()))}


def _mu_text(mu: Any) -> str:
    return f"{mu:g}" if isinstance(mu, float) else "/".join(f"{x:g}" for x in mu)


#: How far past a facet of the guaranteed region the negative control's efforts go, in units of
#: the larger of the region's radius and the command's size (``outside_torques``'s ``reach``):
#: just outside, where the planner predicts a rival (a finger that presses too little slips),
#: not so far that the finger is flung out of the scene (a simulator fault, not a verdict).
NEGATIVE_REACH = 0.3


def _task_path(task: str) -> Path:
    """A shipped task's name (``scenarios/data/NAME.json``) or a hand file's path."""
    return Path(task) if task.endswith(".json") else ROOT / "scenarios" / "data" / f"{task}.json"


def task_rows(task: str, engines: tuple[str, ...], negative: bool = True,
              one_mu: bool = False) -> list[dict]:
    path = _task_path(task)
    name = path.stem
    t0 = time.perf_counter()
    plan = plan_hand(path)
    planning = time.perf_counter() - t0
    rows: list[dict] = []
    base = {"task": name, "reached": plan.reached, "segments": len(plan.segments),
            "modes": [s.claim for s in plan.segments], "planning_s": round(planning, 2),
            "friction_box": [list(iv) for iv in plan.segments[0].mu_intervals]
            if plan.segments else None}
    print(base, flush=True)
    if not plan.segments:
        return [{**base, "kind": "plan", "status": "no segments"}]
    for mu in plan.validate_mu[:1] if one_mu else plan.validate_mu:
        for engine in engines:
            t = time.perf_counter()
            run = validate_plan(plan, engine, mu, name=name)
            rows.append({**base, "kind": "validate", "engine": engine, "mu": _mu_text(mu),
                         "status": run.verdict.outcome.value,
                         "wall_s": round(time.perf_counter() - t, 2), **_measured(run)})
            print(rows[-1], flush=True)
    seg = plan.segments[-1]
    if negative and seg.effort_joints:
        hand = seg.hand_model[0]
        mu = plan.validate_mu[0]
        tau = outside_torques(seg, hand, mu, reach=NEGATIVE_REACH)
        for engine in engines:
            t = time.perf_counter()
            run = validate_plan(seg, engine, mu, torques=tau, expect="disagree",
                                name=f"{name} negative")
            rows.append({**base, "kind": "negative: efforts outside the regions",
                         "engine": engine, "mu": _mu_text(mu),
                         "status": run.verdict.outcome.value,
                         "wall_s": round(time.perf_counter() - t, 2), **_measured(run)})
            print(rows[-1], flush=True)
    return rows


def closing_table(rows: list[dict]) -> str:
    """task | segments | modes | planning time | friction box | engines agreed."""
    out = ["| task | segments | modes | planning time | friction box | engines agreed |",
           "|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r["task"] for r in rows):
        rs = [r for r in rows if r["task"] == name]
        r0 = rs[0]
        val = [r for r in rs if r.get("kind") == "validate"]
        neg = [r for r in rs if str(r.get("kind", "")).startswith("negative")]
        agreed = sorted({r["engine"] for r in val if r["status"] == "agreed"}
                        - {r["engine"] for r in val if r["status"] != "agreed"})
        neg_ok = all(r["status"] == "disagreed" for r in neg)
        out.append(f"| {name} | {r0['segments']} | {', '.join(r0['modes'])} | "
                   f"{r0['planning_s']:.1f} s | {r0['friction_box']} | "
                   f"{', '.join(agreed) or 'none'} ({len(val)} runs); negative control "
                   f"{'failed in every engine' if neg and neg_ok else 'not run or passed'} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/field_tasks.json")
    ap.add_argument("--engines", default=",".join(e for e in ENGINES if e != "dart"))
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--one-mu", action="store_true",
                    help="validate at the first of the plan's validation frictions only")
    ap.add_argument("--keep", action="store_true",
                    help="keep the rows of the other tasks already in --out (re-run some tasks)")
    args = ap.parse_args(argv)
    tasks = args.tasks.split(",")
    names = [_task_path(t).stem for t in tasks]
    rows: list[dict] = []
    if args.keep and Path(args.out).is_file():
        rows = [r for r in json.loads(Path(args.out).read_text()) if r.get("task") not in names]
    for task in tasks:
        rows += task_rows(task, tuple(args.engines.split(",")), one_mu=args.one_mu)
    rows.sort(key=lambda r: TASKS.index(r["task"]) if r["task"] in TASKS else len(TASKS))
    atomic_write_json(args.out, rows)
    print(closing_table(rows))
    print(f"{len(rows)} rows -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
