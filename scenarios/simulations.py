"""The registered simulator scenarios, as data: the paper's examples (Sec. 4.1 eq. 37, Sec. 4.3
eq. 42), the ruler (Sec. 5.1), several workpieces (Sec. 6), the two-finger hand plan (Sec. 5.2),
and a negative control for each kind.

Each is a shipped file with friction and an expectation (:mod:`scenarios.registry`), run by
:func:`scenarios.runs.run_spec` through the same path as ``qsplan simulate`` / ``validate`` run a
user's file -- the same scene, scale, speed, settings and judge. Every one runs on every engine
of the settings table. The expected modes of the several-workpiece files are derived by hand in
``tests/planner/test_multibody.py``.
"""

from __future__ import annotations

from scenarios.registry import (
    Expect,
    Parameter,
    PlanRun,
    RulerRun,
    Scenario,
    SystemRun,
    register,
)
from sim.settings import ENGINES


def _mu(default: tuple[float, ...], judged: str) -> Parameter:
    return Parameter("mu", "floats", default, "-", 0.0, 10.0,
                     f"simulated friction, one per contact (judged at {judged})")


def system(name: str, summary: str, reference: str, expect: Expect, spec: SystemRun,
           tags: tuple[str, ...]) -> None:
    """Register a system-file scenario (``--set mu=...`` changes the simulated friction)."""
    judged = ("the judged friction" if spec.judge_mu is not None else "the same friction")
    register(Scenario(name=name, summary=summary, reference=reference, expect=expect,
                      parameters=(_mu(spec.mu, judged),), spec=spec, engines=ENGINES,
                      tags=("sim", *tags)))


# ---- the paper's examples (scenes sized by the pipeline: 37 m and 3.6 m files -> 0.4 m) -----
E41, E43 = "example_4_1", "example_4_3"
for _name, _summary, _data, _mu_v, _ref in (
        ("ex41_3s", "Example 4.1 inside the 3S region (S+1 S-2 S-3)", E41, (0.2, 0.3, 0.1),
         "Sec. 4.1, eq. 37, Fig. 3"),
        ("ex41_rs", "Example 4.1 inside the RS region (R1 S-2 B3)", E41, (0.75, 0.45, 0.55),
         "Sec. 4.1, eq. 37, Fig. 3"),
        ("ex41_jam", "Example 4.1 in a jam region: growing force", E41, (0.75, 0.95, 0.25),
         "Sec. 4.1, eq. 37, Fig. 3"),
        ("ex43_one", "Example 4.3 where one mode is feasible (S-1 R2 B3)", E43,
         (0.15, 0.65, 0.05), "Sec. 4.3, eq. 42, Figs. 5-6"),
        ("ex43_two", "Example 4.3 where two modes are feasible", E43, (0.05, 0.15, 0.85),
         "Sec. 4.3, eq. 42, Figs. 5-6"),
        ("ex43_three", "Example 4.3 where three modes are feasible", E43, (0.65, 0.15, 0.05),
         "Sec. 4.3, eq. 42, Figs. 5-6")):
    system(_name, _summary, _ref, Expect.AGREE, SystemRun(_data, _mu_v), ("paper",))
system("neg_ex41_wrong_region", "Negative control: 3S run judged by the RS region's prediction",
       "Sec. 4.1, eq. 37", Expect.DISAGREE,
       SystemRun(E41, (0.2, 0.3, 0.1), judge_mu=(0.75, 0.45, 0.55)), ("paper", "negative"))
system("neg_ex43_wrong_mu", "Negative control: two-mode run judged at the one-mode mu",
       "Sec. 4.3, eq. 42", Expect.DISAGREE,
       SystemRun(E43, (0.05, 0.15, 0.85), judge_mu=(0.15, 0.65, 0.05)), ("paper", "negative"))

