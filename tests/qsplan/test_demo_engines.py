"""The demo's engines side by side (qsplan.demo_engines) on recorded-style run summaries, and
``qsplan simulate`` with several engines through the command line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from qsplan.demo_engines import by_question, consensus_table, excuse_checks, side_by_side_lines

ROOT = Path(__file__).resolve().parents[2]
CREEP = ("contact c3, predicted to stick, slipped at 2e-05 m/s (3.0 x the slip threshold "
         "6.7e-06 m/s) on 40% of the judged steps")


def _run(engine: str, mu: float, status: str, seg2: str = "agreed", task: bool = True,
         expect: str = "agree", artefacts: tuple[str, ...] = ()) -> dict:
    name = (f"whole task, {engine}, mu={mu:g}" if task and expect == "agree" else
            f"negative control (R2S torque, claims 4S), {engine}, mu={mu:g}")
    arts = [{"kind": "creep", "contact": "c3", "value": 2e-5, "threshold": 6.7e-6, "text": t}
            for t in artefacts]
    return {"engine": engine, "name": name, "task": task, "expect": expect, "status": status,
            "parameters": {"mu": [mu, mu]}, "reason": "",
            "observed": {"fault": None, "engine_measures": {"artefacts": arts}},
            "segments": [{"segment": 1, "status": "agreed"}, {"segment": 2, "status": seg2}]
            if task else []}


RESULTS = [
    _run("pymunk", 0.1, "agreed"), _run("mujoco", 0.1, "disagreed", "disagreed",
                                        artefacts=(CREEP,)), _run("dart", 0.1, "agreed"),
    _run("pymunk", 0.2, "agreed"), _run("mujoco", 0.2, "agreed"), _run("dart", 0.2, "agreed"),
    *(_run(e, 0.2, "disagreed", task=False, expect="disagree")
      for e in ("pymunk", "mujoco", "dart")),
]


def test_runs_are_grouped_by_question_whatever_the_engine():
    groups = by_question(RESULTS)
    assert [len(v) for v in groups.values()] == [3, 3, 3]
    assert [k[3] for k in groups] == ["whole task, mu=0.1", "whole task, mu=0.2",
                                      "negative control (R2S torque, claims 4S), mu=0.2"]


def test_side_by_side_names_where_the_engines_disagree_and_why():
    text = "\n".join(side_by_side_lines(RESULTS))
    assert "| run | expected | pymunk | MuJoCo | DART | consensus |" in text
    assert "| whole task, mu=0.1 | agreed | agreed | disagreed | agreed | agreed |" in text
    assert "| whole task, mu=0.1: segment 2 | agreed | agreed | disagreed | agreed | agreed |" \
        in text
    assert "- whole task, mu=0.1: consensus agreed" in text and "odd engine: MuJoCo" in text
    assert CREEP in text and "an engine artefact" in text
    assert "mu=0.2: consensus" not in text  # unanimous there
    table = consensus_table(RESULTS)
    assert table["questions"][0]["whole"]["odd"] == ["mujoco"]
    json.dumps(table)


def test_a_failed_check_of_the_odd_engine_with_a_measured_artefact_is_excused():
    checks = [
        {"check": "task segment 2 in mujoco, mu=0.1: claimed mode and final position",
         "expected": "", "measured": "disagreed: 60%", "held": False},
        {"check": "whole task in mujoco, mu=0.1", "expected": "", "measured": "disagreed",
         "held": False},
        # the same engine at another friction value, and a control at mu = 0.2: not excused
        {"check": "whole task in mujoco, mu=0.2", "expected": "", "measured": "disagreed",
         "held": False},
        {"check": "negative control in mujoco, mu=0.2: validation", "expected": "",
         "measured": "agreed", "held": False},
    ]
    out = excuse_checks(checks, RESULTS)
    assert [c["held"] for c in out] == [True, True, False, False]
    assert "MuJoCo is the odd engine, engine artefact measured: " + CREEP in out[0]["measured"]
    # without a measured artefact the odd engine's failure stands
    bare = [dict(r, observed={"fault": None}) for r in RESULTS]
    assert [c["held"] for c in excuse_checks(checks, bare)] == [False] * 4


@pytest.mark.skipif(not __import__("importlib").util.find_spec("dartpy"),
                    reason="needs qsplan[dart]")
def test_simulate_in_several_engines_writes_each_run_and_their_consensus(tmp_path, capsys):
    from planner.files.schema import load_schema
    from qsplan.cli import main

    box = str(ROOT / "scenarios" / "data" / "box_on_table_high.json")
    out = tmp_path / "three"
    code = main(["simulate", box, "--engine", "pymunk,dart", "--out", str(out), "--no-render"])
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert code == 0
    assert [x.get("engine") for x in lines[:2]] == ["pymunk", "dart"]
    assert lines[2]["consensus"] == "agreed" and lines[2]["text"] == "all engines agreed"
    assert sorted(p.name for p in out.iterdir()) == ["consensus.json", "dart", "pymunk"]
    c = json.loads((out / "consensus.json").read_text())
    assert c["verdicts"] == {"pymunk": "agreed", "dart": "agreed"} and c["unanimous"]
    import jsonschema

    schema = load_schema("run-summary")
    for e in ("pymunk", "dart"):
        jsonschema.validate(json.loads((out / e / "summary.json").read_text()), schema)


@pytest.mark.long
def test_validate_in_several_engines_writes_each_and_their_consensus(tmp_path, capsys):
    from qsplan.cli import main

    plan = tmp_path / "plan.json"
    assert main(["-q", "plan", "two_finger_hand", "--waypoints", "6", "--out", str(plan)]) == 0
    out = tmp_path / "val"
    code = main(["validate", str(plan), "--engine", "pymunk,mujoco", "--mu", "0.05,0.1",
                 "--no-render", "--out", str(out)])
    text = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["consensus.json", "mujoco", "pymunk"]
    assert (out / "pymunk" / "mu_0.05" / "summary.json").is_file()
    c = json.loads((out / "consensus.json").read_text())
    assert c["engines"] == ["pymunk", "mujoco"] and [r["mu"] for r in c["runs"]] == ["0.05",
                                                                                    "0.1"]
    assert "consensus mu=0.05: " in text and "consensus mu=0.1: " in text
    agreed = all(r["whole"]["majority"] == "agreed" for r in c["runs"])
    assert code == (0 if agreed else 1)
