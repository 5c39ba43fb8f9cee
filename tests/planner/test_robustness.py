"""Tolerance policy, degenerate configurations and scale robustness of the core."""

from __future__ import annotations

import numpy as np
import pytest
from randsys import random_system
from test_feasibility_properties import _system_kwargs
from test_paper import rod

from planner import Status, System, feasible_modes


def circle_contacts(n, radius=1.0, offset=0.0):
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False) + offset
    pts = radius * np.c_[np.cos(ang), np.sin(ang)]
    return pts, -pts / radius


def test_concurrent_lines_of_action_are_degenerate_not_errors():
    pts, nrm = circle_contacts(3)  # all normals pass through the centre
    s = System.from_contacts(points=pts, normals=nrm, mu=0.0, external_wrench=[0, -1, 0],
                             contact_velocities=[[0, 1], [0, 1], [0, 1]])
    pred = feasible_modes(s)
    assert pred.degenerate > 0
    assert pred.status in (Status.JAMMED, Status.UNIQUE, Status.AMBIGUOUS)
    assert all(m.mode.family != "3S" for m in pred.modes)  # 3S needs rank W_Amu = 3 (31)


def test_parallel_lines_of_action():
    s = System.from_contacts(points=[[-1, 0], [0, 0], [1, 0]], normals=[[0, 1]] * 3, mu=0.0,
                             external_wrench=[0, -1, 0],
                             contact_velocities=[[0, 1], [0, 1], [0, 1]])
    pred = feasible_modes(s)  # W_A has rank 2 for 3S: condition (30) fails
    assert pred.degenerate > 0
    assert "S1 S" not in " ".join(pred.labels)


def test_coincident_contacts():
    s = System.from_contacts(points=[[0, 0], [0, 0], [1, 1]], normals=[[0, 1], [0, 1], [-1, 0]],
                             mu=0.3, external_wrench=[0, -1, 0],
                             contact_velocities=[[0, 0.1], [0, 0.1], [0, 0.1]])
    pred = feasible_modes(s)
    assert pred.degenerate > 0
    assert isinstance(pred.status, Status)


def test_zero_input_velocity_is_at_rest():
    s = rod(0.4, 0.25, 0.3, 0.3, speed=0.0)
    pred = feasible_modes(s)
    assert pred.status is Status.AT_REST
    assert "every commanded joint velocity is zero" in pred.reason
    assert not pred.modes  # with only velocity-driven supports nothing can roll alone


def test_all_contacts_pulling_away():
    """Fingers retreat radially. The all-breaking mode is no candidate (it has no kinematic
    constraint, eq. 29); what remains are modes in which the workpiece rides on one finger, and
    the status says how many there are."""
    pts, nrm = circle_contacts(3, offset=0.3)
    for mu, status in ((0.0, Status.AMBIGUOUS), (0.5, Status.UNIQUE)):
        s = System.from_contacts(points=pts, normals=nrm, mu=mu, external_wrench=[0, -1, 0],
                                 contact_velocities=[[-1, 0], [-1, 0], [-1, 0]])
        pred = feasible_modes(s)
        assert pred.status is status, (mu, pred.labels)
        assert pred.reason.startswith(f"{len(pred.modes)} feasible mode(s)")
        for m in pred.modes:
            assert m.mode.family == "RS" and m.mode.tokens.count("B") == 1


@pytest.mark.parametrize("n_c,status", [(1, Status.NO_CANDIDATES), (2, Status.UNIQUE)])
def test_one_or_two_contacts(n_c, status):
    if n_c == 1:
        s = System.from_contacts(points=[[0, 0]], normals=[[0, 1]], mu=0.3,
                                 external_wrench=[0, -1, 0], contact_velocities=[[0, 1]])
    else:
        s = rod(0.4, 0.25, 0.3, 0.3)
    pred = feasible_modes(s)
    assert pred.status is status
    if n_c == 1:
        assert "admit no mode" in pred.reason and pred.candidates == 0


def test_mu_exactly_zero(example_41):
    pred = feasible_modes(example_41, [0.0, 0.0, 0.0])
    assert pred.labels == ["S+1 S-2 S-3"]


@pytest.mark.parametrize("length", [1e-6, 1e-3, 1.0, 1e3, 1e6])
@pytest.mark.parametrize("load", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("speed", [1e-6, 1e6])
def test_scale_invariance(length, load, speed):
    rng = np.random.default_rng(7)
    found_any = False
    for _ in range(15):
        s = random_system(rng, int(rng.integers(3, 6)), 0, virtual=True)
        ref = feasible_modes(s)
        kw = _system_kwargs(s, pts=s.points * length, g=np.r_[s.g_obj[:2], s.g_obj[2] * length],
                            load_scale=load)
        kw["contact_velocities"] = np.asarray(kw["contact_velocities"]) * speed
        scaled = feasible_modes(System.from_contacts(**kw))
        robust = {m.label for m in ref.modes if m.margin > 1e-6}
        found_any |= bool(robust)
        assert robust <= set(scaled.labels)
        assert {m.label for m in scaled.modes if m.margin > 1e-6} <= set(ref.labels)
    assert found_any


def _perturbed(s, rng, eps=1e-12):
    kw = _system_kwargs(s)
    out = {}
    for key, val in kw.items():
        if key == "joints":
            out[key] = [{k: v * (1 + eps * rng.uniform(-1, 1)) for k, v in j.items()} for j in val]
        elif key == "normals":
            n = np.asarray(val) + eps * rng.uniform(-1, 1, np.shape(val))
            out[key] = n / np.linalg.norm(n, axis=1, keepdims=True)
        else:
            a = np.asarray(val, dtype=float)
            out[key] = a * (1 + eps * rng.uniform(-1, 1, a.shape))
    return System.from_contacts(**out)


@pytest.mark.parametrize("seed", range(40))
def test_decisions_do_not_flip_under_1e12_perturbations(seed):
    rng = np.random.default_rng(seed)
    s = random_system(rng, int(rng.integers(2, 6)), int(rng.integers(0, 2)))
    ref = feasible_modes(s)
    for _ in range(3):
        p = feasible_modes(_perturbed(s, rng))
        assert p.labels == ref.labels
        assert [m.on_boundary for m in p.modes] == [m.on_boundary for m in ref.modes]
        assert [m.label for m in p.boundary_modes] == [m.label for m in ref.boundary_modes]


def test_boundary_case_is_reported_and_stable():
    """Rod exactly on the line l1 mu2 = l2 mu1 (Fig. 8): both RS modes, flagged on the boundary."""
    s = rod(0.4, 0.2, 0.2, 0.1)  # l1 mu2 = 0.04 = l2 mu1
    pred = feasible_modes(s)
    assert sorted(pred.labels) == ["R1 S-2", "S+1 R2"]
    assert all(m.on_boundary for m in pred.modes) and pred.on_boundary
    rng = np.random.default_rng(0)
    for _ in range(20):
        p = feasible_modes(_perturbed(s, rng))
        assert sorted(p.labels) == ["R1 S-2", "S+1 R2"]
        assert all(m.on_boundary for m in p.modes)
