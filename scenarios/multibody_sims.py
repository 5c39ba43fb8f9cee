"""Simulator scenarios of several workpieces (issue 17), each on pymunk and MuJoCo, with
negative controls: two stacked blocks pushed at the upper or the lower block, a ruler carrying a
block on two approaching fingers, a part pushed against a wall by a tool.

The expected modes are derived by hand in ``tests/test_multibody.py``; predictions come from
:func:`planner.predict.feasibility.feasible_modes` on the slow-motion system (checked equal to
the unscaled prediction), observations from the simulator's contact data and body poses only
(:func:`sim.multibody_run.simulate_multibody`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planner.files.atomic import atomic_write_json
from planner.files.system_file import load_system
from scenarios.registry import DATA_DIR, Parameter, Scenario, register
from sim.backends import ENGINES
from sim.compare import Expect

#: Friction of the stacked blocks (table, table, interface, interface, pusher).
UPPER_SLIDES = (0.5, 0.5, 0.3, 0.3, 0.0)   # mu_b W1 = 0.3 < mu_t (W0 + W1) = 1.5
TOGETHER = (0.15, 0.15, 0.9, 0.9, 0.0)     # mu_t (W0 + W1) = 0.45 < mu_b W1 = 0.9
#: Ruler with a block: the right / the left finger slides.
RIGHT_SLIDES, LEFT_SLIDES = (0.4, 0.4, 0.5, 0.5), (0.2, 0.5, 0.5, 0.5)
#: Part, tool and wall: the part climbs a slippery wall / everything jams at a gripping one.
CLIMB, GRIP = (0.3, 0.3, 0.3, 0.3, 0.9, 0.0, 0.1), (0.5, 0.5, 0.5, 0.5, 0.5, 0.0, 0.5)


def run_multibody(out_dir: Path, *, name: str, expect: Expect, data: str, mu: Any,
                  judge_mu: Any = None, judge_data: str | None = None,
                  engine: str = "pymunk", **_: Any) -> dict[str, Any]:
    """Run the shipped system ``data`` at ``mu`` on ``engine``, judged at ``judge_mu`` and/or
    against the prediction of ``judge_data`` (negative controls); writes ``summary.json``."""
    from planner.predict.feasibility import feasible_modes
    from sim.multibody_run import simulate_multibody

    system = load_system(DATA_DIR / f"{data}.json")
    judge = None if judge_data is None else load_system(DATA_DIR / f"{judge_data}.json")
    run = simulate_multibody(system, engine, mu=mu, judge_mu=judge_mu, judge_system=judge)
    base = system if judge is None else judge
    unscaled = feasible_modes(base.with_mu(mu if judge_mu is None else judge_mu)).labels
    verdict = run.verdict
    summary = {
        "scenario": name, "engine": engine, "expect": expect.value, **verdict.to_dict(),
        "passed": verdict.held(expect),
        "parameters": {"data": data, "mu": list(mu),
                       "judge_mu": None if judge_mu is None else list(judge_mu),
                       "judge_data": judge_data},
        "predicted": {"labels": run.predicted, "unscaled_labels": unscaled,
                      "scale_invariant": sorted(run.predicted) == sorted(unscaled or ["JAM"])},
        "observed": {"counts": dict(verdict.observed_counts),
                     "judged_steps": verdict.judged_steps,
                     "body_twists_over_drive": run.twists.tolist(),
                     "jammed_at_s": run.recording.jammed_at,
                     "fault": verdict.fault.reason if verdict.fault else None},
    }
    atomic_write_json(Path(out_dir) / "summary.json", summary)
    return summary


def _scenario(name: str, summary: str, expect: Expect, **kw: Any) -> None:
    mu = Parameter("mu", "floats", tuple(kw["mu"]), "-", 0.0, 10.0,
                   "simulated friction, one per contact")
    register(Scenario(name=name, summary=summary, reference="Sec. 6 (several workpieces)",
                      expect=expect, parameters=(mu,),
                      run=lambda out_dir, _n=name, _e=expect, _kw=kw, **opt: run_multibody(
                          Path(out_dir), name=_n, expect=_e, **{**_kw, **opt}),
                      engines=ENGINES, tags=("sim", "multibody")))


_scenario("mb_stack_upper_slides", "Stacked blocks pushed at the upper block: it slides over "
          "the resting lower one (R1 R2 S-3 S-4 R5)", Expect.AGREE, data="stacked_blocks",
          mu=UPPER_SLIDES)
_scenario("mb_stack_together", "Stacked blocks pushed at the upper block: both slide "
          "together (S-1 S-2 R3 R4 R5)", Expect.AGREE, data="stacked_blocks", mu=TOGETHER)
_scenario("neg_mb_stack_wrong_region", "Negative control: upper block sliding, judged at the "
          "friction where both slide together", Expect.DISAGREE, data="stacked_blocks",
          mu=UPPER_SLIDES, judge_mu=TOGETHER)
_scenario("mb_stack_lower_pushed", "Stacked blocks pushed at the lower block: the upper rides "
          "along (S-1 S-2 R3 R4 R5)", Expect.AGREE, data="stacked_blocks_lower",
          mu=UPPER_SLIDES)
_scenario("neg_mb_stack_lower_as_upper", "Negative control: the lower-pushed run judged by "
          "the upper-pushed prediction", Expect.DISAGREE, data="stacked_blocks_lower",
          mu=UPPER_SLIDES, judge_data="stacked_blocks")
_scenario("mb_ruler_block_right", "Ruler carrying a block on two approaching fingers: the "
          "right finger slides (R1 S-2 R3 R4)", Expect.AGREE, data="ruler_block",
          mu=RIGHT_SLIDES)
_scenario("mb_ruler_block_left", "Ruler carrying a block: a weaker left finger slides "
          "instead (S+1 R2 R3 R4)", Expect.AGREE, data="ruler_block", mu=LEFT_SLIDES)
_scenario("neg_mb_ruler_block_wrong_mu", "Negative control: right finger sliding, judged at "
          "the friction where the left one slides", Expect.DISAGREE, data="ruler_block",
          mu=RIGHT_SLIDES, judge_mu=LEFT_SLIDES)
_scenario("mb_wall_climb", "Part pushed against a slippery wall by a tool: it climbs "
          "(S-1 B2 S-3 S-4 R5 R6 S-7)", Expect.AGREE, data="part_tool_wall", mu=CLIMB)
_scenario("mb_wall_jam", "Part pushed against a gripping wall by a tool: jam", Expect.AGREE,
          data="part_tool_wall", mu=GRIP)
_scenario("neg_mb_wall_climb_as_jam", "Negative control: the climbing run judged at the "
          "gripping wall's friction (a jam predicted)", Expect.DISAGREE,
          data="part_tool_wall", mu=CLIMB, judge_mu=GRIP)
