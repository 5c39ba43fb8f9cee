"""``qsplan simulate``: bad input exits 2 naming expected vs got, before any simulation."""

from __future__ import annotations

import json

import pytest

from qsplan.cli import main
from scenarios.registry import DATA_DIR

BOX = str(DATA_DIR / "box_on_table_high.json")

JOINT_SPACE = {
    "contacts": [{"point": [-0.4, 0.0], "normal": [0.0, 1.0], "mu": 0.3},
                 {"point": [0.25, 0.0], "normal": [0.0, 1.0], "mu": 0.3}],
    "external_wrench": [0.0, -1.0, 0.0],
    "manipulator": {"jacobian": [[[0.0, 0.0], [-1.0, 0.0]], [[0.0, 0.0], [0.0, -1.0]]],
                    "joints": [{"velocity": 0.001}, {"velocity": -0.001}]},
}


@pytest.mark.parametrize("extra,message", [
    (["--engine", "bullet"], "--engine: expected one of pymunk, mujoco, dart, got 'bullet'"),
    (["--mu", "0.3,x"], "--mu: expected comma-separated numbers, got 'x'"),
    (["--mu", "0.3,0.3"], "mu: expected 3 friction coefficients (one per contact), got shape (2,)"),
    (["--judge-mu", "-1"], "--judge-mu: expected a number in [0"),
    (["--duration", "0.1"], "--duration: expected seconds in (0.3, 600]"),
    (["--speed", "0"], "--speed: expected a finite speed > 0"),
])
def test_bad_options_exit_2(extra, message, capsys) -> None:
    assert main(["simulate", BOX, *extra]) == 2
    assert message in capsys.readouterr().err


def test_joint_space_manipulator_is_refused(tmp_path, capsys) -> None:
    f = tmp_path / "rod.json"
    f.write_text(json.dumps(JOINT_SPACE))
    assert main(["simulate", str(f)]) == 2
    assert "expected a system given by contact velocities" in capsys.readouterr().err


def test_output_path_checked_before_any_work(tmp_path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["simulate", BOX, "--out", str(blocker / "sub")]) == 2
    assert "--out" in capsys.readouterr().err


def test_missing_file_exits_2(tmp_path, capsys) -> None:
    assert main(["simulate", str(tmp_path / "nope.json")]) == 2
    assert "expected an existing file, got no such file" in capsys.readouterr().err
