"""sim.plan_exec.compare and the `qsplan validate` argument checks (issue 5)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.cli import main
from planner.errors import InputError
from sim.plan_exec import ExecStatus, compare

CLAIM = "S-1 S-2 S+3 S+4"


def _poses(n, dx=-0.001):
    return np.column_stack([dx * np.arange(n), np.zeros(n), np.zeros(n)])


def test_agreeing_run_passes():
    n = 40
    obs = [CLAIM] * 39 + ["R1 S-2 S+3 S+4"]
    c = compare(CLAIM, obs, _poses(n), _poses(n))
    assert c.status is ExecStatus.PASSED and c.agree_fraction == pytest.approx(39 / 40)
    assert c.reasons == ()


def test_rival_mode_fails_with_reason():
    n = 40
    obs = ["R1 S-2 S+3 S+4"] * 20 + [CLAIM] * 20
    c = compare(CLAIM, obs, _poses(n), _poses(n))
    assert c.status is ExecStatus.FAILED
    assert "50.0%" in c.reasons[0] and "R1 S-2 S+3 S+4" in c.reasons[0]


def test_pose_drift_fails():
    n = 40
    sim = _poses(n)
    sim[-1, 0] += 0.05 * 0.039  # 5 % of the 39 mm travel
    c = compare(CLAIM, [CLAIM] * n, _poses(n), sim)
    assert c.status is ExecStatus.FAILED and c.final_error_of_travel == pytest.approx(0.05)
    assert "of travel" in c.reasons[0]


def test_bad_shapes_rejected():
    with pytest.raises(InputError, match=r"expected shape \(3, 3\).*got \(3, 2\)"):
        compare(CLAIM, [CLAIM] * 3, np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(InputError, match="positive travel, got 0"):
        compare(CLAIM, [CLAIM] * 3, np.zeros((3, 3)), np.zeros((3, 3)))


def test_validate_cli_bad_input(tmp_path):
    assert main(["validate", str(tmp_path / "missing.json")]) == 2
    assert main(["validate", str(tmp_path / "missing.json"), "--engine", "bullet"]) == 2
