"""Two boxes on several table supports where MuJoCo's soft contacts showed a right prediction
only through the judge's soft-contact rules (docs/simulation-measurements.md, "MuJoCo: boxes on
many supports"; docs/simulation.md, "Judging a run").

Both files are validation-campaign points away from region boundaries on which pymunk agrees:

* ``tall_box_on_8_supports_slides.json``: a tall box (0.114 x 0.290 m) on 8 supports pushed by a
  frictionless finger at 0.82 of its slide/tip height; predicted to slide without turning. MuJoCo
  slides it in a stick-slip cycle of about 0.12 s that rocks it on its soft front supports: the
  twist over the first 0.2 s of judged steps misses, the twist over the stretch in which the
  certificate's configuration holds (:func:`sim.judge.twist_stretch`) agrees.
* ``tall_box_on_3_supports_tips.json``: a tall box on 3 supports tipping about its front
  corner; MuJoCo tips it at the predicted rate, but the middle support, half a width from the
  pivot, keeps its load until the turn has lifted it out of its penetration: judged open from
  its clearing time (:func:`sim.judge_soft.clearing_times`) on, the run agrees.

Each ran ``disagreed`` with the judge's fixed 0.2 s stretch and without the clearing time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planner.files.system_file import load_system
from scenarios.runs import simulate_system
from sim.classify import twist_error
from sim.jobs import RunResult
from sim.verdict import TWIST_TOLERANCE, Outcome

pytest.importorskip("mujoco")

DATA = Path(__file__).parents[1] / "data"
SLIDES = DATA / "tall_box_on_8_supports_slides.json"
TIPS = DATA / "tall_box_on_3_supports_tips.json"


@pytest.fixture(scope="module")
def slides() -> RunResult:
    return simulate_system(load_system(SLIDES), "mujoco")


@pytest.mark.slow
def test_rocking_box_turns_only_in_the_early_stretch(slides: RunResult) -> None:
    """The stick-slip rocking is there: the least-squares rotation rate over every judged step,
    times the size, is below 2 % of the drive speed, while the twist of the first 0.2 s misses
    by more than the 10 % tolerance; and the table contacts slip in bursts faster than twice
    the drive speed (the stick-slip cycle)."""
    res = slides
    p = res.summary.parameters
    rec = res.recording
    exp = res.job.expectation
    judged = rec.times >= p["settle_s"]
    rate = np.polyfit(rec.times[judged], rec.poses[judged, 0, 2], 1)[0]
    assert abs(rate) * p["size_m"] < 0.02 * p["drive_speed_m_per_s"]
    t, pose = rec.times[judged], rec.poses[judged, 0]
    k = int(np.searchsorted(t, t[0] + 0.2 + 1e-9)) - 1
    early = (pose[k] - pose[0]) / (t[k] - t[0])
    assert twist_error(early, exp.twists()[0], exp.length, exp.drive) > TWIST_TOLERANCE
    table = np.asarray(p["environment"], dtype=bool)
    burst = np.max(np.abs(rec.slip_velocity[judged][:, table]))
    assert burst > 2.0 * p["drive_speed_m_per_s"]


@pytest.mark.slow
def test_rocking_box_agrees(slides: RunResult) -> None:
    """Over the stretch in which the certificate holds the rocking averages out."""
    v = slides.verdict
    assert v.outcome == Outcome.AGREED, v.reason
    assert v.motion.twist_error <= TWIST_TOLERANCE


@pytest.mark.slow
def test_tipping_box_agrees() -> None:
    """The middle support is judged open once the turn has lifted it out of its depth."""
    res = simulate_system(load_system(TIPS), "mujoco")
    assert res.verdict.outcome == Outcome.AGREED, res.verdict.reason
    assert any("lifted them out of their measured depth: 2 until" in r
               for r in res.verdict.reasons), res.verdict.reasons
