"""``qsplan plan`` with a hand file's ``uncertainty`` section: the plan is guaranteed over the
mass / centre-of-mass set, says what its commands tolerate, writes it in ``extra.uncertainty``
(schema-valid, loads back), and a bad section exits 2 naming the field (docs/planning.md,
"Uncertainty beyond friction")."""

from __future__ import annotations

import json

import jsonschema
import pytest

from planner.files.schema import load_schema
from planner.plan.plan_file import load_plan
from qsplan.cli import main
from scenarios.registry import DATA_DIR


def _hand(tmp_path, section):
    d = json.loads((DATA_DIR / "table_push_hand.json").read_text())
    d["uncertainty"] = section
    path = tmp_path / "push.json"
    path.write_text(json.dumps(d))
    return path


def test_plan_prints_and_writes_the_tolerated_uncertainty(tmp_path, capsys):
    path = _hand(tmp_path, {"mass": [0.08, 0.12], "com": [[0.019, 0.021], [0.019, 0.021]]})
    out = tmp_path / "plan.json"
    assert main(["plan", str(path), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "guaranteed over mass [0.08, 0.12] kg, centre of mass x [19, 21] mm" in text
    assert "the commands tolerate mass the whole mass, centre of mass +-" in text
    doc = json.loads(out.read_text())
    unc = doc["extra"]["uncertainty"]
    assert unc["set"] == {"mass": [0.08, 0.12], "com": [[0.019, 0.021], [0.019, 0.021]]}
    assert unc["tolerated"]["mass_kg"] is None  # every force scales with the load (p = 0)
    assert 0.001 <= unc["tolerated"]["com_m"] < 0.02
    from referencing import Registry, Resource
    registry = Registry().with_resource("https://qsplan.example/schemas/hand.schema.json",
                                        Resource.from_contents(load_schema("hand")))
    validator = jsonschema.Draft202012Validator(load_schema("plan"), registry=registry)
    assert [e.message for e in validator.iter_errors(doc)] == []
    assert load_plan(out).segments[0].hand_model[0].load_set.mass == (0.08, 0.12)


def test_a_bad_section_exits_2_naming_the_field(tmp_path, capsys):
    path = _hand(tmp_path, {"mass": [0.2, 0.3]})
    assert main(["plan", str(path), "--out", str(tmp_path / "p.json")]) == 2
    err = capsys.readouterr().err
    assert "uncertainty: mass interval: expected 0 < lo <= 0.1" in err
    assert not (tmp_path / "p.json").exists()


@pytest.mark.long
def test_margins_flag_without_a_section(tmp_path, capsys):
    out = tmp_path / "plan.json"
    assert main(["plan", "table_push_hand", "--margins", "--out", str(out)]) == 0
    assert "at the nominal mass and centre of mass; the commands tolerate" in capsys.readouterr().out
    assert json.loads(out.read_text())["extra"]["uncertainty"]["set"] is None
