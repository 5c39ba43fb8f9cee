"""The batch API: feasible_modes_batch equals a loop of feasible_modes calls."""

from __future__ import annotations

import numpy as np
import pytest
from randsys import random_system
from test_indeterminate_any_size import box_on_supports, pinched_box, random_redundant_system

from planner.errors import InputError
from planner.predict.batch import feasible_modes_batch
from planner.predict.feasibility import feasible_modes


def assert_same(single, batch):
    assert len(single) == len(batch)
    for a, b in zip(single, batch):
        assert (a.status, a.labels, a.degenerate, a.limits, a.reason) == (
            b.status, b.labels, b.degenerate, b.limits, b.reason)
        assert [m.label for m in a.boundary_modes] == [m.label for m in b.boundary_modes]
        for x, y in zip(a.all_modes, b.all_modes):
            for name in ("qdot", "joint_velocities", "contact_forces", "joint_efforts"):
                np.testing.assert_allclose(getattr(x, name), getattr(y, name),
                                           rtol=1e-9, atol=1e-12, err_msg=name)
            assert x.force_indeterminate == y.force_indeterminate


def two_finger_systems(n, effort=0.0, mu=0.1):
    from planner.files.hand_file import load_hand
    from planner.plan.trajectory import integrate_segment
    from scenarios.registry import shipped_file

    hand, q0, data = load_hand(shipped_file("two_finger_hand"))
    spec = data["segment"]
    seg = integrate_segment(hand, q0, drive=spec["drive"], speed=spec["speed"],
                            mode=spec["mode"], max_time=spec["max_time"]).resample(hand, n)
    return [hand.system(seg.q[i], mu, [{"effort": effort},
                                       {"velocity": float(seg.thetadot[i, 1])}])
            for i in range(n)]


@pytest.mark.parametrize("effort", [0.0, -0.05, 0.05])
def test_two_finger_waypoints(effort):
    systems = two_finger_systems(40, effort=effort)
    assert_same([feasible_modes(s) for s in systems], feasible_modes_batch(systems))


@pytest.mark.parametrize("seed", range(8))
def test_random_systems_with_effort_joints(seed):
    rng = np.random.default_rng(seed)
    n_c, n_e = int(rng.integers(3, 7)), int(rng.integers(0, 3))
    systems = [random_system(np.random.default_rng(1000 * seed + i), n_c, n_effort=n_e,
                             n_velocity=2, virtual=False) for i in range(30)]
    systems = [s for s in systems if s.control == systems[0].control]  # one structure
    assert len(systems) >= 4
    single = [feasible_modes(s) for s in systems]
    assert any(p.labels for p in single)
    assert_same(single, feasible_modes_batch(systems))
    assert_same([feasible_modes(s, indeterminate=False) for s in systems],
                feasible_modes_batch(systems, indeterminate=False))


def test_force_indeterminate_modes_and_the_scan_fallback():
    rng = np.random.default_rng(4)
    boxes = [box_on_supports(6, push=(0.01, t), rng=np.random.default_rng(9))
             for t in np.linspace(-0.02, 0.02, 5)]
    single = [feasible_modes(s) for s in boxes]
    assert any(p.indeterminate_modes for p in single)
    assert_same(single, feasible_modes_batch(boxes))
    pinches = [pinched_box(5, lift=lift, rng=np.random.default_rng(2)) for lift in (0.01, -0.01)]
    assert_same([feasible_modes(s) for s in pinches], feasible_modes_batch(pinches))
    mixed = [random_redundant_system(rng, 9) for _ in range(3)]
    mixed = [s for s in mixed if s.n_contacts == 9 and s.n_joints == mixed[0].n_joints]
    assert_same([feasible_modes(s) for s in mixed], feasible_modes_batch(mixed))


def test_friction_rows_and_errors():
    systems = two_finger_systems(6)
    mus = np.linspace(0.0, 0.4, 6)[:, None] * np.ones(4)
    assert_same([feasible_modes(s, m) for s, m in zip(systems, mus)],
                feasible_modes_batch(systems, mus))
    assert_same([feasible_modes(s, 0.3) for s in systems], feasible_modes_batch(systems, 0.3))
    assert feasible_modes_batch([]) == []
    with pytest.raises(InputError, match=r"mu: expected shape \(6, 4\)"):
        feasible_modes_batch(systems, np.zeros((5, 4)))
    with pytest.raises(InputError, match=r"systems\[1\]: expected the structure"):
        feasible_modes_batch([systems[0], box_on_supports(3)])
    with pytest.raises(InputError, match=r"systems\[0\]: expected a planner System"):
        feasible_modes_batch(["not a system"])


def test_systems_with_different_numbers_of_bodies_are_refused():
    """Same contacts and joints, one body against two: a project error naming both counts,
    not numpy's broadcasting error."""
    import json

    from planner.files.system_file import system_from_dict
    from scenarios.registry import DATA_DIR

    data = json.loads((DATA_DIR / "stacked_blocks.json").read_text())
    two = system_from_dict(data)
    one_body = {k: v for k, v in data.items() if k != "workpieces"}
    one_body["external_wrench"] = [0.0, -3.0, 0.0]
    one_body["contacts"] = [{k: v for k, v in c.items() if k not in ("body", "other")}
                            for c in data["contacts"]]
    one = system_from_dict(one_body)
    assert (one.n_contacts, one.n_joints, one.n_bodies) == (two.n_contacts, two.n_joints, 1)
    with pytest.raises(InputError, match=r"systems\[1\]: expected .*1 bodies.*got .*2 bodies"):
        feasible_modes_batch([one, two])


def test_batch_lists_the_same_boundary_modes():
    """A box on 8 evenly spaced supports pushed by one finger (tests/planner/test_search.py's
    geometry-first box) at three frictions: many kinematic boundary candidates, only some with
    forces within Coulomb; the batch and the single call list the same boundary-tolerance
    modes."""
    from test_search import box_on_supports as pushed_box

    systems = [pushed_box(8, mu) for mu in (0.2, 0.5, 0.9)]
    single = [feasible_modes(s) for s in systems]
    assert all(p.boundary_modes for p in single)
    assert_same(single, feasible_modes_batch(systems))
