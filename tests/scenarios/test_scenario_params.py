"""Typed scenario parameters: ``scenarios show NAME`` and ``scenarios run NAME --set k=v``."""

from __future__ import annotations

import json

import pytest

from planner.errors import InputError
from qsplan.cli import main
from scenarios.registry import Parameter, all_scenarios, get, parse_settings

RULER_KEYS = {"mu_s", "mu_k", "left", "right", "speed"}


def test_ruler_and_examples_declare_their_parameters() -> None:
    table = all_scenarios()
    rulers = [sc for sc in table.values() if "ruler" in sc.tags]
    examples = [sc for n, sc in table.items() if n.startswith(("ex4", "neg_ex4"))]
    assert rulers and examples
    for sc in rulers:
        assert RULER_KEYS <= {p.name for p in sc.parameters}
    for sc in examples:
        assert "mu" in {p.name for p in sc.parameters}


def test_show_lists_defaults_units_and_ranges(capsys) -> None:
    assert main(["scenarios", "show", "ruler_static_kinetic"]) == 0
    out = capsys.readouterr().out
    for key in RULER_KEYS:
        assert key in out
    assert "default -0.4" in out and "unit L" in out and "[-0.5, -0.01]" in out


@pytest.mark.parametrize("setting,message", [
    ("left=0.2", "--set left: expected a number in [-0.5, -0.01], got '0.2'"),
    ("mu_s=abc", "--set mu_s: expected a number in [0.0, 10.0], got 'abc'"),
    ("nope=1", "unknown parameter 'nope' of scenario 'ruler_static_kinetic'; expected one of"),
    ("nope=1", "; got 'nope'"),
    ("left", "--set: expected key=value, got 'left'"),
])
def test_bad_settings_exit_2_naming_expected_and_got(setting, message, tmp_path, capsys) -> None:
    code = main(["scenarios", "run", "ruler_static_kinetic", "--out", str(tmp_path / "o"),
                 "--set", setting])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_parse_settings_types() -> None:
    sc = get("ex41_3s")
    assert parse_settings(sc, ["mu=0.1,0.2,0.3"]) == {"mu": (0.1, 0.2, 0.3)}
    p = Parameter("n", "int", 3, lo=1, hi=5)
    assert p.parse("4") == 4
    with pytest.raises(InputError, match="expected an integer in"):
        p.parse("4.5")


def test_ruler_run_takes_the_layout_and_reports_length(tmp_path, capsys) -> None:
    """A short single-mu ruler from another layout: the far (right) finger slides first."""
    out = tmp_path / "r"
    code = main(["scenarios", "run", "ruler_single_mu", "--engine", "pymunk", "--no-render",
                 "--out", str(out), "--set", "left=-0.15", "--set", "right=0.3",
                 "--set", "speed=0.002"])
    s = json.loads((out / "summary.json").read_text())
    assert s["parameters"]["length_m"] == pytest.approx(0.1)
    assert s["parameters"]["finger_x_m"] == pytest.approx([-0.015, 0.03])
    assert s["predicted"]["sliding_finger"][0] == 1
    # single mu: the far finger slides until both are equidistant, 0.15 L from the COM
    assert s["predicted"]["switch_positions_m"][0] == pytest.approx(0.015, rel=1e-6)
    assert code == 0 and s["status"] == "agreed"
