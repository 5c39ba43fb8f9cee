"""Relaxed-utility (force-indeterminate) modes at any n_c, against an independent
brute force over all 3^n_c contact-state assignments; the status when a limit applies; bounded
memory of the exhaustive enumeration."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from certify import check_certificate
from scipy.optimize import linprog

from planner import Status, System, feasible_modes
from planner.errors import InputError
from planner.predict import feasibility
from planner.predict.indeterminate import (
    closed_bases_suffice,
    indeterminate_modes,
    scan_indeterminate,
)

B_, S_, R_ = 0, 1, 2  # this file's own codes (the brute force shares nothing with planner)


def box_on_supports(n_supports, mu=0.5, push_height=0.1, push=(0.01, 0.0), rng=None):
    """A 2 x 1 box on ``n_supports`` collinear supports (redundant: their normal rows span a
    plane) and a finger on its left side at ``push_height``, moving at ``push`` (normal,
    tangent), given as contact-point velocities."""
    xs = (np.sort(rng.uniform(-1.0, 1.0, n_supports)) if rng is not None
          else np.linspace(-1.0, 1.0, n_supports))
    points = [[x, 0.0] for x in xs] + [[-1.0, push_height]]
    normals = [[0.0, 1.0]] * n_supports + [[1.0, 0.0]]
    vel = [[0.0, 0.0]] * n_supports + [list(push)]
    return System.from_contacts(points=points, normals=normals, mu=mu,
                                external_wrench=[0.0, -1.0, 0.0], contact_velocities=vel)


def random_redundant_system(rng, n_c):
    """Collinear supports on a table (at rest), one or two moving fingers on the box's sides
    or top, random load and friction: force-indeterminate modes are common."""
    n_f = int(rng.integers(1, 3))
    n_s = n_c - n_f
    xs = np.sort(rng.uniform(-1.0, 1.0, n_s))
    points = [[x, 0.0] for x in xs]
    normals = [[0.0, 1.0]] * n_s
    vel = [[0.0, 0.0]] * n_s
    for _ in range(n_f):
        side = int(rng.integers(0, 3))
        if side == 0:
            points.append([-1.0, rng.uniform(0.05, 0.9)])
            normals.append([1.0, 0.0])
        elif side == 1:
            points.append([1.0, rng.uniform(0.05, 0.9)])
            normals.append([-1.0, 0.0])
        else:
            points.append([rng.uniform(-0.9, 0.9), 1.0])
            normals.append([0.0, -1.0])
        vel.append([rng.uniform(0.0, 0.02), rng.normal(0.0, 0.01)])
    load = [rng.normal(0.0, 0.3), -1.0, rng.normal(0.0, 0.2)]
    return System.from_contacts(points=points, normals=normals, mu=rng.uniform(0.1, 0.9, n_c),
                                external_wrench=load, contact_velocities=vel)


def brute_force_indeterminate(system, tol=1e-7):
    """Labels of the feasible modes with more than 3 + |tau_I| kinematic constraints, by
    testing every one of the 3^n_c assignments: least-squares velocities (unique and
    consistent), strict separation/slip, then one force LP per survivor."""
    n_c = system.n_contacts
    E, V = system.effort_joints, system.velocity_joints
    K = np.concatenate([system.W.T, -system.J[:, E]], axis=1)  # rows: n_1, t_1, n_2, ...
    k = K.shape[1]
    b = system.J[:, V] @ system.joint_inputs[V]
    v_scale = max(float(np.max(np.abs(b))), 1e-300)
    found = []
    total = 3 ** n_c
    digits = 3 ** np.arange(n_c)
    for start in range(0, total, 200_000):
        idx = np.arange(start, min(total, start + 200_000))
        codes = (idx[:, None] // digits) % 3  # (m, n_c)
        mask = np.zeros((len(idx), 2 * n_c))
        mask[:, 0::2] = codes != B_
        mask[:, 1::2] = codes == R_
        many = mask.sum(axis=1) > k
        codes, mask = codes[many], mask[many]
        outer = (K[:, :, None] * K[:, None, :]).reshape(2 * n_c, k * k)
        M = (mask @ outer).reshape(-1, k, k)
        ev = np.linalg.eigvalsh(M)
        ok = ev[:, 0] > 1e-9 * ev[:, -1]
        codes, mask, M = codes[ok], mask[ok], M[ok]
        z = np.linalg.solve(M, ((mask * b) @ K)[..., None])[..., 0]
        v = z @ K.T - b
        consistent = np.max(np.abs(v) * mask, axis=1) <= tol * v_scale
        vn, vt = v[:, 0::2], v[:, 1::2]
        separate = np.all((codes != B_) | (vn > tol * v_scale), axis=1)
        slip = np.all((codes != S_) | (np.abs(vt) > tol * v_scale), axis=1)
        for c, vt_row in zip(codes[consistent & separate & slip],
                             vt[consistent & separate & slip]):
            xi = np.sign(vt_row)
            if forces_feasible(system, c, xi):
                found.append(" ".join(
                    ("B" if s == B_ else "R" if s == R_ else ("S+" if x > 0 else "S-")) + str(i + 1)
                    for i, (s, x) in enumerate(zip(c, xi))))
    return sorted(found)


def forces_feasible(system, codes, xi):
    """Contact forces with W c = -g_obj, J_E^T c = tau_E - g_man_E, c = 0 at B, Coulomb cone at
    R, c_t = -mu xi c_n >= 0-normal at S (eqs. 9-11, 17, 21-22, 26): max-slack LP."""
    n_c = system.n_contacts
    E = system.effort_joints
    A_eq = np.concatenate([system.W, system.J[:, E].T], axis=0)  # (k, 2 n_c)
    b_eq = np.concatenate([-system.g_obj, system.joint_inputs[E] - system.g_man[E]])
    ub_rows, bounds = [], []
    for i in range(n_c):
        bounds += [(0.0, 0.0), (0.0, 0.0)] if codes[i] == B_ else [(None, None), (None, None)]
        if codes[i] == R_:
            for sgn in (1.0, -1.0):
                row = np.zeros(2 * n_c + 1)
                row[2 * i], row[2 * i + 1], row[-1] = -system.mu[i], sgn, 1.0
                ub_rows.append(row)
        if codes[i] != B_:
            row = np.zeros(2 * n_c + 1)
            row[2 * i], row[-1] = -1.0, 1.0
            ub_rows.append(row)
    eq_rows = [np.r_[A_eq[j], 0.0] for j in range(A_eq.shape[0])]
    eq_rhs = list(b_eq)
    for i in range(n_c):
        if codes[i] == S_:
            row = np.zeros(2 * n_c + 1)
            row[2 * i + 1], row[2 * i] = 1.0, system.mu[i] * xi[i]
            eq_rows.append(row)
            eq_rhs.append(0.0)
    scale = max(float(np.max(np.abs(b_eq))), 1.0)
    res = linprog(np.r_[np.zeros(2 * n_c), -1.0], A_ub=np.array(ub_rows),
                  b_ub=np.zeros(len(ub_rows)), A_eq=np.array(eq_rows), b_eq=eq_rhs,
                  bounds=[*bounds, (None, scale)], method="highs")
    return res.status == 0 and -res.fun >= -1e-9 * scale


def pinched_box(n_supports, lift=0.01, squeeze=0.0, mu=0.6, rng=None):
    """A box on ``n_supports`` supports, pinched by two fingers on one horizontal line (the
    opposite normals defeat the structural shortcut) that move up by ``lift``."""
    xs = (np.sort(rng.uniform(-1.0, 1.0, n_supports)) if rng is not None
          else np.linspace(-1.0, 1.0, n_supports))
    points = [[x, 0.0] for x in xs] + [[-1.0, 0.5], [1.0, 0.5]]
    normals = [[0.0, 1.0]] * n_supports + [[1.0, 0.0], [-1.0, 0.0]]
    # contact frames: t = (-n_y, n_x) rotated so that n x t = +1
    vel = [[0.0, 0.0]] * n_supports + [[squeeze, lift], [squeeze, -lift]]
    return System.from_contacts(points=points, normals=normals, mu=mu,
                                external_wrench=[0.0, -1.0, 0.0], contact_velocities=vel)


@pytest.mark.parametrize("n_c", [*range(9, 13), *(pytest.param(n, marks=pytest.mark.slow)
                                                  for n in (13, 14))])  # 13-14: -m slow
@pytest.mark.long
def test_relaxed_utility_modes_agree_with_brute_force(n_c):
    rng = np.random.default_rng(1500 + n_c)
    system = random_redundant_system(rng, n_c)
    pred = feasible_modes(system)
    assert pred.complete and pred.limits == ()
    got = sorted(m.label for m in pred.indeterminate_modes)
    want = brute_force_indeterminate(system)
    assert got == want
    for fm in pred.indeterminate_modes:
        check_certificate(system, fm)
    # the general row-subset scan (used when the structural shortcut does not apply) agrees
    scan = scan_indeterminate(system)
    assert sorted(m.label for m in indeterminate_modes(
        system, system.mu, kinematics=scan.kinematics)) == want


def test_pinch_grasp_needs_the_full_scan_and_gets_it():
    system = pinched_box(7, rng=np.random.default_rng(7))
    assert not closed_bases_suffice(system)
    assert closed_bases_suffice(box_on_supports(7, rng=np.random.default_rng(7)))
    pred = feasible_modes(system)
    want = brute_force_indeterminate(system)
    assert sorted(m.label for m in pred.indeterminate_modes) == want
    assert "B1 B2 B3 B4 B5 B6 B7 R8 R9" in want and pred.complete


def test_brute_force_finds_relaxed_modes_in_these_systems():
    """The comparison above is not vacuous: the seeds include force-indeterminate modes."""
    counts = [len(brute_force_indeterminate(random_redundant_system(
        np.random.default_rng(1500 + n_c), n_c))) for n_c in (9, 10)]
    assert sum(counts) > 0


@pytest.mark.parametrize("n_supports", [8, 12])
def test_box_on_many_supports_pushed_low_slides(n_supports):
    system = box_on_supports(n_supports)
    pred = feasible_modes(system)
    slide = " ".join(f"S-{i + 1}" for i in range(n_supports)) + f" R{n_supports + 1}"
    assert pred.status is Status.UNIQUE and pred.labels == [slide]
    assert pred.indeterminate_modes[0].force_indeterminate and pred.complete
    check_certificate(system, pred.indeterminate_modes[0])


def test_limit_is_reported_not_skipped_silently():
    system = box_on_supports(8)
    off = feasible_modes(system, indeterminate=False)
    assert off.status is Status.JAMMED and not off.complete
    assert off.limits == (feasibility.INDETERMINATE_OFF,) and "NOT COMPLETE" in off.reason
    budget = feasible_modes(system, max_subsets=100)  # C(18, 3) = 816 row subsets
    assert not budget.complete and "C(18, 3) = 816 row subsets exceed max_subsets = 100" in (
        budget.limits[0])
    assert budget.to_dict()["complete"] is False
    forced = feasible_modes(system, indeterminate=True, max_subsets=100)
    assert forced.complete and forced.status is Status.UNIQUE


def test_cli_prints_the_limit_and_the_sliding_mode(tmp_path, capsys):
    from planner.files.system_file import save_system
    from qsplan.cli import main

    path = tmp_path / "box8.json"
    save_system(box_on_supports(8), path)
    assert main(["modes", str(path)]) == 0
    out = capsys.readouterr().out
    assert "status: unique" in out and "S-8 R9" in out and "limit:" not in out
    assert main(["modes", str(path), "--no-indeterminate"]) == 0
    out = capsys.readouterr().out
    assert "status: jammed" in out and f"limit: {feasibility.INDETERMINATE_OFF}" in out
    assert main(["modes", str(path), "--indeterminate"]) == 0
    assert "S-8 R9" in capsys.readouterr().out


def test_large_enumeration_is_streamed_in_bounded_memory(monkeypatch):
    system = box_on_supports(49, rng=np.random.default_rng(3))  # 19,600 + 2,450 candidates
    whole = feasible_modes(system, indeterminate=False)
    assert whole.method == "exhaustive"
    monkeypatch.setattr(feasibility, "STREAM_ELEMENTS", 100 * 1000)  # 1,000 per chunk
    tracemalloc.start()
    streamed = feasible_modes(system, indeterminate=False)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert streamed.method == "exhaustive, streamed in 23 chunks"
    assert streamed.labels == whole.labels and streamed.degenerate == whole.degenerate
    # unstreamed, the velocities alone are 22,050 x 100 doubles (17.6 MB)
    assert peak < 6e6


def test_too_large_exhaustive_request_is_refused():
    from planner.sweeps.random_systems import random_system

    with pytest.raises(InputError, match="candidate modes .* use planner.predict.search"):
        feasible_modes(random_system(0, 30), indeterminate=False)


def test_cli_json_carries_completeness(tmp_path, capsys):
    import json

    from planner.files.system_file import save_system
    from qsplan.cli import main

    path = tmp_path / "box12.json"
    save_system(box_on_supports(12), path)
    assert main(["modes", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] is True and out["limits"] == [] and out["method"] == "exhaustive"
    assert out["status"] == "unique" and out["modes"][0]["force_indeterminate"] is True
    assert main(["modes", str(path), "--json", "--no-indeterminate"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["complete"] is False and out["status"] == "jammed"
    assert out["limits"] == [feasibility.INDETERMINATE_OFF]


def test_search_reports_an_over_budget_relaxed_scan():
    from planner.predict.search import search_modes
    from planner.sweeps.random_systems import random_system

    system = random_system(0, 11)  # C(22, 11) = 705,432 row subsets > 250,000
    pred = search_modes(system).prediction
    assert pred.method == "search" and not pred.complete
    assert "C(22, 11) = 705432 row subsets exceed max_subsets" in pred.limits[0]
    assert "NOT COMPLETE" in pred.reason
    # the exhaustive call proves by the structural test that there is nothing to scan
    assert feasible_modes(system).complete


def test_streamed_enumeration_finds_the_relaxed_modes_too(monkeypatch):
    system = box_on_supports(20, rng=np.random.default_rng(5))  # 21 contacts: 1,750 candidates
    whole = feasible_modes(system)
    assert whole.indeterminate_modes and whole.complete and whole.method == "exhaustive"
    monkeypatch.setattr(feasibility, "STREAM_ELEMENTS", 42 * 100)  # 256 per chunk (the floor)
    streamed = feasible_modes(system)
    assert streamed.method == "exhaustive, streamed in 7 chunks" and streamed.complete
    assert streamed.labels == whole.labels and streamed.status is whole.status
