"""The shipped JSON Schemas (planner/files/schemas): valid schemas; every shipped data file, the
docs' examples and a written plan validate; loader and schema agree on good and bad documents."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import pytest

jsonschema = pytest.importorskip("jsonschema")
referencing = pytest.importorskip("referencing")

from planner.errors import QsplanError  # noqa: E402
from planner.files.hand_file import hand_from_dict  # noqa: E402
from planner.files.schema import SCHEMA_KINDS, load_schema, schema_path  # noqa: E402
from planner.files.system_file import system_from_dict  # noqa: E402
from planner.plan.plan_file import digest, plan_from_dict, save_plan  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"
SCHEMAS = {k: load_schema(k) for k in SCHEMA_KINDS}
REGISTRY = referencing.Registry().with_resources(
    (s["$id"], referencing.Resource.from_contents(s)) for s in SCHEMAS.values())


def _validator(kind: str) -> Any:
    return jsonschema.Draft202012Validator(SCHEMAS[kind], registry=REGISTRY)


def schema_ok(kind: str, doc: Any) -> bool:
    return _validator(kind).is_valid(doc)


def _resign(d: dict) -> dict:
    """A fresh digest value (the algorithm is left as it is), so a mutated plan is judged on
    its content, not on the stale digest."""
    if isinstance(d.get("digest"), dict):
        d["digest"]["value"] = digest({k: v for k, v in d.items() if k != "digest"})
    return d


LOADERS = {"system": system_from_dict, "hand": hand_from_dict,
           "plan": lambda d: plan_from_dict(_resign(copy.deepcopy(d)) if isinstance(d, dict)
                                            and "digest" in d else d)}


def loader_ok(kind: str, doc: Any) -> bool:
    try:
        LOADERS[kind](copy.deepcopy(doc))
    except QsplanError:
        return False
    return True


def kind_of(doc: dict) -> str:
    if doc.get("format") == "qsplan-plan":
        return "plan"
    return "hand" if "palm" in doc else "system"


def doc_examples() -> list[tuple[str, str, dict, bool]]:
    """Every ``<!-- test: file NAME -->`` JSON block of docs/*.md: (doc, name, content, good);
    an example is a bad one when the next test marker runs a command expecting exit code 2."""
    out = []
    for md in sorted((ROOT / "docs").glob("*.md")):
        text = md.read_text()
        for m in re.finditer(r"<!-- test: file (\S+) -->\s*```json\n(.*?)```", text, re.S):
            after = re.search(r"<!-- test: (.*?)-->", text[m.end():])
            good = not (after and "exit=2" in after.group(1))
            out.append((md.name, m.group(1), json.loads(m.group(2)), good))
    return out


@pytest.fixture(scope="module")
def plan_dict(tmp_path_factory) -> dict:
    from planner.plan.hand_planner import plan_hand

    path = save_plan(plan_hand(DATA / "two_finger_hand.json", waypoints=3),
                     tmp_path_factory.mktemp("plan") / "plan.json")
    return json.loads(path.read_text())


@pytest.mark.parametrize("kind", SCHEMA_KINDS)
def test_schemas_are_valid_draft_2020_12(kind):
    jsonschema.Draft202012Validator.check_schema(SCHEMAS[kind])
    assert schema_path(kind).name == f"{kind}.schema.json"
    assert SCHEMAS[kind]["$id"].endswith(f"/{kind}.schema.json")


def test_schema_kinds_are_checked():
    with pytest.raises(QsplanError, match="schema: expected one of"):
        schema_path("muspace")


@pytest.mark.parametrize("path", sorted(DATA.glob("*.json")), ids=lambda p: p.name)
def test_every_shipped_data_file_validates(path):
    doc = json.loads(path.read_text())
    kind = kind_of(doc)
    errors = [e.message for e in _validator(kind).iter_errors(doc)]
    assert errors == []
    assert loader_ok(kind, doc)


def test_the_docs_examples_validate():
    examples = doc_examples()
    assert len(examples) >= 7  # the rod forms, example 4.1 and the scene-geometry examples
    assert any(not good for *_, good in examples)  # and a refused one
    for md, name, doc, good in examples:
        kind = kind_of(doc)
        errors = [e.message for e in _validator(kind).iter_errors(doc)]
        assert (errors == []) is good, f"{md}: {name}: {errors}"
        assert loader_ok(kind, doc) is good, f"{md}: {name}"


def test_a_written_plan_validates(plan_dict):
    assert [e.message for e in _validator("plan").iter_errors(plan_dict)] == []
    assert loader_ok("plan", plan_dict)


# ---- loader and schema agree -------------------------------------------------------------------
SYSTEM = {
    "contacts": [{"point": [0.0, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
                 {"point": [0.2, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
                 {"point": [0.0, 0.03], "normal": [1.0, 0.0], "mu": 0.5}],
    "external_wrench": [0.0, -1.0, -0.1],
    "manipulator": {"contact_velocities": [[0.0, 0.0], [0.0, 0.0], [0.001, 0.0]]},
    "workpiece": {"polygon": [[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]], "mass": 0.1},
}
JACOBIAN = {"contacts": SYSTEM["contacts"][2:], "external_wrench": [1.0, 0.0, 0.0],
            "manipulator": {"jacobian": [[[1.0, 0.0], [0.0, 1.0]]],
                            "joints": [{"velocity": 0.1}, {"effort": 1.0}]}}
CHAIN = {"contacts": SYSTEM["contacts"],
         "manipulator": {"chain": {"joints": [{"type": "prismatic", "origin": [-0.1, 0.03]}]},
                         "q": [0.0], "contact_links": [None, None, 0],
                         "joints": [{"velocity": 0.001}]}}


def _edit(base: Any, fn) -> Any:
    d = copy.deepcopy(base)
    fn(d)
    return d


def _system_cases() -> list[tuple[str, Any, bool]]:
    ex41 = json.loads((DATA / "example_4_1.json").read_text())
    s = SYSTEM
    return [
        ("box", s, True), ("jacobian", JACOBIAN, True), ("chain", CHAIN, True),
        ("example 4.1", ex41, True),
        ("tagged", _edit(s, lambda d: d.update(format="qsplan-system", version=1)), True),
        ("free keys", _edit(s, lambda d: [d.update(name="x", notes="y"),
                                          d["contacts"][0].update(comment="z")]), True),
        ("com given", _edit(s, lambda d: d["workpiece"].update(com=[0.05, 0.05])), True),
        ("scalar mu with W", _edit(ex41, lambda d: d.update(mu=0.2)), True),
        ("not an object", [s], False),
        ("contact without mu", _edit(s, lambda d: d["contacts"][2].pop("mu")), False),
        ("top-level mu with contacts", _edit(s, lambda d: d.update(mu=[0.1, 0.1, 0.1])), False),
        ("both forms", _edit(s, lambda d: d.update(wrench_matrix=ex41["wrench_matrix"])), False),
        ("neither form", _edit(s, lambda d: d.pop("contacts")), False),
        ("W without mu", _edit(ex41, lambda d: d.pop("mu")), False),
        ("unknown top key", _edit(s, lambda d: d.update(gravity=9.81)), False),
        ("unknown contact key", _edit(s, lambda d: d["contacts"][0].update(mu_k=0.1)), False),
        ("unknown manipulator key", _edit(s, lambda d: d["manipulator"].update(speed=1)), False),
        ("two manipulator forms", _edit(s, lambda d: d["manipulator"].update(
            jacobian=JACOBIAN["manipulator"]["jacobian"])), False),
        ("no manipulator", _edit(s, lambda d: d.pop("manipulator")), False),
        ("negative mu", _edit(s, lambda d: d["contacts"][0].update(mu=-0.1)), False),
        ("string number", _edit(s, lambda d: d["contacts"][0].update(point=["0", 0])), False),
        ("environment not bool", _edit(s, lambda d: d["contacts"][0].update(environment=1)),
         False),
        ("workpiece 2 vertices", _edit(s, lambda d: d["workpiece"].update(
            polygon=[[0, 0], [1, 0]])), False),
        ("workpiece mass 0", _edit(s, lambda d: d["workpiece"].update(mass=0)), False),
        ("workpiece without mass", _edit(s, lambda d: d["workpiece"].pop("mass")), False),
        ("unknown workpiece key", _edit(s, lambda d: d["workpiece"].update(inertia=1)), False),
        ("joint with both commands", _edit(JACOBIAN, lambda d: d["manipulator"]["joints"][0]
                                           .update(effort=1.0)), False),
        ("joint unknown key", _edit(JACOBIAN, lambda d: d["manipulator"]["joints"][0]
                                    .update(torque=1.0)), False),
        ("jacobian without joints", _edit(JACOBIAN, lambda d: d["manipulator"].pop("joints")),
         False),
        ("chain joint unknown key", _edit(CHAIN, lambda d: d["manipulator"]["chain"]["joints"][0]
                                          .update(limit=1)), False),
        ("chain joint without type", _edit(CHAIN, lambda d: d["manipulator"]["chain"]["joints"][0]
                                           .pop("type")), False),
        ("chain without links", _edit(CHAIN, lambda d: d["manipulator"].pop("contact_links")),
         False),
        ("q with velocities", _edit(s, lambda d: d["manipulator"].update(q=[0.0])), False),
        ("wrong format", _edit(s, lambda d: d.update(format="qsplan-hand")), False),
        ("wrong version", _edit(s, lambda d: d.update(version=2)), False),
        ("version true", _edit(s, lambda d: d.update(version=True)), False),
    ]


def _hand_cases() -> list[tuple[str, Any, bool]]:
    h = json.loads((DATA / "two_finger_hand.json").read_text())
    return [
        ("shipped", h, True),
        ("minimal", _edit(h, lambda d: [d.pop(k) for k in ("segment", "mu", "load", "format",
                                                            "version", "name", "description",
                                                            "units")]), True),
        ("revolute stated", _edit(h, lambda d: d["fingers"][0].update(type="revolute")), True),
        ("per-contact interval", _edit(h, lambda d: d["mu"].update(interval=[[0, 0.1]] * 4)),
         True),
        ("prismatic finger", _edit(h, lambda d: d["fingers"][0].update(type="prismatic")), False),
        ("multi-link finger", _edit(h, lambda d: d["fingers"][0].update(links=[{}, {}])), False),
        ("unknown top key", _edit(h, lambda d: d.update(table={})), False),
        ("unknown finger key", _edit(h, lambda d: d["fingers"][0].update(radius=0.004)), False),
        ("tip with vertex", _edit(h, lambda d: d["contacts"][3].update(vertex=1)), False),
        ("contact kind glue", _edit(h, lambda d: d["contacts"][3].update(kind="glue")), False),
        ("side 2", _edit(h, lambda d: d["contacts"][2].update(side=2)), False),
        ("no palm", _edit(h, lambda d: d.pop("palm")), False),
        ("negative width", _edit(h, lambda d: d["fingers"][0].update(width=-1)), False),
        ("segment without mode", _edit(h, lambda d: d["segment"].pop("mode")), False),
        ("segment speed 0", _edit(h, lambda d: d["segment"].update(speed=0)), False),
        ("one waypoint", _edit(h, lambda d: d["segment"].update(waypoints=1)), False),
        ("negative validate", _edit(h, lambda d: d["mu"].update(validate=[-0.1])), False),
        ("pose of 2", _edit(h, lambda d: d["workpiece"].update(pose=[0, 0])), False),
        ("load without force", _edit(h, lambda d: d["load"].pop("force")), False),
        ("wrong format", _edit(h, lambda d: d.update(format="qsplan-system")), False),
    ]


V1 = json.loads((ROOT / "tests" / "data" / "plan_v1_two_finger.json").read_text())
V2 = json.loads((ROOT / "tests" / "data" / "plan_v2_three_finger.json").read_text())


def _plan_cases(p: dict) -> list[tuple[str, Any, bool]]:
    def seg(d):
        return d["segments"][0]

    def wp(d):
        return d["segments"][0]["waypoints"][0]

    return [
        ("written", p, True),
        ("version 1", V1, True),
        ("version 2", V2, True),
        ("version 1 without optional keys",
         _edit(V1, lambda d: [d.pop(k) for k in ("exact", "notes", "extra")]), True),
        ("version 1, two efforts", _edit(V1, lambda d: d.update(control=["effort", "effort"])),
         False),
        ("version 1, band of 3", _edit(V1, lambda d: d["waypoints"][0].update(band=[0, 1, 2])),
         False),
        ("version 2, no band", _edit(V2, lambda d: seg(d)["waypoints"][0].pop("band")), False),
        ("without segment notes", _edit(p, lambda d: seg(d).pop("notes")), False),
        ("unknown top key", _edit(p, lambda d: d.update(author="me")), False),
        ("unknown waypoint key", _edit(p, lambda d: wp(d).update(force=1)), False),
        ("waypoint without margin", _edit(p, lambda d: wp(d).pop("margin")), False),
        ("version-2 waypoint keys", _edit(p, lambda d: wp(d).update(torque_command=0.0)), False),
        ("event without t", _edit(p, lambda d: seg(d)["event"].pop("t")), False),
        ("unknown event kind", _edit(p, lambda d: seg(d)["event"].update(kind="bump")), False),
        ("unknown mu key", _edit(p, lambda d: d["mu"].update(grid=5)), False),
        ("no velocity joint", _edit(p, lambda d: seg(d).update(control=["effort", "effort"])),
         False),
        ("model box", _edit(p, lambda d: d["mu"].update(model="box")), False),
        ("md5", _edit(p, lambda d: d["digest"].update(algorithm="md5")), False),
        ("one waypoint", _edit(p, lambda d: seg(d).update(waypoints=seg(d)["waypoints"][:1])),
         False),
        ("band of 3", _edit(p, lambda d: wp(d).update(bands=[[0, 1, 2]])), False),
        ("prismatic hand", _edit(p, lambda d: d["hand"]["fingers"][0].update(type="prismatic")),
         False),
        ("hand unknown key", _edit(p, lambda d: d["hand"].update(tabel=1)), False),
        ("wrong version", _edit(p, lambda d: d.update(version=2)), False),
    ]


@pytest.mark.parametrize("name,doc,good", _system_cases(), ids=lambda v: v if isinstance(v, str)
                         else None)
def test_system_loader_and_schema_agree(name, doc, good):
    assert schema_ok("system", doc) is good, name
    assert loader_ok("system", doc) is good, name


@pytest.mark.parametrize("name,doc,good", _hand_cases(), ids=lambda v: v if isinstance(v, str)
                         else None)
def test_hand_loader_and_schema_agree(name, doc, good):
    assert schema_ok("hand", doc) is good, name
    assert loader_ok("hand", doc) is good, name


def test_plan_loader_and_schema_agree(plan_dict):
    cases = _plan_cases(plan_dict)
    assert len(cases) >= 15
    for name, doc, good in cases:
        assert schema_ok("plan", doc) is good, name
        assert loader_ok("plan", doc) is good, name


@pytest.mark.parametrize("kind,doc", [
    ("system", _edit(SYSTEM, lambda d: d["workpiece"].update(
        polygon=[[0, 0], [0, 1], [1, 1], [1, 0]]))),  # clockwise
    ("system", _edit(SYSTEM, lambda d: d["contacts"][0].update(normal=[0.0, 2.0]))),
    ("system", _edit(SYSTEM, lambda d: d["manipulator"]["contact_velocities"][0].__setitem__(
        0, 1.0))),  # an environment contact that moves
    ("system", _edit(JACOBIAN, lambda d: d["manipulator"]["joints"].pop())),  # count mismatch
    ("hand", _edit(json.loads((DATA / "two_finger_hand.json").read_text()),
                   lambda d: d["contacts"][0].update(vertex=9))),  # beyond the polygon
])
def test_what_only_the_loader_checks(kind, doc):
    """Geometry and counts a JSON Schema cannot express: the schema accepts, the loader says why
    not (documented in each schema's description)."""
    assert schema_ok(kind, doc)
    assert not loader_ok(kind, doc)
