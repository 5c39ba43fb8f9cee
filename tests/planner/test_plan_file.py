"""Plan files: the one plan model written as version 3, versions 1 and 2 read into it; round trip,
tamper evidence, malformed input, atomic writes, `qsplan plan`."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.plan.hand_planner import plan_hand
from planner.plan.model import Plan, Segment, Waypoint
from planner.plan.plan_file import (
    PLAN_VERSION,
    digest,
    load_plan,
    plan_from_dict,
    plans_equal,
    save_plan,
)
from qsplan.cli import main
from scenarios.registry import DATA_DIR

HAND_FILE = DATA_DIR / "two_finger_hand.json"
TEST_DATA = Path(__file__).parents[1] / "data"
V1_FILE = TEST_DATA / "plan_v1_two_finger.json"  # written by the version-1 planner
V2_FILE = TEST_DATA / "plan_v2_three_finger.json"  # written by the version-2 planner

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


def _copy(src, tmp_path):
    path = tmp_path / src.name
    path.write_bytes(src.read_bytes())
    return path


def test_plan_content(plan):
    assert isinstance(plan, Plan) and len(plan.segments) == 1 and plan.reached
    seg = plan.segments[0]
    assert isinstance(seg, Segment) and isinstance(seg.waypoints[0], Waypoint)
    assert seg.claim == CLAIM
    assert seg.control == ("effort", "velocity")  # chosen by the utility conditions
    assert seg.event.kind == "new contact"
    assert seg.event.detail == "vertex 4 meets the left finger"
    assert seg.exact and plan.exact
    for w in seg.waypoints:
        (lo, hi), = w.bands
        assert lo < w.torque_commands[0] < hi
        assert w.margin > 0
        assert w.predicted == (CLAIM,)
        assert w.velocity_commands == (0.02,)  # the driven joint's own rate
    assert "R1 B2 S-3 S-4" in seg.waypoints[0].rivals
    assert 0.014 < seg.travel() < 0.017
    cmd = seg.joint_commands()
    assert cmd.shape == (11, 2)
    assert np.array_equal(cmd[:, 0], seg.torques()[:, 0]) and np.all(cmd[:, 1] == 0.02)
    assert plan.start_times().tolist() == [0.0] and plan.duration() == seg.duration()
    assert plan.contacts == (seg.contacts,) and len(seg.contacts) == 4
    assert "curves" in seg.extra and seg.extra["spacing"]["rule"] == "uniform"


def test_round_trip_is_identical(plan, saved):
    again = load_plan(saved)
    assert plans_equal(plan, again)
    seg, back = plan.segments[0], again.segments[0]
    assert np.array_equal(back.torques(), seg.torques())
    assert back.waypoints == seg.waypoints
    assert json.loads(saved.read_text())["version"] == PLAN_VERSION == 3


def test_tampered_value_is_rejected(saved):
    _rewrite(saved, lambda d: d["segments"][0]["waypoints"][3].update(torque_commands=[-1e-4]))
    with pytest.raises(FileFormatError, match="digest mismatch"):
        load_plan(saved)


def test_tampered_hand_is_rejected(saved):
    _rewrite(saved, lambda d: d["hand"]["load"].update(force=[0.0, 0.0]))
    with pytest.raises(FileFormatError, match="digest mismatch"):
        load_plan(saved)


def _wp(d, k):
    return d["segments"][0]["waypoints"][k]


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d.update(version=PLAN_VERSION + 1), "expected plan version 1, 2, 3, got 4"),
    (lambda d: d.update(version=True), "expected plan version 1, 2, 3, got True"),
    (lambda d: d.update(format="pickle"), "format"),
    (lambda d: d.pop("segments"), "expected key 'segments'"),
    (lambda d: _wp(d, 0).update(pose=[0, 0]), r"pose: expected a list of 3 numbers"),
    (lambda d: _wp(d, 1).update(t=0.0), "strictly increasing"),
    (lambda d: _wp(d, 0).update(bands=[[1.0, -1.0]]), "lower <= upper"),
    (lambda d: d["segments"][0].update(control=["effort", "effort"]),
     "at least one 'velocity'"),
    (lambda d: d["mu"].update(intervals=[[0.3, 0.1]]), "0 <= lo <= hi"),
    (lambda d: _wp(d, 2).update(torque_commands=["1e-3"]), "expected a finite number"),
    (lambda d: _wp(d, 2).update(torque_commands=[1e-3, 2e-3]),
     r"expected 1 velocity_commands and 1 torque_commands and bands .* got 1, 2 and 1"),
    (lambda d: _wp(d, 2).update(predicted="S+1"), "list of strings"),
    (lambda d: d["segments"][0].update(claim="S+1 S+2"), "expected 4 tokens"),
    (lambda d: d["segments"][0]["event"].update(kind="collision"), "event.kind: expected one"),
    (lambda d: d.update(reached=False), "diagnosis: expected null for a plan that reaches"),
    (lambda d: d.update(segments=[]), "segments: expected a list of segments .empty only for a "
                                      "partial plan"),
])
def test_malformed_plans_name_the_problem(saved, mutate, match):
    _rewrite(saved, mutate, redigest=True)  # a consistent digest: the content check must catch it
    with pytest.raises(FileFormatError, match=match):
        load_plan(saved)


@pytest.mark.parametrize("text, match", [
    ("", "expected valid JSON"),
    ('{"format": "qsplan-plan", "version": 3, "x": NaN}', "NaN"),
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


# ---- versions 1 and 2 ------------------------------------------------------------------------
def test_a_version_1_file_loads_as_a_plan_of_one_segment():
    raw = json.loads(V1_FILE.read_text())
    plan = load_plan(V1_FILE)
    assert len(plan.segments) == 1 and plan.reached and plan.diagnosis is None
    seg = plan.segments[0]
    assert seg.claim == raw["claim"] and seg.control == tuple(raw["control"])
    assert seg.policy == raw["policy"] == plan.policy
    for w, r in zip(seg.waypoints, raw["waypoints"], strict=True):
        assert w.velocity_commands == (r["velocity_command"],)
        assert w.torque_commands == (r["torque_command"],)
        assert w.bands == (tuple(r["band"]),)
        assert w.margin == r["margin"] and w.pose == tuple(r["pose"])
    assert seg.joint_commands()[:, 1].tolist() == [r["velocity_command"]
                                                  for r in raw["waypoints"]]
    assert plan.contacts == (tuple(raw["hand"]["contacts"]),)
    assert seg.mu_intervals == tuple(tuple(iv) for iv in raw["mu"]["intervals"])
    assert seg.extra["curves"] == raw["extra"]["curves"]  # Figures 10-13 still drawable
    hand, q0 = seg.hand_model
    assert hand.n_contacts == 4 and np.allclose(q0[3:], seg.waypoints[0].angles, atol=1e-9)


def test_a_version_2_file_loads_with_every_joints_command():
    raw = json.loads(V2_FILE.read_text())
    plan = load_plan(V2_FILE)
    seg, r = plan.segments[0], raw["segments"][0]
    assert seg.control == ("velocity", "effort", "effort") and seg.effort_joints == (1, 2)
    for w, rw in zip(seg.waypoints, r["waypoints"], strict=True):
        assert w.torque_commands == tuple(rw["torque_commands"])
        assert w.velocity_commands == tuple(rw["velocity_commands"])
        # the first band as written; the other effort's band is its command -+ margin
        assert w.bands[0] == tuple(rw["band"])
        assert w.bands[1] == pytest.approx((rw["torque_commands"][1] - rw["margin"],
                                            rw["torque_commands"][1] + rw["margin"]))
    assert seg.joint_commands().shape == (len(seg.waypoints), 3)
    assert plan.mu_intervals == ((0.0, 0.1),) and seg.mu_intervals == ((0.0, 0.1),) * 5


def test_older_versions_are_resaved_as_version_3(tmp_path):
    for src in (V1_FILE, V2_FILE):
        plan = load_plan(src)
        path = save_plan(plan, tmp_path / f"re_{src.name}")
        assert json.loads(path.read_text())["version"] == 3
        assert plans_equal(load_plan(path), plan)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d["waypoints"][1].update(t=0.0), "strictly increasing"),
    (lambda d: d["waypoints"][0].update(band=[1.0, -1.0]), "lower <= upper"),
    (lambda d: d.update(control=["effort", "effort"]), "one 'effort' joint"),
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
def test_malformed_version_1_files_name_the_problem(tmp_path, mutate, match):
    path = _copy(V1_FILE, tmp_path)
    _rewrite(path, mutate, redigest=True)
    with pytest.raises(FileFormatError, match=match) as info:
        load_plan(path)
    assert str(info.value).startswith(f"plan file '{path}': ")


def test_tampered_older_versions_are_refused(tmp_path):
    v1 = _copy(V1_FILE, tmp_path)
    _rewrite(v1, lambda d: d["waypoints"][1].update(torque_command=-1e-4))
    v2 = _copy(V2_FILE, tmp_path)
    _rewrite(v2, lambda d: d["segments"][0]["waypoints"][1]["torque_commands"].reverse())
    for path in (v1, v2):
        with pytest.raises(FileFormatError, match="digest mismatch"):
            load_plan(path)


# ---- the command --------------------------------------------------------------------------
@pytest.mark.long
def test_cli_plan_writes_plan_and_figures(tmp_path, capsys):
    out = tmp_path / "plan.json"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2", "--waypoints", "6", "--out", str(out),
               "--figures", str(tmp_path / "fig")])
    assert rc == 0
    plan = load_plan(out)
    assert plan.segments[0].claim == CLAIM and len(plan.segments[0].waypoints) == 6
    names = sorted(p.name for p in (tmp_path / "fig").iterdir())
    assert names == ["fig10_bounds_mu_lo.png", "fig11_bounds_mu_hi.png",
                     "fig12_rival_bounds_mu_hi.png", "fig13_guaranteed.png"]
    text = capsys.readouterr().out
    assert "claim S+1 S+2 S-3 S-4" in text
    assert "the workpiece moves 15.2 mm left, without turning" in text
    assert "(new contact): vertex 4 meets the left finger" in text


@pytest.mark.parametrize("args, match", [
    (["--mu", "0.3:0.1"], "--mu: expected LO <= HI, got '0.3:0.1'"),
    (["--mu", "a:b"], "--mu: expected a number, got 'a'"),
    (["--mu", "0.1,0.2"], "expected one (lo, hi) interval or 4 of them"),
    (["--policy", "random"], "policy"),
    (["--control", "x"], "--control: expected comma-separated joint indices"),
    (["--control", "0,0"], "--control: expected distinct joint indices"),
    (["--control", "5"], "control: expected velocity-controlled joints forming a partition"),
])
@pytest.mark.long
def test_cli_plan_bad_input(tmp_path, capsys, args, match):
    rc = main(["plan", "two_finger_hand", "--waypoints", "3", "--out", str(tmp_path / "p.json"),
               *args])
    assert rc == 2
    assert match in capsys.readouterr().err or pytest.fail(capsys.readouterr().err)
    assert not (tmp_path / "p.json").exists()


@pytest.mark.long
def test_negative_control_plan_predicts_r2s_in_the_first_half():
    neg = plan_hand(HAND_FILE, mu=(0.0, 0.2), waypoints=11, policy="rival:R2S").segments[0]
    assert neg.claim == CLAIM  # it still claims 4S ...
    first = [w.predicted for w in neg.waypoints[:4]]
    assert all(p == ("R1 B2 S-3 S-4",) for p in first)  # ... but predicts R2S early on
    assert neg.waypoints[-1].predicted == (CLAIM,)
    assert any(w.margin < 0 for w in neg.waypoints)


@pytest.mark.long
def test_cli_plan_per_contact_intervals(tmp_path, capsys):
    out = tmp_path / "p.json"
    rc = main(["plan", "two_finger_hand", "--mu", "0:0.2,0:0.1,0:0.3,0:0.2", "--model",
               "independent", "--waypoints", "3", "--out", str(out)])
    assert rc == 0
    plan = load_plan(out)
    assert plan.mu_model == "independent"
    assert plan.mu_intervals == ((0.0, 0.2), (0.0, 0.1), (0.0, 0.3), (0.0, 0.2))
    assert plan.segments[0].mu_intervals == plan.mu_intervals
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
    (lambda d: _wp(d, 2).update(force=1.0),
     r"segments\[0\]\.waypoints\[2\]: unknown key 'force'"),
    (lambda d: _wp(d, 2).pop("rivals"), r"segments\[0\]\.waypoints\[2\]: expected key 'rivals'"),
    (lambda d: d["mu"].update(grid=5), "mu: unknown key 'grid'"),
    (lambda d: d["segments"][0]["event"].pop("t"), r"segments\[0\]\.event: expected key 't'"),
    (lambda d: d["segments"][0]["event"].update(t="late"),
     r"segments\[0\]\.event\.t: expected a finite number"),
    (lambda d: d["hand"]["fingers"][0].update(type="prismatic"),
     r"segments\[0\]: plan.hand: fingers\[0\]\.type: expected \"revolute\" for a single-link "
     "finger"),
    (lambda d: d["hand"].update(tabel=1), r"segments\[0\]: plan.hand: hand: unknown key 'tabel'"),
    (lambda d: d["mu"]["intervals"].extend([[0, 0.2]] * 2),
     r"segments\[0\]\.contacts: expected 4 friction intervals \(one per contact\) or one for "
     "all, got 3"),
])
def test_unknown_and_missing_plan_keys_are_named(saved, mutate, match):
    _rewrite(saved, mutate, redigest=True)
    with pytest.raises(FileFormatError, match=match) as info:
        load_plan(saved)
    assert str(info.value).startswith(f"plan file '{saved}': ")


def test_the_segment_hand_is_parsed_once(saved, monkeypatch):
    import planner.files.hand_file as hf

    calls = []
    real = hf.hand_file_from_dict

    def counting(data, source="<dict>"):
        calls.append(source)
        return real(data, source)

    monkeypatch.setattr(hf, "hand_file_from_dict", counting)
    plan = load_plan(saved)
    seg = plan.segments[0]
    assert calls == ["plan.hand"]  # checked while loading
    hand, q0 = seg.hand_model
    assert seg.hand_model is seg.hand_model and calls == ["plan.hand"]  # cached
    assert hand.n_fingers == len(seg.control) and hand.n_contacts == len(seg.mu_intervals)
    np.testing.assert_allclose(q0[3:], seg.waypoints[0].angles, atol=1e-12)


@pytest.mark.long
def test_cli_figures_of_a_segment_without_one_effort_joint(tmp_path, capsys):
    """A velocity-only segment (the table push) has no Figures 10-13: its effort regions
    (here the margin along the travel) are drawn instead."""
    rc = main(["plan", "table_push_hand", "--out", str(tmp_path / "p.json"), "--figures",
               str(tmp_path / "fig")])
    assert rc == 0
    assert [p.name for p in (tmp_path / "fig").iterdir()] == ["regions.png"]
    assert "figure: " in capsys.readouterr().out
