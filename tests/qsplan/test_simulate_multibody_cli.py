"""``qsplan simulate`` on a file with several workpieces (the one pipeline: sim.jobs, judged per
contact and per body twist)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from qsplan.cli import main
from scenarios.registry import DATA_DIR

TOGETHER = "0.15,0.15,0.9,0.9,0"  # both blocks slide together (scenarios/simulations.py)


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("engine", ["pymunk", "mujoco"])
@pytest.mark.parametrize("data, mode", [("stacked_blocks", "R1 R2 S-3 S-4 R5"),
                                        ("stacked_blocks_lower", "S-1 S-2 R3 R4 R5")])
@pytest.mark.long
def test_stacked_blocks_agree(tmp_path: Path, engine: str, data: str, mode: str) -> None:
    out = tmp_path / "run"
    code = main(["simulate", str(DATA_DIR / f"{data}.json"), "--engine", engine,
                 "--out", str(out)])
    s = _summary(out)
    assert (code, s["status"], s["passed"], s["expect"]) == (0, "agreed", True, "agree")
    assert s["predicted"]["labels"] == [mode]
    assert s["observed"]["counts"].get(mode, 0) >= 0.95 * s["judged_steps"] > 0
    assert len(s["motion"]["twist_observed"]) == 3 * s["parameters"]["n_bodies"] == 6
    assert s["motion"]["twist_error"] <= 0.1


def test_judge_mu_is_a_negative_control(tmp_path: Path) -> None:
    out = tmp_path / "neg"
    code = main(["simulate", str(DATA_DIR / "stacked_blocks.json"), "--judge-mu", TOGETHER,
                 "--out", str(out)])
    s = _summary(out)
    assert (code, s["status"], s["expect"], s["passed"]) == (1, "disagreed", "disagree", True)
    assert "R1 R2 S-3 S-4 R5" not in s["predicted"]["labels"]


def test_speed_and_kinetic_friction_apply_to_several_workpieces(tmp_path: Path) -> None:
    """The options of a one-workpiece file mean the same for several (the one pipeline)."""
    out = tmp_path / "opts"
    main(["simulate", str(DATA_DIR / "stacked_blocks.json"), "--speed", "0.001",
          "--mu-kinetic", "0.5,0.5,0.3,0.3,0", "--duration", "0.8", "--no-render",
          "--out", str(out)])
    p = _summary(out)["parameters"]
    assert p["drive_speed_m_per_s"] == pytest.approx(0.001)
    assert p["mu_kinetic"] == pytest.approx([0.5, 0.5, 0.3, 0.3, 0.0])
