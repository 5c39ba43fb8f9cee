"""Simulator scenarios of the two-finger hand plan (Sec. 5.2, Figs. 9-13).

``hand_4s_plan``: the planned 4S segment (torque in the band guaranteed for mu in [0, 0.2]) run
at mu = 0.1; expected to agree (claimed mode >= 95 %, final position within 2 % of travel).
``neg_hand_r2s_torque``: the negative control (torque in the R2S band while claiming 4S) at
mu = 0.2; the validator must disagree.

By default only the first ``waypoints = 6`` waypoints (1.7 s of the 13.3 s segment) are run,
to keep the every-scenario test short; ``waypoints=None`` runs the whole segment (what
``qsplan demo`` does at mu = 0, 0.1, 0.2). The hand is simulated at its own SI size, so no
scaling is applied (``scale = 1``; the ``scale_invariant`` flag of the other simulator
scenarios is vacuously true here).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

from planner.files.atomic import atomic_write_json
from planner.plan.model import Segment
from scenarios.registry import Expect, Scenario, register, shipped_file
from sim.backends import ENGINES

HAND = "two_finger_hand"


@lru_cache(maxsize=4)
def _plan(policy: str) -> Segment:
    from planner.plan.hand_planner import plan_hand

    return plan_hand(shipped_file(HAND), mu=(0.0, 0.2), policy=policy).segments[0]


def run_hand(out_dir: Path, *, name: str, expect: Expect, policy: str, mu: float,
             engine: str = "pymunk", waypoints: int | None = 6, render: bool = True,
             **_: Any) -> dict[str, Any]:
    from sim.hand_run import run_plan

    plan = _plan(policy)
    res = run_plan(plan, engine, mu, out_dir, waypoints=waypoints, render=render, name=name,
                   expect=expect)
    n = waypoints or len(plan.waypoints)
    summary = dict(res.summary)
    summary.update({
        "scenario": name,
        "parameters": {"hand": HAND, "policy": policy, "mu": mu, "waypoints": n,
                       "mu_interval": list(plan.mu_intervals[0])},
        "predicted": {"claim": plan.claim,
                      "modes": sorted({lab for w in plan.waypoints[:n] for lab in w.predicted}),
                      "scale": 1.0, "scale_invariant": True},
        "observed": dict(res.verdict.observed_counts),
    })
    out_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


register(Scenario(
    name="hand_4s_plan",
    summary="two-finger hand: planned 4S segment, torque in the band guaranteed for mu in "
            "[0, 0.2], run at mu = 0.1",
    reference="Sec. 5.2, Figs. 9-13",
    expect=Expect.AGREE,
    run=lambda out, **kw: run_hand(out, name="hand_4s_plan", expect=Expect.AGREE, policy="midband",
                                   mu=0.1, **kw),
    engines=ENGINES, tags=("sim", "paper", "hand")))

register(Scenario(
    name="neg_hand_r2s_torque",
    summary="negative control: torque in the R2S band while the plan claims 4S, mu = 0.2 "
            "(validation must fail)",
    reference="Sec. 5.2, Figs. 11-12",
    expect=Expect.DISAGREE,
    run=lambda out, **kw: run_hand(out, name="neg_hand_r2s_torque", expect=Expect.DISAGREE,
                                   policy="rival:R2S", mu=0.2, **kw),
    engines=ENGINES, tags=("sim", "paper", "hand", "negative")))
