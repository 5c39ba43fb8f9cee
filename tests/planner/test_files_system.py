"""System files: missing and unknown keys, the scene-geometry keys (``workpiece``, per-contact
``environment``) and their round trip through save_system / load_system."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from planner import feasible_modes
from planner.errors import FileFormatError, InputError
from planner.files.system_file import load_system, save_system, system_from_dict, system_to_dict
from planner.model.system import System
from planner.model.workpiece import WorkpieceGeometry, polygon_area_centroid

#: A box of 0.2 m x 0.1 m on a table (contacts 1, 2 at its bottom corners, environment) pushed
#: by one finger at its left side (contact 3, moving right at 1 mm/s): gravity 1 N.
BOX = {
    "name": "box on a table",
    "contacts": [
        {"point": [0.0, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
        {"point": [0.2, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
        {"point": [0.0, 0.03], "normal": [1.0, 0.0], "mu": 0.5},
    ],
    "external_wrench": [0.0, -1.0, -0.1],
    "manipulator": {"contact_velocities": [[0.0, 0.0], [0.0, 0.0], [0.001, 0.0]]},
    "workpiece": {"polygon": [[0.0, 0.0], [0.2, 0.0], [0.2, 0.1], [0.0, 0.1]], "mass": 0.102},
}


def _box(**changes):
    d = copy.deepcopy(BOX)
    d.update(changes)
    return d


def test_the_box_loads_with_its_scene_geometry():
    s = system_from_dict(BOX)
    assert s.environment == (True, True, False)
    assert isinstance(s.workpiece, WorkpieceGeometry)
    assert s.workpiece.mass == 0.102
    np.testing.assert_allclose(s.workpiece.com, [0.1, 0.05])  # default: the area centroid
    assert s.workpiece.area == pytest.approx(0.02)


def test_scene_geometry_changes_no_prediction():
    with_geometry = system_from_dict(BOX)
    plain = copy.deepcopy(BOX)
    del plain["workpiece"]
    for c in plain["contacts"]:
        c.pop("environment", None)
    a, b = feasible_modes(with_geometry), feasible_modes(system_from_dict(plain))
    assert a.labels == b.labels and a.status is b.status
    assert a.labels  # the box moves in some mode: the comparison is not vacuous
    for fa, fb in zip(a.modes, b.modes):
        np.testing.assert_array_equal(fa.qdot, fb.qdot)


@pytest.mark.parametrize("source", ["contacts", "wrench_matrix", "jacobian", "chain"])
def test_round_trip_keeps_workpiece_and_environment(tmp_path, data_dir, source):
    d = _box()
    expect = (True, True, False)
    if source == "wrench_matrix":  # the paper's rounded matrix is written back as a matrix
        d = json.loads((data_dir / "example_4_1.json").read_text())
        d["manipulator"]["contact_velocities"][0] = [0.0, 0.0]
        d["environment"] = [True, False, False]
        d["workpiece"] = {"polygon": [[-5, -5], [5, -5], [5, 5], [-5, 5]], "mass": 1,
                          "com": [0.5, 0.25]}
        expect = (True, False, False)
    elif source == "jacobian":
        d["manipulator"] = {"jacobian": [[[0.0], [0.0]], [[0.0], [0.0]], [[1.0], [0.0]]],
                            "joints": [{"velocity": 0.001}]}
    elif source == "chain":
        d["manipulator"] = {
            "chain": {"joints": [{"type": "prismatic", "origin": [-0.05, 0.03]}]},
            "contact_links": [None, None, 0], "joints": [{"velocity": 0.001}]}
    s = system_from_dict(d)
    back = load_system(save_system(s, tmp_path / "s.json"))
    assert back.environment == s.environment == expect
    assert ("wrench_matrix" in system_to_dict(s)) == (source == "wrench_matrix")
    np.testing.assert_array_equal(back.workpiece.polygon, s.workpiece.polygon)
    np.testing.assert_array_equal(back.workpiece.com, s.workpiece.com)
    assert back.workpiece.mass == s.workpiece.mass
    for key in ("W", "mu", "g_obj", "J", "joint_inputs", "g_man"):
        np.testing.assert_array_equal(getattr(back, key), getattr(s, key))
    assert system_to_dict(back) == system_to_dict(s)


def test_chain_contact_jacobian_of_the_environment_is_zero():
    d = _box(manipulator={
        "chain": {"joints": [{"type": "prismatic", "origin": [-0.05, 0.03]}]},
        "contact_links": [None, None, 0], "joints": [{"velocity": 0.001}]})
    s = system_from_dict(d)
    np.testing.assert_array_equal(s.J[:4], 0.0)
    assert s.J[4, 0] == pytest.approx(1.0)  # n . e_x for the pushing finger


@pytest.mark.parametrize("mutate,match", [
    (lambda d: d["contacts"][2].pop("mu"), "contact 3: expected key 'mu'"),
    (lambda d: d.update(mu=[0.3, 0.3, 0.5]),
     "top-level 'mu': expected it only with 'wrench_matrix'"),
    (lambda d: d.update(environment=[True, True, False]),
     "top-level 'environment': expected it only with 'wrench_matrix'"),
    (lambda d: d.update(masss=1), "top level: unknown key 'masss'"),
    (lambda d: d["contacts"][0].update(frction=0.1), "contact 1: unknown key 'frction'"),
    (lambda d: d["manipulator"].update(joints=[]),
     r"manipulator \(contact_velocities form\): unknown key 'joints'"),
    (lambda d: d["workpiece"].update(colour="red"), "workpiece: unknown key 'colour'"),
    (lambda d: d["contacts"][0].update(environment="yes"),
     "contact 1 environment: expected true or false, got the string 'yes'"),
    (lambda d: d["manipulator"]["contact_velocities"][0].__setitem__(1, 0.001),
     r"contact 1: expected zero manipulator velocity for a contact with the fixed environment, "
     r"got contact velocity \[0.0, 0.001\]"),
    (lambda d: d["workpiece"].pop("mass"), "workpiece: expected key 'mass'"),
    (lambda d: d["workpiece"].update(mass=0), "workpiece.mass: expected a positive number"),
    (lambda d: d["workpiece"].update(mass=True), "workpiece.mass: expected a finite number"),
    (lambda d: d["workpiece"]["polygon"].reverse(),
     "workpiece.polygon: expected a convex polygon listed counter-clockwise"),
    (lambda d: d["workpiece"].update(polygon=[[0, 0], [1, 0]]),
     "workpiece.polygon: expected at least 3 vertices, got 2"),
    (lambda d: d["workpiece"].update(polygon=[[0, 0], [1, 0], [1, 1], [0.5, -1], [0, 1]]),
     "workpiece.polygon: expected a convex polygon"),
    (lambda d: d["workpiece"].update(polygon=[[0, 0], [1, 0], [0, 1], [1, 0.000001]]),
     "workpiece.polygon: expected a convex polygon"),
    (lambda d: d["workpiece"].update(com=[0.5, 0.5]),
     r"workpiece.com: expected a point inside the polygon, got \[0.5, 0.5\]"),
    (lambda d: d["workpiece"].update(com=[0.1]), r"workpiece.com: expected shape \(2,\)"),
    (lambda d: d["workpiece"]["polygon"][0].__setitem__(0, None),
     "workpiece.polygon: expected numbers, got null"),
    (lambda d: d.update(workpiece=[1, 2]), "workpiece: expected an object, got an array"),
])
def test_box_file_errors_name_the_key(mutate, match):
    d = _box()
    mutate(d)
    with pytest.raises(FileFormatError, match=match):
        system_from_dict(d)


def test_a_star_polygon_is_not_convex():
    """Five left turns that wind twice (a pentagram) are refused."""
    k = np.arange(5) * 2
    star = np.c_[np.cos(2 * np.pi * k / 5), np.sin(2 * np.pi * k / 5)].tolist()
    with pytest.raises(InputError, match="turning once around"):
        WorkpieceGeometry(star, 1.0)


def test_centroid_of_a_triangle():
    area, c = polygon_area_centroid(np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]]))
    assert area == pytest.approx(4.5)
    np.testing.assert_allclose(c, [1.0, 1.0])


def test_wrench_matrix_form_environment_errors(example_41, data_dir):
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d["environment"] = [True, False, False]
    with pytest.raises(FileFormatError, match="contact 1: expected zero manipulator velocity"):
        system_from_dict(d)
    d["environment"] = [False, False]
    with pytest.raises(FileFormatError, match="environment: expected 3 true/false flags"):
        system_from_dict(d)
    d["environment"] = [0, 0, 0]
    with pytest.raises(FileFormatError, match="environment: expected a list of true/false"):
        system_from_dict(d)


def test_chain_link_of_an_environment_contact_must_be_null():
    d = _box(manipulator={
        "chain": {"joints": [{"type": "prismatic"}]},
        "contact_links": [0, None, 0], "joints": [{"velocity": 0.001}]})
    with pytest.raises(FileFormatError, match=r"contact_links\[0\]: expected null for contact 1"):
        system_from_dict(d)
    d["manipulator"]["contact_links"] = [None, None, None]
    with pytest.raises(FileFormatError, match=r"contact_links\[2\]: expected an integer, got null"):
        system_from_dict(d)
    d["manipulator"]["contact_links"] = [None, None, 0]
    d["manipulator"]["chain"]["joints"][0]["axis"] = 1
    with pytest.raises(FileFormatError, match="chain joint 1: unknown key 'axis'"):
        system_from_dict(d)


def test_jacobian_rows_of_an_environment_contact_must_be_zero():
    d = _box(manipulator={"jacobian": [[[0.0], [0.1]], [[0.0], [0.0]], [[1.0], [0.0]]],
                          "joints": [{"velocity": 0.001}]})
    with pytest.raises(FileFormatError, match=r"contact 1: expected zero manipulator velocity .*"
                                              r"zero Jacobian rows\), got rows"):
        system_from_dict(d)


def test_joint_commands_with_unknown_keys():
    d = _box(manipulator={"jacobian": [[[0.0]] * 2, [[0.0]] * 2, [[1.0], [0.0]]],
                          "joints": [{"velocity": 0.001, "veloctiy": 1}]})
    with pytest.raises(FileFormatError, match="joint 1: unknown key 'veloctiy'"):
        system_from_dict(d)


def test_free_keys_are_allowed_in_every_object():
    d = _box(description="d", reference="r", units="SI", notes="n", comment="c")
    d["contacts"][0]["name"] = "table left"
    d["manipulator"]["note"] = "pushed"
    d["workpiece"]["comment"] = "box"
    assert system_from_dict(d).n_contacts == 3


def test_api_keeps_working_and_checks_the_new_fields():
    s = System.from_contacts(points=[[0, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.2,
                             contact_velocities=[[0, 0], [0, 1]])
    assert s.environment == (False, False) and s.workpiece is None
    e = System.from_contacts(points=[[0, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.2,
                             contact_velocities=[[0, 0], [0, 1]], environment=[True, False])
    assert e.with_mu(0.4).environment == (True, False)  # copies keep the scene data
    with pytest.raises(InputError, match="contact 1: expected zero manipulator velocity"):
        e.with_joint_inputs([0.0, 1.0, 0.0, 1.0])
    with pytest.raises(InputError, match="environment: expected 2 true/false flags"):
        System.from_contacts(points=[[0, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.2,
                             contact_velocities=[[0, 0], [0, 1]], environment=[1, 0])
    with pytest.raises(InputError, match="workpiece: expected a WorkpieceGeometry or None"):
        System.from_contacts(points=[[0, 0]], normals=[[0, 1]], mu=0.2,
                             contact_velocities=[[0, 0]], workpiece={"polygon": []})


def test_a_virtual_system_keeps_nonzero_joint_loads(tmp_path):
    d = _box(manipulator={"contact_velocities": [[0, 0], [0, 0], [0.001, 0]],
                          "joint_loads": [0, 0, 0, 0, 0.5, 0]})
    s = system_from_dict(d)
    back = load_system(save_system(s, tmp_path / "s.json"))
    np.testing.assert_array_equal(back.g_man, s.g_man)
