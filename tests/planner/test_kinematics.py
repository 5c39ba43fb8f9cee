"""Planar chains: forward kinematics and Jacobians checked against finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from planner import InputError
from planner.model.kinematics import Chain, JointSpec, chain_from_dict


def branching_chain():
    return Chain((
        JointSpec("revolute", -1, (0.0, 0.0), 0.3),        # 0: shoulder
        JointSpec("prismatic", 0, (0.5, 0.0), 0.2),        # 1: slide on link 0
        JointSpec("revolute", 1, (0.2, 0.1), -0.4),        # 2: finger A
        JointSpec("revolute", 0, (0.4, -0.1), 0.9),        # 3: branch: finger B on link 0
        JointSpec("prismatic", -1, (1.0, 1.0), 1.2),       # 4: independent slider on the base
    ), base_pose=(0.1, -0.2, 0.25))


@pytest.mark.parametrize("seed", range(10))
def test_point_jacobian_matches_finite_differences(seed):
    rng = np.random.default_rng(seed)
    ch = branching_chain()
    q = rng.normal(0, 0.7, ch.n_joints)
    for body in range(ch.n_joints):
        local = rng.normal(0, 0.3, 2)
        p = ch.point_world(q, body, local)
        J = ch.point_jacobian(q, body, p)
        h = 1e-6
        fd = np.empty_like(J)
        for j in range(ch.n_joints):
            dq = np.zeros(ch.n_joints)
            dq[j] = h
            fd[:, j] = (ch.point_world(q + dq, body, local) - ch.point_world(q - dq, body, local)) / (2 * h)
        np.testing.assert_allclose(J, fd, atol=1e-8)


def test_contact_jacobian_rows_are_normal_and_tangent():
    ch = branching_chain()
    q = np.array([0.1, 0.05, -0.3, 0.4, 0.2])
    p = ch.point_world(q, 2, [0.1, 0.0])
    n = np.array([np.cos(0.7), np.sin(0.7)])
    Jc = ch.contact_jacobian(q, [2], [p], [n])
    Jp = ch.point_jacobian(q, 2, p)
    np.testing.assert_allclose(Jc[0, 0], n @ Jp)
    np.testing.assert_allclose(Jc[0, 1], np.array([-n[1], n[0]]) @ Jp)
    # joints not on the path to body 2 (the branch 3 and the slider 4) contribute nothing
    assert np.all(Jc[0, :, 3:] == 0)


def test_chain_errors():
    with pytest.raises(InputError, match="expected kind 'revolute' or 'prismatic', got 'ball'"):
        Chain((JointSpec("ball"),))
    with pytest.raises(InputError, match=r"expected parent in -1..0 \(parents listed first\), got 1"):
        Chain((JointSpec("revolute"), JointSpec("revolute", parent=1)))
    ch = branching_chain()
    with pytest.raises(InputError, match=r"joint positions q: expected shape \(5,\)"):
        ch.body_poses([0, 0])
    with pytest.raises(InputError, match="body: expected a joint/body index in 0..4, got 7"):
        ch.point_jacobian(np.zeros(5), 7, [0, 0])
    with pytest.raises(InputError, match="expected an object with a 'joints' list"):
        chain_from_dict({"links": []})


def test_chain_system_file_two_finger():
    """A two-finger hand given as a chain in a system file: Jacobian from geometry."""
    from planner.files.system_file import system_from_dict

    d = {
        "contacts": [{"point": [-0.05, 0.1], "normal": [1, 0], "mu": 0.2},
                     {"point": [0.05, 0.1], "normal": [-1, 0], "mu": 0.2}],
        "external_wrench": [0, -1, 0],
        "manipulator": {
            "chain": {"joints": [{"type": "revolute", "origin": [-0.05, 0.0], "angle": 1.5707963},
                                 {"type": "revolute", "origin": [0.05, 0.0], "angle": 1.5707963}]},
            "q": [0.0, 0.0], "contact_links": [0, 1],
            "joints": [{"velocity": 0.0}, {"effort": 1.0}],
        },
    }
    s = system_from_dict(d)
    # finger 0 rotating CCW about (-0.05, 0): contact at height 0.1 moves -x, i.e. along -n
    np.testing.assert_allclose(s.J[0:2, 0], [-0.1, 0.0], atol=1e-7)
