"""Acceptance test of ``qsplan simulate`` (issue 14): a box on a table pushed by one finger.

The system files ``scenarios/data/box_on_table_low.json`` / ``_high.json``: a box of width
``w = 0.08`` m, height ``0.12`` m and weight ``m g = 0.981`` N stands on a table (contacts 1 and 2
at the rear and front bottom corners, ``"environment": true``, normal ``+y``, friction ``mu``); a
frictionless finger (contact 3, normal ``+x``) pushes the rear face at height ``y`` above the
table, moving ``+x``.

Boundary between sliding and tipping, by hand (quasistatic, the paper's modes; ``t = rot90(n)``):

* **sliding** ``S-1 S-2 R3``: the box translates in ``+x``, both table contacts slide (their
  friction ``mu N_1``, ``mu N_2`` points ``-x``), the finger rolls. With a frictionless finger of
  normal force ``P``: ``P = mu (N_1 + N_2)`` and ``N_1 + N_2 = m g``, so ``P = mu m g``. Moments
  about the front corner ``(w, 0)``: the push ``P`` at height ``y`` gives ``-P y``, the weight at
  ``x = w/2`` gives ``+m g w/2``, the rear normal force at distance ``w`` gives ``-N_1 w``, the
  table friction forces act on the line ``y = 0`` (no moment):
  ``N_1 = m g / 2 - P y / w = m g (1/2 - mu y / w)``. The mode needs ``N_1 >= 0``:
  **slides iff** ``y <= w / (2 mu)``.
* **tipping** ``B1 R2 S+3``: the box turns about its front corner, the rear contact opens
  (``N_1 = 0``), the front corner sticks, the finger slides up the face (the face point at height
  ``y`` moves ``(omega y, omega w)``, so ``v_t3 > 0``). Moments about the front corner:
  ``P y = m g w / 2``; forces: ``N_2 = m g``, friction at the corner ``F_2 = P``. Sticking needs
  ``P <= mu N_2``: ``m g w / (2 y) <= mu m g``: **tips iff** ``y >= w / (2 mu)``.

So the boundary is ``y* = w / (2 mu)``: ``0.133`` m at ``mu = 0.3``, ``0.044`` m at ``mu = 0.9``.
The low file (``y = 0.06``, ``mu = 0.3``) slides; the high file (``y = 0.10``, ``mu = 0.9``) tips.
Both heights lie between the two boundaries, so each run judged at the *other* file's friction
(``--judge-mu``) must disagree: the negative controls. The planner reproduces the hand values
(test below: ``P = mu m g`` sliding, ``P = m g w / (2 y)`` tipping).

The observation is the simulator's own contact data (:mod:`sim.classify`); the prediction is the
planner's, made at the scene's (slow-motion) contact speeds. MuJoCo's low push shows stick-slip:
the box's mean velocity is the drive speed (twist within 3 % of the certificate's ``qdot``), but
the table contacts slide above the slip threshold on only ~50 % of the steps and the finger
touches on ~20 % (the box sticks, the soft finger contact loads up, the box jumps ahead). That
run is ``inconclusive`` with this measured cause (:func:`sim.system_run.stick_slip_verdict`),
never a pass; its negative control still disagrees (the tipping twist is far from the sliding
one). docs/simulation.md has the measurement.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.files.system_file import load_system
from planner.predict.feasibility import feasible_modes
from qsplan.cli import main
from scenarios.registry import DATA_DIR
from sim.compare import Outcome
from sim.system_run import ENGINE, RATE, judge_recording, simulate_system

W, WEIGHT = 0.08, 0.981
CASES = {"low": (0.06, 0.3, "S-1 S-2 R3"), "high": (0.10, 0.9, "B1 R2 S+3")}
OTHER = {"low": "high", "high": "low"}
DURATION = {"pymunk": 1.0, "mujoco": 2.0}
#: What each run must show: agreed, except MuJoCo's low push, whose stick-slip is reported as
#: inconclusive with its measured cause (module docstring) -- never as a pass.
EXPECTED = {("low", "pymunk"): Outcome.AGREED, ("high", "pymunk"): Outcome.AGREED,
            ("low", "mujoco"): Outcome.INCONCLUSIVE, ("high", "mujoco"): Outcome.AGREED}


def box(case: str):
    return load_system(DATA_DIR / f"box_on_table_{case}.json")


@pytest.mark.parametrize("case", ["low", "high"])
def test_boundary_by_hand_matches_planner(case: str) -> None:
    y, mu, label = CASES[case]
    sliding = y <= W / (2 * mu)
    assert sliding == (case == "low")
    pred = feasible_modes(box(case))
    assert pred.labels == [label]
    force = pred.all_modes[0].contact_forces[2][0]
    expected = mu * WEIGHT if sliding else WEIGHT * W / (2 * y)
    assert force == pytest.approx(expected, rel=1e-6)
    other_mu = CASES[OTHER[case]][1]
    assert feasible_modes(box(case).with_mu([other_mu, other_mu, 0.0])).labels \
        == [CASES[OTHER[case]][2]]


_RUNS: dict[tuple[str, str], object] = {}


def run(case: str, engine: str):
    key = (case, engine)
    if key not in _RUNS:
        _RUNS[key] = simulate_system(box(case), engine, duration=DURATION[engine])
    return _RUNS[key]


@pytest.mark.parametrize("case,engine", sorted(EXPECTED))
def test_box_agrees_and_negative_control_disagrees(case: str, engine: str) -> None:
    res = run(case, engine)
    assert res.verdict.outcome is EXPECTED[case, engine], res.verdict.reason
    if EXPECTED[case, engine] is Outcome.AGREED:
        assert res.summary["observed"]["counts"] == {CASES[case][2]: res.verdict.judged_steps}
    else:
        assert "stick-slip" in res.verdict.reason
    # the same recording judged at the other case's friction: the negative control
    other_mu = CASES[OTHER[case]][1]
    judged = feasible_modes(box(case).with_mu([other_mu, other_mu, 0.0]))
    p = res.summary["parameters"]
    verdict, _, _ = judge_recording(res.recording, judged, engine, p["drive_speed_m_per_s"],
                                    WEIGHT, p["length"])
    assert verdict.outcome is Outcome.DISAGREED, verdict.reason


def test_box_moves_as_predicted_pymunk() -> None:
    """The observed motion itself (not only labels): sliding translates at the drive speed;
    tipping turns clockwise at ``omega = v / y`` about the front corner."""
    for case in ("low", "high"):
        res = run(case, "pymunk")
        rec = res.recording
        iw = rec.body_names.index("workpiece")
        k = rec.times >= ENGINE["pymunk"]["settle"]
        t, pose = rec.times[k], rec.poses[k, iw]
        vx = np.polyfit(t, pose[:, 0], 1)[0]
        omega = np.polyfit(t, pose[:, 2], 1)[0]
        v = res.summary["parameters"]["drive_speed_m_per_s"]
        assert v == pytest.approx(RATE["pymunk"] * res.summary["parameters"]["length"])
        if case == "low":
            assert vx == pytest.approx(v, rel=0.02)
            assert abs(omega) < 0.01 * v / CASES[case][0]
        else:
            assert omega == pytest.approx(-v / CASES[case][0], rel=0.05)


def test_cli_judge_mu_negative_control(tmp_path, capsys) -> None:
    f = str(DATA_DIR / "box_on_table_high.json")
    out = tmp_path / "agree"
    assert main(["simulate", f, "--engine", "pymunk", "--duration", "0.8", "--no-render",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "agreed" and summary["predicted"]["labels"] == ["B1 R2 S+3"]
    assert summary["expect"] == "agree" and summary["passed"] is True
    assert summary["parameters"]["length"] > 0
    code = main(["simulate", f, "--engine", "pymunk", "--duration", "0.8",
                 "--judge-mu", "0.3,0.3,0"])
    assert code == 1
    line = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert line["status"] == "disagreed" and line["predicted"] == ["S-1 S-2 R3"]
