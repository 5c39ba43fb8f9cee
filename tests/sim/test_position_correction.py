"""Motion by position correction: a flat wedge pushed down its 21.5 deg slope by a
frictionless finger (tests/data/flat_wedge_pushed_down_slope.json, written from the docs).

By hand: the finger presses along the slope's inward normal, 21.5 deg from the vertical, so a
finger force ``F`` pushes the wedge sideways with ``F sin 21.5`` and into the table with
``F cos 21.5``; the table holds it for every ``F`` when ``mu_table >= tan 21.5 deg = 0.394``
(the weight only adds normal force): the finger cannot advance, a jam. Below that the wedge
slides left. pymunk removes the overlap the finger makes by pushing the wedge away outside its
velocity solve, without friction, so it slides in pymunk either way: its run is reported as
one the engine cannot judge, never as a disagreement with a right prediction. MuJoCo and DART
show the jam, and disagree with it when the table is slippery (the negative control)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from test_natural_geometry import simulate

from planner.files.system_file import load_system
from planner.predict.feasibility import feasible_modes

WEDGE = "flat_wedge_pushed_down_slope.json"
DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.mark.parametrize("mu,jam", [(0.43, True), (0.40, True), (0.38, False), (0.30, False)])
def test_the_jam_threshold_is_tan_of_the_slope(mu: float, jam: bool) -> None:
    system = load_system(DATA / WEDGE)
    pred = feasible_modes(system, [mu, mu, 0.0])
    assert (not pred.all_modes) == jam
    if not jam:
        assert [m.mode.label for m in pred.all_modes] == ["S+1 S+2 R3"]  # t = (-1, 0): left


Run = tuple[int, dict[str, Any]]


@pytest.fixture(scope="module")
def nominal(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Run]:
    """``qsplan simulate`` of the wedge at its file's friction in an engine, each engine run
    once for this module's tests."""
    runs: dict[str, Run] = {}

    def run(engine: str) -> Run:
        if engine == "dart":
            pytest.importorskip("dartpy")
        if engine not in runs:
            runs[engine] = simulate(WEDGE, engine, tmp_path_factory.mktemp(f"wedge-{engine}"))
        return runs[engine]
    return run


@pytest.mark.long
def test_pymunk_cannot_judge_a_wedge_it_moves_by_position_correction(
        nominal: Callable[[str], Run]) -> None:
    code, s = nominal("pymunk")
    assert code == 1 and s["status"] == "inconclusive", s["reason"]
    assert "position correction" in s["reason"]


@pytest.mark.long
@pytest.mark.parametrize("engine", ["dart", pytest.param("mujoco", marks=pytest.mark.slow)])
def test_engines_without_it_show_the_jam_and_its_negative_control_fails(
        engine: str, nominal: Callable[[str], Run], tmp_path: Path) -> None:
    code, s = nominal(engine)
    assert code == 0 and s["status"] == "agreed", s["reason"]
    assert s["predicted"]["labels"] == ["JAM"]
    code, s = simulate(WEDGE, engine, tmp_path, "--mu", "0.3,0.3,0", "--judge-mu", "0.43,0.43,0")
    assert code == 1 and s["status"] == "disagreed", s["reason"]


@pytest.mark.long
def test_the_consensus_names_position_correction_as_pymunks_artefact(
        nominal: Callable[[str], Run]) -> None:
    """pymunk's wedge run measures the artefact; with DART's agreeing run and MuJoCo's
    (recorded as agreed here: the consensus reads summaries), pymunk is the odd engine and
    its cause is named. (DART removes overlap outside its velocities too in a jam, but its
    forces grow and it shows the jam.)"""
    pytest.importorskip("dartpy")
    from sim.consensus import consensus

    _, s_pm = nominal("pymunk")
    _, s_dart = nominal("dart")
    kinds = [a["kind"] for a in s_pm["observed"]["engine_measures"]["artefacts"]]
    assert "position_correction" in kinds
    assert s_dart["status"] == "agreed"
    s_mj = dict(s_dart, engine="mujoco")
    c = consensus([s_pm, s_dart, s_mj])
    assert c.odd == ("pymunk",) and "position correction" in " ".join(c.causes["pymunk"])
