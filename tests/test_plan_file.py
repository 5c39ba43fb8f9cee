"""Plan files: round trip, tamper evidence, malformed input, atomic writes, `qsplan plan`."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.plan.plan_file import (
    PLAN_VERSION,
    digest,
    load_plan,
    plan_from_dict,
    plans_equal,
    save_plan,
)
from planner.plan.segment_planner import plan_hand
from qsplan.cli import main
from scenarios.registry import DATA_DIR

HAND_FILE = DATA_DIR / "two_finger_hand.json"

CLAIM = "S+1 S+2 S-3 S-4"


@pytest.fixture(scope="module")
def plan():
    return plan_hand(HAND_FILE, mu=(0.0, 0.2), waypoints=11)


@pytest.fixture()
def saved(plan, tmp_path):
    path = tmp_path / "plan.json"
    save_plan(plan, path)
    return path


def _rewrite(path, mutate, *, redigest=False):
    data = json.loads(path.read_text())
    mutate(data)
    if redigest:
        body = {k: v for k, v in data.items() if k != "digest"}
        data["digest"]["value"] = digest(body)
    path.write_text(json.dumps(data))


def test_plan_content(plan):
    assert plan.claim == CLAIM
    assert plan.control == ("effort", "velocity")  # chosen by the utility conditions
    assert plan.event["kind"] == "new contact"
    assert plan.exact
    for w in plan.waypoints:
        assert w.band[0] < w.torque_command < w.band[1]
        assert w.margin > 0
        assert w.predicted == (CLAIM,)
        assert w.velocity_command > 0
    assert "R1 B2 S-3 S-4" in plan.waypoints[0].rivals
    assert 0.014 < plan.travel() < 0.017


def test_round_trip_is_identical(plan, saved):
    again = load_plan(saved)
    assert plans_equal(plan, again)
    assert again == plan or plans_equal(again, plan)
    assert np.array_equal(again.torques(), plan.torques())
    assert again.waypoints[0].band == plan.waypoints[0].band


def test_tampered_value_is_rejected(saved):
    _rewrite(saved, lambda d: d["waypoints"][3].update(torque_command=-0.0001))
    with pytest.raises(FileFormatError, match="digest mismatch"):
        load_plan(saved)


def test_tampered_hand_is_rejected(saved):
    _rewrite(saved, lambda d: d["hand"]["load"].update(force=[0.0, 0.0]))
    with pytest.raises(FileFormatError, match="digest mismatch"):
        load_plan(saved)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d.update(version=PLAN_VERSION + 1), "plan version"),
    (lambda d: d.update(format="pickle"), "format"),
    (lambda d: d.pop("waypoints"), "expected key 'waypoints'"),
    (lambda d: d["waypoints"][0].update(pose=[0, 0]), r"pose: expected a list of 3 numbers"),
    (lambda d: d["waypoints"][1].update(t=0.0), "strictly increasing"),
    (lambda d: d["waypoints"][0].update(band=[1.0, -1.0]), "lower <= upper"),
    (lambda d: d.update(control=["effort", "effort"]), "one 'effort' joint"),
    (lambda d: d["mu"].update(intervals=[[0.3, 0.1]]), "0 <= lo <= hi"),
    (lambda d: d["waypoints"][2].update(torque_command="1e-3"), "expected a finite number"),
    (lambda d: d["waypoints"][2].update(predicted="S+1"), "list of strings"),
])
def test_malformed_plans_name_the_problem(saved, mutate, match):
    _rewrite(saved, mutate, redigest=True)  # a consistent digest: the content check must catch it
    with pytest.raises(FileFormatError, match=match):
        load_plan(saved)


@pytest.mark.parametrize("text, match", [
    ("", "expected valid JSON"),
    ('{"format": "qsplan-plan", "version": 1, "x": NaN}', "NaN"),
    ("[" * 50000, "nested|JSON"),
    ("[1, 2]", "JSON object"),
])
def test_garbage_files(tmp_path, text, match):
    p = tmp_path / "p.json"
    p.write_text(text)
    with pytest.raises(FileFormatError, match=match):
        load_plan(p)


def test_truncated_and_binary_files(saved):
    raw = saved.read_bytes()
    saved.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(FileFormatError, match="expected valid JSON"):
        load_plan(saved)
    saved.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(FileFormatError, match="UTF-8"):
        load_plan(saved)
    with pytest.raises(InputError, match="plan file .*: expected an existing file"):
        load_plan(saved.with_name("missing.json"))


def test_atomic_write_keeps_the_old_file_on_failure(plan, saved):
    before = saved.read_bytes()
    bad = dataclasses.replace(plan, extra={"x": float("nan")})
    with pytest.raises(InputError, match="finite"):
        save_plan(bad, saved)
    assert saved.read_bytes() == before
    assert [p.name for p in saved.parent.iterdir()] == [saved.name]  # no temp file left


def test_plan_from_dict_needs_an_object():
    with pytest.raises(FileFormatError, match="JSON object"):
        plan_from_dict([])


def test_cli_plan_writes_plan_and_figures(tmp_path, capsys):
    out = tmp_path / "plan.json"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2", "--waypoints", "6", "--out", str(out),
               "--figures", str(tmp_path / "fig")])
    assert rc == 0
    plan = load_plan(out)
    assert plan.claim == CLAIM and len(plan.waypoints) == 6
    names = sorted(p.name for p in (tmp_path / "fig").iterdir())
    assert names == ["fig10_bounds_mu_lo.png", "fig11_bounds_mu_hi.png",
                     "fig12_rival_bounds_mu_hi.png", "fig13_guaranteed.png"]
    assert "claim S+1 S+2 S-3 S-4" in capsys.readouterr().out


@pytest.mark.parametrize("args, match", [
    (["--mu", "0.3:0.1"], "--mu: expected LO <= HI, got '0.3:0.1'"),
    (["--mu", "a:b"], "--mu: expected a number, got 'a'"),
    (["--mu", "0.1,0.2"], "expected one (lo, hi) interval or 4 of them"),
    (["--policy", "random"], "policy"),
    (["--control", "x"], "integer or 'auto'"),
])
def test_cli_plan_bad_input(tmp_path, capsys, args, match):
    rc = main(["plan", "two_finger_hand", "--waypoints", "3", "--out", str(tmp_path / "p.json"),
               *args])
    assert rc == 2
    assert match in capsys.readouterr().err or pytest.fail(capsys.readouterr().err)
    assert not (tmp_path / "p.json").exists()


def test_negative_control_plan_predicts_r2s_in_the_first_half():
    neg = plan_hand(HAND_FILE, mu=(0.0, 0.2), waypoints=11, policy="rival:R2S")
    assert neg.claim == CLAIM  # it still claims 4S ...
    first = [w.predicted for w in neg.waypoints[:4]]
    assert all(p == ("R1 B2 S-3 S-4",) for p in first)  # ... but predicts R2S early on
    assert neg.waypoints[-1].predicted == (CLAIM,)
    assert any(w.margin < 0 for w in neg.waypoints)


def test_cli_plan_per_contact_intervals(tmp_path, capsys):
    out = tmp_path / "p.json"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2,0:0.1,0:0.3,0:0.2", "--model",
               "independent", "--waypoints", "3", "--out", str(out)])
    assert rc == 0
    plan = load_plan(out)
    assert plan.mu_model == "independent"
    assert plan.mu_intervals == ((0.0, 0.2), (0.0, 0.1), (0.0, 0.3), (0.0, 0.2))
    # without --model: per-contact intervals are what was asked for (the default there)
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2,0:0.1,0:0.3,0:0.2", "--waypoints", "3",
               "--out", str(tmp_path / "q.json")])
    assert rc == 0 and load_plan(tmp_path / "q.json").mu_model == "independent"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2,0:0.1,0:0.3,0:0.2", "--model", "common",
               "--waypoints", "3", "--out", str(tmp_path / "r.json")])
    assert rc == 2 and "independent" in capsys.readouterr().err


# ---- strict keys and the embedded hand (one file layer) -------------------------------------
@pytest.mark.parametrize("mutate, match", [
    (lambda d: d.update(author="me"), "plan: unknown key 'author'"),
    (lambda d: d["waypoints"][2].update(force=1.0), r"waypoints\[2\]: unknown key 'force'"),
    (lambda d: d["waypoints"][2].pop("rivals"), r"waypoints\[2\]: expected key 'rivals'"),
    (lambda d: d["mu"].update(grid=5), "mu: unknown key 'grid'"),
    (lambda d: d["event"].pop("t"), "event: expected key 't'"),
    (lambda d: d["event"].update(t="late"), "event.t: expected a finite number"),
    (lambda d: d["hand"]["fingers"][0].update(type="prismatic"),
     r"plan.hand: fingers\[0\]\.type: expected \"revolute\" for a single-link finger"),
    (lambda d: d["hand"].update(tabel=1), "plan.hand: hand: unknown key 'tabel'"),
    (lambda d: d["mu"]["intervals"].pop(), r"hand: expected 2 joints \(one per control entry\) "
                                           r"and 3 contacts \(one per mu interval\), got 2 "
                                           "joints and 4 contacts"),
])
def test_unknown_and_missing_plan_keys_are_named(saved, mutate, match):
    _rewrite(saved, mutate, redigest=True)
    with pytest.raises(FileFormatError, match=match) as info:
        load_plan(saved)
    assert str(info.value).startswith(f"plan file '{saved}': ")


def test_the_plan_hand_is_parsed_once(saved, monkeypatch):
    import planner.files.hand_file as hf

    calls = []
    real = hf.hand_file_from_dict

    def counting(data, source="<dict>"):
        calls.append(source)
        return real(data, source)

    monkeypatch.setattr(hf, "hand_file_from_dict", counting)
    plan = load_plan(saved)
    assert calls == ["plan.hand"]  # checked while loading
    hand, q0 = plan.hand_model
    assert plan.hand_model is plan.hand_model and calls == ["plan.hand"]  # cached
    assert hand.n_fingers == len(plan.control) and hand.n_contacts == len(plan.mu_intervals)
    np.testing.assert_allclose(q0[3:], plan.waypoints[0].angles, atol=1e-12)
