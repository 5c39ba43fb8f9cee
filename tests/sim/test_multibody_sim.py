"""Several workpieces in both engines: the scene builder (sim/scenes/multibody.py)
and the per-body judge (sim/judge.py). The scenarios themselves -- stacked blocks pushed
at either block, a ruler carrying a block, a part pushed against a wall by a tool, at friction
points in different regions, each with negative controls -- are registered in
scenarios/multibody_sims.py and run on both engines by tests/scenarios/test_scenarios.py; their expected
modes are derived by hand in tests/planner/test_multibody.py."""

from __future__ import annotations

import numpy as np
import pytest

from planner.files.system_file import load_system
from scenarios.registry import DATA_DIR
from scenarios.runs import simulate_system
from sim.scenes.system import system_scene
from sim.verdict import Outcome

ENGINES = ("pymunk", "mujoco")
STACK = DATA_DIR / "stacked_blocks.json"


def test_scene_has_one_site_per_contact_with_planner_signs() -> None:
    """A contact between two workpieces is a foot on the other body touching the body its
    normal points into: pair (body_a = other, body_b = body), the engine's reading convention
    (normal into body_b, slip of body_b minus body_a) is then eq. (5)'s."""
    system = load_system(STACK)
    scene = system_scene(system)
    pairs = {p.name: p for p in scene.pairs}
    assert [p.name for p in scene.pairs] == ["c1", "c2", "c3", "c4", "c5"]
    assert (pairs["c3"].body_a, pairs["c3"].body_b) == ("work0", "work1")
    assert pairs["c3"].shape_a != pairs["c4"].shape_a  # one foot per contact
    foot = scene.body("work0").shapes[pairs["c3"].shape_a]
    top = np.array(foot.center) + np.array([0.0, foot.radius])  # rim point towards work1
    assert np.allclose(top, [-0.45, 1.0 + scene.meta["preload_m"]])


def test_negative_control_system_must_match() -> None:
    from planner.errors import InputError

    with pytest.raises(InputError, match="judge system: expected the same number of contacts"):
        simulate_system(load_system(STACK), "pymunk",
                        judge_system=load_system(DATA_DIR / "ruler_block.json"))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.long
def test_stacked_blocks_pushed_at_the_lower_block(engine) -> None:
    """The upper block rides along (``S-1 S-2 R3 R4 R5``): both bodies' observed twists are
    (1, 0, 0) times the drive speed, body by body (the registered scenarios check the modes)."""
    run = simulate_system(load_system(DATA_DIR / "stacked_blocks_lower.json"), engine,
                          mu=[0.5, 0.5, 0.3, 0.3, 0.0])
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reason
    twists = np.asarray(run.verdict.motion.twist_observed).reshape(2, 3)
    drive = run.summary.parameters["drive_speed_m_per_s"]
    assert np.allclose(twists / drive, [[1, 0, 0], [1, 0, 0]], atol=0.05)
