"""Two boxes on several table supports where MuJoCo misses a right prediction
(docs/simulation-measurements.md, "MuJoCo: boxes on many supports").

Both files are validation-campaign points away from region boundaries on which pymunk agrees:

* ``tall_box_on_8_supports_slides.json``: a tall box (0.114 x 0.290 m) on 8 supports pushed by a
  frictionless finger at 0.82 of its slide/tip height; predicted to slide without turning. MuJoCo
  slides it in a stick-slip cycle of about 0.12 s that rocks it on its soft front supports: its
  mean rotation over the judged steps is nil, but the twist over the first 0.2 s of them (the
  certificate's stretch) is off by more than the tolerance.
* ``tall_box_on_3_supports_tips.json``: a tall box on 3 supports tipping about its front
  corner; MuJoCo tips it at the predicted rate, but the middle support, half a width from the
  pivot, keeps its load while the box has turned less than the support's penetration over its
  distance to the pivot.

The verdicts are strict ``xfail``: a change that makes MuJoCo agree on them must update the
record (and this file).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planner.files.system_file import load_system
from scenarios.runs import simulate_system
from sim.jobs import RunResult
from sim.verdict import Outcome

pytest.importorskip("mujoco")

DATA = Path(__file__).parents[1] / "data"
SLIDES = DATA / "tall_box_on_8_supports_slides.json"
TIPS = DATA / "tall_box_on_3_supports_tips.json"


@pytest.fixture(scope="module")
def slides() -> RunResult:
    return simulate_system(load_system(SLIDES), "mujoco")


@pytest.mark.slow
def test_rocking_box_turns_only_in_the_early_stretch(slides: RunResult) -> None:
    """The twist miss is the stick-slip rocking, not a turning box: the least-squares rotation
    rate over every judged step, times the size, is below 2 % of the drive speed, while the
    twist of the first 0.2 s misses by more than the 10 % tolerance; and the table contacts
    slip in bursts faster than twice the drive speed (the stick-slip cycle)."""
    res = slides
    p = res.summary.parameters
    rec = res.recording
    judged = rec.times >= p["settle_s"]
    rate = np.polyfit(rec.times[judged], rec.poses[judged, 0, 2], 1)[0]
    assert abs(rate) * p["size_m"] < 0.02 * p["drive_speed_m_per_s"]
    assert res.verdict.motion.twist_error > 0.10
    table = np.asarray(p["environment"], dtype=bool)
    burst = np.max(np.abs(rec.slip_velocity[judged][:, table]))
    assert burst > 2.0 * p["drive_speed_m_per_s"]


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="MuJoCo's stick-slip rocking on soft supports")
def test_rocking_box_agrees(slides: RunResult) -> None:
    assert slides.verdict.outcome == Outcome.AGREED, slides.verdict.reason


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="a soft support near the pivot keeps its load")
def test_tipping_box_agrees() -> None:
    res = simulate_system(load_system(TIPS), "mujoco")
    assert res.verdict.outcome == Outcome.AGREED, res.verdict.reason
