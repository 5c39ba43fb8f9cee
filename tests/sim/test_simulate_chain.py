"""``qsplan simulate`` with a chain manipulator ("chain manipulators are built as their
links").

Test data (``tests/data``): the box of ``scenarios/data/box_on_table_low.json`` (0.08 x 0.12 m,
0.1 kg, table friction 0.3) pushed at height ``y = 0.03`` m by a frictionless fingertip at the end
of a two-link revolute finger (``two_link_finger_box.json``) or of a prismatic finger
(``prismatic_finger_box.json``), both moving the tip +x at 1 mm/s through their joint rates. By
the hand derivation of ``tests/sim/test_simulate_box.py`` the box slides iff ``y <= w / (2 mu)``:
``0.133`` m at the file's ``mu = 0.3`` (slides, ``S-1 S-2 R3``) and ``0.02`` m at ``mu = 2``
(tips, ``B1 R2 S+3``), so each run judged at table friction 2 must disagree (negative control).

Also: the built links sit where the chain's forward kinematics puts them and their contact
sites touch the predicted points with the predicted normals (both engines).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.system_file import load_system, system_from_dict
from planner.predict.feasibility import feasible_modes
from scenarios.runs import simulate_system
from sim.backends import DEFAULT_ENGINES, make_backend
from sim.scenes.shapes import PRELOAD
from sim.scenes.system import commanded_contact_speed, scale_velocities, system_scene
from sim.verdict import Outcome

DATA = Path(__file__).resolve().parents[1] / "data"
FILES = ["two_link_finger_box", "prismatic_finger_box"]


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
@pytest.mark.parametrize("name", FILES)
def test_links_are_built_at_the_chains_forward_kinematics(name, engine):
    system = load_system(DATA / f"{name}.json")
    scene = system_scene(system)
    geom = system.chain
    poses = geom.body_poses()
    be = make_backend(engine)
    be.build(scene)
    be.step(1e-4)
    st = be.state()
    for j in range(geom.chain.n_joints):
        x, y, th = st[f"link{j + 1}"].pose
        assert np.allclose([x, y], poses[j, :2], atol=1e-6 * scene.length_scale)
        assert abs(np.angle(np.exp(1j * (th - poses[j, 2])))) < 1e-6
    # the contact site touches the predicted point with the predicted normal
    reading = be.contacts()["c3"]
    assert reading.present
    assert np.allclose(reading.normal, system.normals[2], atol=1e-6)
    assert np.allclose(reading.point, system.points[2], atol=2 * PRELOAD * scene.length_scale)


def test_contact_speed_and_slow_motion_scale_only_velocities():
    system = load_system(DATA / "two_link_finger_box.json")
    assert commanded_contact_speed(system) == pytest.approx(1e-3)
    slow = scale_velocities(system, 0.5)
    assert np.allclose(slow.joint_inputs, 0.5 * np.asarray(system.joint_inputs))
    mixed = system_from_dict({**_raw("two_link_finger_box"), "manipulator": {
        **_raw("two_link_finger_box")["manipulator"],
        "joints": [{"velocity": 0.0125}, {"effort": 0.01}]}})
    assert np.allclose(scale_velocities(mixed, 0.5).joint_inputs, [0.00625, 0.01])


def _raw(name):
    import json

    return json.loads((DATA / f"{name}.json").read_text())


#: file -> (judging friction of its negative control, the mode predicted there)
NEGATIVE = {"two_link_finger_box": ([2.0, 2.0, 0.0], "B1 R2 S+3"),
            "prismatic_finger_box": ([2.0, 2.0, 0.0], "B1 R2 S+3"),
            "two_link_effort_finger_box": ([2.0, 2.0, 0.5], "B1 R2 R3")}


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
@pytest.mark.parametrize("name", list(NEGATIVE))
@pytest.mark.long
def test_chain_pushing_a_box_agrees_and_its_negative_control_disagrees(name, engine):
    system = load_system(DATA / f"{name}.json")
    judge, rival = NEGATIVE[name]
    assert feasible_modes(system).labels == ["S-1 S-2 R3"]
    assert feasible_modes(system.with_mu(judge)).labels == [rival]
    run = simulate_system(system, engine)
    assert run.verdict.outcome is Outcome.AGREED, run.verdict.reasons
    assert run.verdict.judged_steps > 500
    if name == "two_link_effort_finger_box":
        # the distal joint's effort reaches the tip: c_3t = tau_2 / 0.12 m (eq. 3; file note)
        rec = run.recording
        late = rec.times > 0.5 * rec.times[-1]
        assert np.mean(rec.tangent_force[late, 2]) == pytest.approx(0.01 / 0.12, rel=0.02)
    neg = simulate_system(system, engine, judge_mu=judge)
    assert neg.verdict.outcome is Outcome.DISAGREED, neg.verdict.reasons
    assert neg.summary.parameters["negative_control"]


def test_a_chain_link_that_would_cut_the_workpiece_is_refused():
    raw = _raw("prismatic_finger_box")
    raw["manipulator"]["chain"]["joints"][0]["origin"] = [0.04, 0.03]  # inside the box
    with pytest.raises(InputError, match="cuts into the workpiece"):
        system_scene(system_from_dict(raw))
    jac = {**raw, "manipulator": {"jacobian": [[[0.0], [0.0]], [[0.0], [0.0]], [[1.0], [0.0]]],
                                  "joints": [{"velocity": 0.001}]}}
    with pytest.raises(InputError, match="got a bare Jacobian: it has no link geometry"):
        system_scene(system_from_dict(jac))


@pytest.mark.long
def test_cli_simulates_a_chain_system(tmp_path):
    out = subprocess.run([sys.executable, "-m", "qsplan.cli", "simulate",
                          str(DATA / "prismatic_finger_box.json"), "--engine", "pymunk",
                          "--out", str(tmp_path / "run"), "--no-render"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert '"status": "agreed"' in out.stdout
    neg = subprocess.run([sys.executable, "-m", "qsplan.cli", "simulate",
                          str(DATA / "prismatic_finger_box.json"), "--engine", "pymunk",
                          "--judge-mu", "2,2,0"], capture_output=True, text=True, timeout=300)
    assert neg.returncode == 1 and '"status": "disagreed"' in neg.stdout


def test_a_saved_chain_system_keeps_its_chain(tmp_path):
    from planner.files.system_file import save_system

    system = load_system(DATA / "two_link_effort_finger_box.json")
    again = load_system(save_system(system, tmp_path / "s.json"))
    assert again.chain is not None and again.chain.contact_links == (None, None, 1)
    assert np.allclose(again.J, system.J) and np.allclose(again.joint_inputs, system.joint_inputs)
    assert np.allclose(again.chain.body_poses(), system.chain.body_poses())


@pytest.mark.parametrize("engine", DEFAULT_ENGINES)
def test_link_radius_key_sets_the_capsules(engine):
    from planner.errors import FileFormatError
    from sim.scene import Capsule

    raw = _raw("prismatic_finger_box")
    raw["manipulator"]["link_radius"] = 0.01
    system = system_from_dict(raw)
    assert system.chain.link_radius == 0.01
    scene = system_scene(system)
    caps = [s for s in scene.body("link1").shapes if isinstance(s, Capsule)]
    assert caps and all(c.radius == 0.01 for c in caps)
    be = make_backend(engine)
    be.build(scene)
    be.step(1e-4)
    reading = be.contacts()["c3"]
    assert reading.present and np.allclose(reading.normal, system.normals[2], atol=1e-6)
    assert np.allclose(reading.point, system.points[2], atol=2 * PRELOAD * scene.length_scale)
    raw["manipulator"]["link_radius"] = -1.0
    with pytest.raises(FileFormatError, match=r"manipulator.link_radius: expected a positive number, got -1.0"):
        system_from_dict(raw)