# ---- several workpieces (friction: table, table, interface, interface, pusher; ...) ---------
UPPER_SLIDES = (0.5, 0.5, 0.3, 0.3, 0.0)   # mu_b W1 = 0.3 < mu_t (W0 + W1) = 1.5
TOGETHER = (0.15, 0.15, 0.9, 0.9, 0.0)     # mu_t (W0 + W1) = 0.45 < mu_b W1 = 0.9
RIGHT_SLIDES, LEFT_SLIDES = (0.4, 0.4, 0.5, 0.5), (0.2, 0.5, 0.5, 0.5)
CLIMB, GRIP = (0.3, 0.3, 0.3, 0.3, 0.9, 0.0, 0.1), (0.5, 0.5, 0.5, 0.5, 0.5, 0.0, 0.5)
SEC6 = "Sec. 6 (several workpieces)"
for _name, _summary, _expect, _spec in (
        ("mb_stack_upper_slides", "Stacked blocks pushed at the upper block: it slides over the "
         "resting lower one (R1 R2 S-3 S-4 R5)", Expect.AGREE,
         SystemRun("stacked_blocks", UPPER_SLIDES)),
        ("mb_stack_together", "Stacked blocks pushed at the upper block: both slide together "
         "(S-1 S-2 R3 R4 R5)", Expect.AGREE, SystemRun("stacked_blocks", TOGETHER)),
        ("neg_mb_stack_wrong_region", "Negative control: upper block sliding, judged at the "
         "friction where both slide together", Expect.DISAGREE,
         SystemRun("stacked_blocks", UPPER_SLIDES, judge_mu=TOGETHER)),
        ("mb_stack_lower_pushed", "Stacked blocks pushed at the lower block: the upper rides "
         "along (S-1 S-2 R3 R4 R5)", Expect.AGREE,
         SystemRun("stacked_blocks_lower", UPPER_SLIDES)),
        ("neg_mb_stack_lower_as_upper", "Negative control: the lower-pushed run judged by the "
         "upper-pushed prediction", Expect.DISAGREE,
         SystemRun("stacked_blocks_lower", UPPER_SLIDES, judge_source="stacked_blocks")),
        ("mb_ruler_block_right", "Ruler carrying a block on two approaching fingers: the right "
         "finger slides (R1 S-2 R3 R4)", Expect.AGREE, SystemRun("ruler_block", RIGHT_SLIDES)),
        ("mb_ruler_block_left", "Ruler carrying a block: a weaker left finger slides instead "
         "(S+1 R2 R3 R4)", Expect.AGREE, SystemRun("ruler_block", LEFT_SLIDES)),
        ("neg_mb_ruler_block_wrong_mu", "Negative control: right finger sliding, judged at the "
         "friction where the left one slides", Expect.DISAGREE,
         SystemRun("ruler_block", RIGHT_SLIDES, judge_mu=LEFT_SLIDES)),
        ("mb_wall_climb", "Part pushed against a slippery wall by a tool: it climbs "
         "(S-1 B2 S-3 S-4 R5 R6 S-7)", Expect.AGREE, SystemRun("part_tool_wall", CLIMB)),
        ("mb_wall_jam", "Part pushed against a gripping wall by a tool: jam", Expect.AGREE,
         SystemRun("part_tool_wall", GRIP)),
        ("neg_mb_wall_climb_as_jam", "Negative control: the climbing run judged at the gripping "
         "wall's friction (a jam predicted)", Expect.DISAGREE,
         SystemRun("part_tool_wall", CLIMB, judge_mu=GRIP))):
    system(_name, _summary, SEC6, _expect, _spec, ("multibody",))


# ---- the ruler ------------------------------------------------------------------------------
def ruler(name: str, summary: str, expect: Expect, spec: RulerRun) -> None:
    """Register a ruler scenario with its typed parameters."""
    params = (
        Parameter("mu_s", "float", spec.mu_s, "-", 0.0, 10.0, "static friction"),
        Parameter("mu_k", "float", spec.mu_k, "-", 0.0, 10.0,
                  "kinetic friction (= mu_s: one Coulomb coefficient)"),
        Parameter("left", "float", -0.4, "L", -0.5, -0.01,
                  "left finger from the centre of mass, rod lengths"),
        Parameter("right", "float", 0.25, "L", 0.01, 0.5,
                  "right finger from the centre of mass, rod lengths"),
        Parameter("speed", "float", None, "m/s", 1e-6, 0.01, "speed of each finger"),
    )
    register(Scenario(name=name, summary=summary, reference="Sec. 5.1 (ruler on two fingers)",
                      expect=expect, parameters=params, spec=spec, engines=ENGINES,
                      tags=("sim", "paper", "ruler")))


ruler("ruler_single_mu", "Ruler, one mu = 0.5: far finger slides until equidistant",
      Expect.AGREE, RulerRun(0.5, 0.5, required=1))
ruler("ruler_static_kinetic", "Ruler, static 0.5 / kinetic 0.3: alternating slides",
      Expect.AGREE, RulerRun(0.5, 0.3))
ruler("neg_ruler_wrong_mu", "Negative control: static/kinetic run judged with kinetic 0.4",
      Expect.DISAGREE, RulerRun(0.5, 0.3, predict_mu_k=0.4))

# ---- the two-finger hand plan (the first 6 waypoints: 1.7 s of the 13.3 s segment) ----------
_W = Parameter("waypoints", "int", 6, "-", 2, 1000,
               "run the plan's first so many waypoints (qsplan demo runs them all)")
register(Scenario(
    name="hand_4s_plan",
    summary="two-finger hand: planned 4S segment, torque in the band guaranteed for mu in "
            "[0, 0.2], run at mu = 0.1", reference="Sec. 5.2, Figs. 9-13", expect=Expect.AGREE,
    spec=PlanRun("two_finger_hand", mu=0.1, waypoints=6), engines=ENGINES, parameters=(_W,),
    tags=("sim", "paper", "hand")))
register(Scenario(
    name="neg_hand_r2s_torque",
    summary="negative control: torque in the R2S band while the plan claims 4S, mu = 0.2 "
            "(validation must fail)", reference="Sec. 5.2, Figs. 11-12", expect=Expect.DISAGREE,
    spec=PlanRun("two_finger_hand", mu=0.2, policy="rival:R2S", waypoints=6), engines=ENGINES,
    parameters=(_W,), tags=("sim", "paper", "hand", "negative")))
