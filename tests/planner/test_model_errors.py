"""Bad input gets a clear error naming what was expected (messages matched)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner import InputError, System, feasible_modes
from planner.errors import FileFormatError
from planner.files.system_file import (
    load_system,
    system_from_dict,
    system_from_json,
    system_to_dict,
)
from planner.model.modes import Mode

W41 = [[0.804, -0.595, -0.707, -0.707, -0.973, 0.232],
       [0.595, 0.804, 0.707, -0.707, -0.232, -0.973],
       [1.04, -20.9, -3.50, -17.9, 14.0, -7.63]]
U41 = [[0.920, -0.391], [0.928, -0.375], [-0.931, -0.367]]


def geo(**over):
    kw = dict(points=[[0, 0], [1, 0], [0, 1]], normals=[[0, 1], [-1, 0], [0, -1]], mu=0.3,
              external_wrench=[0, -1, 0], contact_velocities=[[0, 1], [0, 1], [0, 1]])
    kw.update(over)
    return System.from_contacts(**kw)


@pytest.mark.parametrize("over,match", [
    (dict(points=[[0, 0], [1, 0]]), r"normals: expected shape \(2, 2\)"),
    (dict(points=[[0, 0, 0], [1, 0, 0], [0, 1, 0]]), r"points: expected shape \(n, 2\)"),
    (dict(normals=[[0, 1], [-1, 0], [0, 0]]), "expected a unit normal, got the zero vector"),
    (dict(normals=[[0, 2], [-1, 0], [0, -1]]), r"expected a unit normal \(\|n\| = 1\), got \|n\| = 2"),
    (dict(mu=-0.1), "expected friction coefficients >= 0"),
    (dict(mu=[0.1, 0.2]), r"expected 3 friction coefficients \(one per contact\), got shape \(2,\)"),
    (dict(mu=[0.1, float("nan"), 0.2]), "expected finite friction coefficients"),
    (dict(external_wrench=[0, 1]), r"external_wrench: expected shape \(3,\)"),
    (dict(external_wrench=[0, np.inf, 0]), "external_wrench: expected finite numbers"),
    (dict(contact_velocities=[[0, 1], [0, 1]]), r"contact_velocities: expected shape \(3, 2\)"),
    (dict(contact_velocities=None), "expected exactly one of contact_velocities or jacobian"),
    (dict(points=[[0, "a"], [1, 0], [0, 1]]), "points: expected numbers"),
])
def test_geometric_errors(over, match):
    with pytest.raises(InputError, match=match):
        geo(**over)


def test_jacobian_errors():
    J = np.zeros((3, 2, 2))
    with pytest.raises(InputError, match=r"jacobian: expected shape \(3, 2, n_theta\)"):
        geo(contact_velocities=None, jacobian=np.zeros((3, 3, 2)), joints=[{"velocity": 1}] * 2)
    with pytest.raises(InputError, match=r"joints: expected 2 joints \(one per Jacobian column\), got 1"):
        geo(contact_velocities=None, jacobian=J, joints=[{"velocity": 1}])
    with pytest.raises(InputError, match="joint 2: expected exactly one of 'velocity' or 'effort', got neither"):
        geo(contact_velocities=None, jacobian=J, joints=[{"velocity": 1}, {}])
    with pytest.raises(InputError, match=r"joint 1: expected exactly one of 'velocity' or 'effort', got \['effort', 'velocity'\]"):
        geo(contact_velocities=None, jacobian=J, joints=[{"velocity": 1, "effort": 2}, {"effort": 1}])
    with pytest.raises(InputError, match="joint 1: expected a number for 'effort'"):
        geo(contact_velocities=None, jacobian=J, joints=[{"effort": "x"}, {"effort": 1}])
    with pytest.raises(InputError, match=r"joint_loads: expected shape \(2,\)"):
        geo(contact_velocities=None, jacobian=J, joints=[{"effort": 1}] * 2, joint_loads=[1.0])


def test_wrench_matrix_checks():
    System.from_wrench_matrix(W41, 0.1, contact_velocities=U41)  # rounded to 3 digits: accepted
    bad = np.array(W41)
    bad[0, 0] = 0.9
    with pytest.raises(InputError, match=r"contact 1: expected a unit normal in column 1"):
        System.from_wrench_matrix(bad, 0.1, contact_velocities=U41)
    bad = np.array(W41)
    bad[:2, 1] *= -1  # t = n rotated by -90 degrees
    with pytest.raises(InputError, match=r"contact 1: expected tangent t = n rotated by \+90 deg"):
        System.from_wrench_matrix(bad, 0.1, contact_velocities=U41)
    with pytest.raises(InputError, match=r"wrench_matrix: expected shape \(3, 2\*n_c\)"):
        System.from_wrench_matrix(np.zeros((3, 5)), 0.1, contact_velocities=U41)
    with pytest.raises(InputError, match=r"wrench_matrix: expected shape \(3, 2\*n_c\)"):
        System.from_wrench_matrix("abc", 0.1, contact_velocities=U41)


def test_feasible_modes_errors(example_41):
    with pytest.raises(InputError, match="expected friction coefficients >= 0"):
        feasible_modes(example_41, [0.1, -0.2, 0.1])
    with pytest.raises(InputError, match="system: expected a planner System, got dict"):
        feasible_modes({"W": 1})
    with pytest.raises(InputError, match="tol: expected a finite number >= 0"):
        feasible_modes(example_41, tol=float("nan"))


def test_mode_parse_errors():
    assert Mode.parse("R1 S-2 B3").label == "R1 S-2 B3"
    with pytest.raises(InputError, match="expected 3 tokens"):
        Mode.parse("R1 S-2", 3)
    with pytest.raises(InputError, match="expected R, S\\+, S- or B before 2, got 'X'"):
        Mode.parse("R1 X2")
    with pytest.raises(InputError, match="expected token 2 to end with contact index 2"):
        Mode.parse("R1 B3")


# -- system files ---------------------------------------------------------------------------
def test_paper_files_load_and_round_trip(tmp_path, example_41, example_43):
    from planner.files.system_file import save_system

    for s in (example_41, example_43):
        path = save_system(s, tmp_path / "s.json")
        again = load_system(path)
        np.testing.assert_array_equal(again.W, s.W)
        assert feasible_modes(again).labels == feasible_modes(s).labels
    d = system_to_dict(example_41)
    assert "wrench_matrix" in d  # the rounded paper matrix is kept exactly


@pytest.mark.parametrize("text,match", [
    ("{", "expected valid JSON, got a syntax error at line 1"),
    ("[]", "expected a JSON object at top level, got an array"),
    ('{"manipulator": {}}', "expected exactly one of 'contacts' or 'wrench_matrix'"),
    ('{"contacts": [], "manipulator": {"contact_velocities": []}}', "contacts: expected a non-empty list"),
    ('{"contacts": [{"point": [0, 0]}], "manipulator": {"contact_velocities": [[0, 1]]}}',
     "contact 1: expected key 'mu', got keys \\['point'\\]"),
    ('{"wrench_matrix": [[1, 0], [0, 1], [0, 0]], "manipulator": {"contact_velocities": [[0, 1]]}}',
     "'wrench_matrix': expected a top-level 'mu' \\(one per contact\\) beside it, got no 'mu'"),
    ('{"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": 0.1}], "manipulator": []}',
     "expected a 'manipulator' object, got an array"),
    ('{"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": 0.1}], "manipulator": {}}',
     "manipulator: expected exactly one of 'contact_velocities', 'jacobian' or 'chain', got none"),
    ('{"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": true}], '
     '"manipulator": {"contact_velocities": [[0, 1]]}}', "contact 1 mu: expected numbers, got a boolean"),
    ('{"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": NaN}], '
     '"manipulator": {"contact_velocities": [[0, 1]]}}', "expected finite numbers .*got the constant NaN"),
    ('{"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": -1}], '
     '"manipulator": {"contact_velocities": [[0, 1]]}}', "expected friction coefficients >= 0"),
])
def test_malformed_system_files(text, match):
    with pytest.raises((FileFormatError, InputError), match=match):
        system_from_json(text)


def test_missing_file(tmp_path):
    with pytest.raises(FileFormatError, match="expected an existing file"):
        load_system(tmp_path / "nope.json")


def test_extra_keys_ignored(data_dir):
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d["comment"] = "anything"
    d["manipulator"]["note"] = 1
    assert system_from_dict(d).n_contacts == 3


def test_jacobian_file_with_effort_joint():
    d = {
        "contacts": [{"point": [-1, 0], "normal": [0, 1], "mu": 0.5},
                     {"point": [1, 0], "normal": [0, 1], "mu": 0.5}],
        "external_wrench": [0, -1, 0],
        "manipulator": {"jacobian": [[[0, 0], [-1, 0]], [[0, 0], [0, 1]]],
                        "joints": [{"velocity": 0.1}, {"effort": 0.0}]},
    }
    s = system_from_dict(d)
    assert s.dof == 4 and list(s.effort_joints) == [1]


def test_system_file_version_is_checked(tmp_path):
    import json

    from planner.errors import FileFormatError
    from planner.files.system_file import load_system, save_system, system_from_dict

    path = tmp_path / "s.json"
    system = system_from_dict({"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": 0.2}],
                               "manipulator": {"contact_velocities": [[0.0, 1.0]]}})
    save_system(system, path)
    data = json.loads(path.read_text())
    assert data["format"] == "qsplan-system" and data["version"] == 1
    assert load_system(path).n_contacts == 1
    data["version"] = 2
    path.write_text(json.dumps(data))
    with pytest.raises(FileFormatError, match="version 1, got .qsplan-system. version 2"):
        load_system(path)
