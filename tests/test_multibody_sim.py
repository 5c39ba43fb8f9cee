"""Several workpieces in both engines (issue 17): the scenes of sim/scenes/multibody.py run in
slow motion and are judged per contact and per body (sim/multibody_run.py) against the
planner's prediction at friction points in different regions, each with a negative control
(the same run judged at friction, or against a push, it was not run at) that must disagree.

The expected modes are derived by hand in tests/test_multibody.py; here the simulators check
them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.files.system_file import load_system, system_from_dict
from scenarios.registry import DATA_DIR
from sim.compare import Outcome
from sim.multibody_run import simulate_multibody
from sim.scenes.multibody import multibody_scene

ENGINES = ("pymunk", "mujoco")
STACK = DATA_DIR / "stacked_blocks.json"
UPPER_SLIDES = [0.5, 0.5, 0.3, 0.3, 0.0]    # mu_b W1 = 0.3 < mu_t (W0 + W1) = 1.5
TOGETHER = [0.15, 0.15, 0.9, 0.9, 0.0]      # mu_t (W0 + W1) = 0.45 < mu_b W1 = 0.9


def lower_pushed():
    data = json.loads(STACK.read_text())
    data["contacts"][4] = {"point": [-1.0, 0.5], "normal": [1.0, 0.0], "mu": 0.0, "body": 0}
    return system_from_dict(data)


def test_scene_has_one_site_per_contact_with_planner_signs() -> None:
    """A contact between two workpieces is a foot on the other body touching the body its
    normal points into: pair (body_a = other, body_b = body), the engine's reading convention
    (normal into body_b, slip of body_b minus body_a) is then eq. (5)'s."""
    system = load_system(STACK)
    scene = multibody_scene(system)
    pairs = {p.name: p for p in scene.pairs}
    assert [p.name for p in scene.pairs] == ["c1", "c2", "c3", "c4", "c5"]
    assert (pairs["c3"].body_a, pairs["c3"].body_b) == ("work0", "work1")
    assert pairs["c3"].shape_a != pairs["c4"].shape_a  # one foot per contact
    foot = scene.body("work0").shapes[pairs["c3"].shape_a]
    top = np.array(foot.center) + np.array([0.0, foot.radius])  # rim point towards work1
    assert np.allclose(top, [-0.45, 1.0 + scene.meta["preload_m"]])


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("mu, control", [(UPPER_SLIDES, TOGETHER), (TOGETHER, UPPER_SLIDES)])
def test_stacked_blocks_pushed_at_the_upper_block(engine, mu, control) -> None:
    """The upper block slides over the resting lower one (``R1 R2 S-3 S-4 R5``) or both slide
    together (``S-1 S-2 R3 R4 R5``): the run agrees at its own friction, contact by contact and
    body twist by body twist, and disagrees when judged at the other region's friction."""
    system = load_system(STACK)
    run = simulate_multibody(system, engine, mu=mu)
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reason
    negative = simulate_multibody(system, engine, mu=mu, judge_mu=control)
    assert negative.verdict.outcome is Outcome.DISAGREED, negative.verdict.reason


@pytest.mark.parametrize("engine", ENGINES)
def test_stacked_blocks_pushed_at_the_lower_block(engine) -> None:
    """The upper block rides along (``S-1 S-2 R3 R4 R5``, both twists (1, 0, 0) times the
    drive); judged against the stack pushed at the upper block (which predicts the upper block
    sliding at this friction), the same run disagrees."""
    system = lower_pushed()
    run = simulate_multibody(system, engine, mu=UPPER_SLIDES)
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reason
    assert np.allclose(run.twists, [[1, 0, 0], [1, 0, 0]], atol=0.05)
    negative = simulate_multibody(system, engine, mu=UPPER_SLIDES,
                                  judge_system=load_system(STACK))
    assert negative.verdict.outcome is Outcome.DISAGREED, negative.verdict.reason


@pytest.mark.parametrize("engine", ENGINES)
def test_ruler_carrying_a_block(engine) -> None:
    """A ruler (1 N) with a block (1 N) on its left part, on two fingers approaching each other
    (Sec. 5.1 with a payload): the joint centre of mass (x = -0.15) puts 1.23 N on the left
    finger and 0.77 N on the right one. With mu = 0.4 on both the right finger slides
    (0.308 N friction needed < 0.4 * 0.77; the left one would need the same 0.308 < 0.49):
    ``R1 S-2 R3 R4``; with mu = (0.2, 0.5) the left finger's limit 0.246 N is the smaller one
    and it slides instead: ``S+1 R2 R3 R4``. The block rides along in both (no horizontal load
    on it). Each run agrees at its friction and disagrees judged at the other's."""
    system = load_system(DATA_DIR / "ruler_block.json")
    right, left = [0.4, 0.4, 0.5, 0.5], [0.2, 0.5, 0.5, 0.5]
    for mu, control in ((right, left), (left, right)):
        run = simulate_multibody(system, engine, mu=mu)
        assert run.verdict.outcome is Outcome.AGREED, run.verdict.reason
        negative = simulate_multibody(system, engine, mu=mu, judge_mu=control)
        assert negative.verdict.outcome is Outcome.DISAGREED, negative.verdict.reason


@pytest.mark.parametrize("engine", ENGINES)
def test_part_pushed_against_a_wall_by_a_tool(engine) -> None:
    """The part climbs the slippery wall (mu_w = 0.1, tool friction 0.9: ``S-1 B2 S-3 S-4 R5
    R6 S-7``, twist (2, 0, 4) times the drive) and everything jams at a gripping wall
    (mu_w = 0.5): both runs agree with their predictions and disagree judged at each other's
    friction."""
    system = load_system(DATA_DIR / "part_tool_wall.json")
    climb, grip = [0.3] * 4 + [0.9, 0.0, 0.1], [0.5] * 4 + [0.5, 0.0, 0.5]
    for mu, control in ((climb, grip), (grip, climb)):
        run = simulate_multibody(system, engine, mu=mu)
        assert run.verdict.outcome is Outcome.AGREED, run.verdict.reason
        negative = simulate_multibody(system, engine, mu=mu, judge_mu=control)
        assert negative.verdict.outcome is Outcome.DISAGREED, negative.verdict.reason
