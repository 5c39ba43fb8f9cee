"""Several workpieces: hand-derived answers, the block wrench matrix, the file format
and the command line. The brute-force LP check and the property tests are in
tests/planner/test_multibody_lp.py."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.files.system_file import load_system, save_system, system_from_dict
from planner.model.bodies import multibody_wrench_matrix
from planner.model.geometry import wrench_matrix
from planner.model.modes import candidate_count
from planner.model.system import System
from planner.predict.family import nearest_certificate
from planner.predict.feasibility import Status, feasible_modes
from scenarios.registry import DATA_DIR

STACK = DATA_DIR / "stacked_blocks.json"


def stack_pushed_at(block: str, mu_table: float, mu_between: float) -> System:
    """Two stacked blocks (the shipped file's geometry): block 0 = [-1, 1] x [0, 1] of weight
    2 N on the table (contacts 1-2), block 1 = [-0.5, 0.5] x [1, 1.5] of weight 1 N on block 0
    (contacts 3-4 at x = -0.45, 0.45, normals up into block 1), a frictionless pusher moving at 1 m/s in +x on the left face of
    the ``"upper"`` block at height 1.1 or of the ``"lower"`` block at height 0.5."""
    data = json.loads(STACK.read_text())
    for c in data["contacts"][:2]:
        c["mu"] = mu_table
    for c in data["contacts"][2:4]:
        c["mu"] = mu_between
    if block == "lower":
        data["contacts"][4] = {"point": [-1.0, 0.5], "normal": [1.0, 0.0], "mu": 0.0, "body": 0}
    return system_from_dict(data)


def test_block_wrench_matrix_is_two_opposite_blocks() -> None:
    """A contact between bodies 0 and 1 (normal into 1) enters body 1's rows with ``W_i^1``
    (eq. 1) and body 0's rows with ``-W_i^1``; a contact with the manipulator only its body's."""
    pts = np.array([[0.3, 1.0], [-1.0, 0.5]])
    nrm = np.array([[0.0, 1.0], [1.0, 0.0]])
    W = multibody_wrench_matrix(pts, nrm, [(1, 0), (0, -1)], 2)
    W1 = wrench_matrix(pts, nrm)
    assert W.shape == (6, 4)
    np.testing.assert_array_equal(W[3:, 0:2], W1[:, 0:2])
    np.testing.assert_array_equal(W[:3, 0:2], -W1[:, 0:2])
    np.testing.assert_array_equal(W[:3, 2:4], W1[:, 2:4])
    np.testing.assert_array_equal(W[3:, 2:4], 0.0)


def test_candidate_count_uses_three_rows_per_body() -> None:
    """2 n_R + n_S = 3 n_b + |tau_I| (eq. 49 generalised): the stacked blocks (n_b = 2, five
    contacts, no effort joint) need 6 constraints: sum_{n_R} C(5, n_R) C(5 - n_R, 6 - 2 n_R)
    = C(5,1) C(4,4) + C(5,2) C(3,2) + C(5,3) C(2,0) = 5 + 30 + 10 = 45."""
    system = load_system(STACK)
    assert (system.n_bodies, system.n_q, system.dof) == (2, 6, 6)
    assert candidate_count(5, system.dof) == 45
    assert feasible_modes(system).candidates == 45


@pytest.mark.parametrize("mu_table, mu_between", [(0.5, 0.3), (0.3, 0.45), (0.2, 0.5),
                                                  (0.1, 0.25)])
def test_upper_block_slides_when_the_interface_is_weaker(mu_table, mu_between) -> None:
    """Pushing the upper block (weight W1 = 1 N) over the lower one (W0 = 2 N).

    Both blocks stay down (no tipping: the push is 0.1 m above the interface, far below the
    tipping height 0.5 / mu). Two motions remain. (a) The upper block slides, the lower rests:
    the upper block's equilibrium gives pusher force P = mu_b W1 (interface friction at its
    Coulomb limit, c_t = -mu xi c_n with xi = sgn(v_t) = -1 since t = rot90((0, 1)) = (-1, 0)
    and the upper block moves in +x); the lower block takes mu_b W1 in +x and the table holds
    it iff mu_b W1 <= mu_t (W0 + W1). (b) Both slide: P = mu_t (W0 + W1), which the interface
    transmits iff mu_t (W0 + W1) <= mu_b W1. So with mu_b W1 < mu_t (W0 + W1) the unique mode is
    (a), ``R1 R2 S-3 S-4 R5`` (force-indeterminate: two rolling table contacts under one rigid
    block), with qdot = (0, 0, 0, 1, 0, 0) and interface forces summing to (W1, mu_b W1)."""
    assert mu_between * 1.0 < mu_table * 3.0
    pred = feasible_modes(stack_pushed_at("upper", mu_table, mu_between))
    assert pred.status is Status.UNIQUE and pred.labels == ["R1 R2 S-3 S-4 R5"]
    m = pred.all_modes[0]
    np.testing.assert_allclose(m.qdot, [0, 0, 0, 1, 0, 0], atol=1e-9)
    f = m.contact_forces
    np.testing.assert_allclose(f[2:4].sum(axis=0), [1.0, mu_between], rtol=1e-7)
    np.testing.assert_allclose(f[4], [mu_between, 0.0], atol=1e-9)
    np.testing.assert_allclose(f[0:2, 0].sum(), 3.0, rtol=1e-7)


@pytest.mark.parametrize("mu_table, mu_between", [(0.2, 0.9), (0.1, 0.5), (0.05, 0.3)])
def test_blocks_slide_together_when_the_table_is_weaker(mu_table, mu_between) -> None:
    """Same system (derivation in the test above) with mu_t (W0 + W1) < mu_b W1: the unique
    mode is (b), ``S-1 S-2 R3 R4 R5``: both blocks move at 1 m/s (qdot = (1, 0, 0, 1, 0, 0)),
    the table friction is mu_t (W0 + W1) = 3 mu_t and so is the pusher force."""
    assert mu_table * 3.0 < mu_between * 1.0
    pred = feasible_modes(stack_pushed_at("upper", mu_table, mu_between))
    assert pred.status is Status.UNIQUE and pred.labels == ["S-1 S-2 R3 R4 R5"]
    m = pred.all_modes[0]
    np.testing.assert_allclose(m.qdot, [1, 0, 0, 1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(m.contact_forces[4, 0], 3.0 * mu_table, rtol=1e-7)


def test_equal_limits_give_both_modes() -> None:
    """At mu_b W1 = mu_t (W0 + W1) (0.9 = 0.3 * 3) both force conditions above hold with
    equality: the prediction is ambiguous with exactly the two modes (a) and (b)."""
    pred = feasible_modes(stack_pushed_at("upper", 0.3, 0.9))
    assert pred.status is Status.AMBIGUOUS
    assert sorted(pred.labels) == ["R1 R2 S-3 S-4 R5", "S-1 S-2 R3 R4 R5"]


@pytest.mark.parametrize("mu_table, mu_between", [(0.5, 0.05), (0.5, 0.9), (0.9, 0.2)])
def test_upper_block_rides_along_when_the_lower_is_pushed(mu_table, mu_between) -> None:
    """Pushing the lower block at height 0.5 (tipping needs mu_t * 3 * 0.5 > 3 * 1, i.e.
    mu_t > 2). The upper block's only loads are its weight and the interface forces, so the
    horizontal interface force is zero: sliding would need |c_t| = mu_b c_n with
    sum c_n = W1 > 0, impossible for any mu_b > 0. The upper block therefore rides along:
    unique mode ``S-1 S-2 R3 R4 R5``, qdot = (1, 0, 0, 1, 0, 0), zero interface friction,
    pusher force mu_t (W0 + W1) -- whatever the interface friction."""
    pred = feasible_modes(stack_pushed_at("lower", mu_table, mu_between))
    assert pred.status is Status.UNIQUE and pred.labels == ["S-1 S-2 R3 R4 R5"]
    m = pred.all_modes[0]
    np.testing.assert_allclose(m.qdot, [1, 0, 0, 1, 0, 0], atol=1e-9)
    np.testing.assert_allclose(m.contact_forces[2:4, 1].sum(), 0.0, atol=1e-9)
    np.testing.assert_allclose(m.contact_forces[4, 0], 3.0 * mu_table, rtol=1e-7)


def part_and_tool(mu_table: float, mu_wall: float, mu_tool: float, wall: bool = True) -> System:
    """A part (body 0, the box [0, 1] x [0, 1] bevelled to a nose at (1, 0.5), weight 1 N at
    (0.5, 0.5); scenarios/data/part_tool_wall.json) and a tool (body 1, [-1, 0] x [0, 0.5],
    weight 0.5 N) on a table (contacts 1-2 part, 3-4 tool); the tool touches the part's left
    face at (0, 0.25) (contact 5, normal +x into the part); a frictionless pusher drives the
    tool's left face at (-1, 0.25) at 1 m/s in +x (contact 6); optionally a wall touches the
    part's right face at (1, 0.5) (contact 7, normal -x into the part)."""
    pts = [(0, 0), (0.9, 0), (-1, 0), (0, 0), (0, 0.25), (-1, 0.25)]
    nrm = [(0, 1), (0, 1), (0, 1), (0, 1), (1, 0), (1, 0)]
    bodies = [(0, -1), (0, -1), (1, -1), (1, -1), (0, 1), (1, -1)]
    mu = [mu_table] * 4 + [mu_tool, 0.0]
    vel = [(0, 0)] * 5 + [(1, 0)]
    if wall:
        pts.append((1, 0.5))
        nrm.append((-1, 0))
        bodies.append((0, -1))
        mu.append(mu_wall)
        vel.append((0, 0))
    return System.from_contacts(points=pts, normals=nrm, mu=mu, bodies=bodies,
                                external_wrench=[0, -1, -0.5, 0, -0.5, 0.25],
                                contact_velocities=vel)


@pytest.mark.parametrize("mu_table, mu_tool", [(0.5, 0.5), (0.3, 0.9), (0.1, 0.2)])
def test_tool_pushes_part_along_the_table_without_wall(mu_table, mu_tool) -> None:
    """Without the wall the tool pushes the part (push and reaction at the same height 0.25, so
    no couple tips either body): both slide in +x at 1 m/s, ``S-1 S-2 S-3 S-4 R5 R6``. The
    pusher force is the whole table friction mu_t * 1.5 N; the tool-part force P balances the
    part's table friction, P = mu_t (N1 + N2) (the tool's friction may carry some of the part's
    weight: the mode is force-indeterminate, so N1 + N2 is not fixed)."""
    pred = feasible_modes(part_and_tool(mu_table, 0.0, mu_tool, wall=False))
    assert pred.labels == ["S-1 S-2 S-3 S-4 R5 R6"]
    m = pred.all_modes[0]
    np.testing.assert_allclose(m.qdot, [1, 0, 0, 1, 0, 0], atol=1e-9)
    f = m.contact_forces
    np.testing.assert_allclose(f[5, 0], 1.5 * mu_table, rtol=1e-7)
    np.testing.assert_allclose(f[4, 0], mu_table * f[0:2, 0].sum(), rtol=1e-7)


@pytest.mark.parametrize("mu_table, mu_wall, mu_tool", [(0.5, 0.5, 0.5), (0.3, 0.3, 0.9),
                                                        (0.1, 0.4, 0.9)])
def test_part_against_wall_jams_when_the_wall_grips(mu_table, mu_wall, mu_tool) -> None:
    """With the wall the part cannot move in +x, and the tool's pushed point must. The one
    escape keeps contact 1 on the table and the wall contact sliding: the part turns
    counter-clockwise and climbs the wall. Its equilibrium (normal forces N1 at (0, 0), Nw at
    the wall, P from the tool at (0, 0.25), table friction -mu_t N1, wall friction -mu_w Nw
    against the climb, weight at (0.5, 0.5)): x: P = mu_t N1 + Nw; moment about the origin:
    (0.5 - mu_w) Nw - 0.25 P - 0.5 = 0, hence (0.25 - mu_w) Nw = 0.25 mu_t N1 + 0.5 > 0, which
    needs mu_w < 0.25 (the same holds when the tool tips instead of sliding: the part's motion
    and equilibrium are the same). With mu_w > 0.25 nothing can move: jammed (Fig. 3's "Jam");
    at mu_w = 0.25 the forces grow without bound, a boundary case left out here."""
    pred = feasible_modes(part_and_tool(mu_table, mu_wall, mu_tool))
    assert pred.status is Status.JAMMED and pred.labels == []


def test_part_climbs_the_wall_when_the_wall_is_slippery() -> None:
    """mu_t = 0.3, mu_w = 0.1, mu_tool = 0.9 (derivation above). Kinematics: contact 1 stays on
    the table (v_y(0, 0) = 0), the wall contact keeps v_x(1, 0.5) = 0 and the tool contact
    moves with the tool, (1, 0): v_x - 0.25 omega = 1, v_x - 0.5 omega = 0, v_y = 0, so
    qdot_part = (2, 0, 4): it turns about (0, 0.5); contact 2 lifts, the tool slides at 1 m/s.
    Forces at N1 = 0: Nw = 0.5 / 0.15 = 3.33 = P, the tool must lift with f = 1 + mu_w Nw =
    1.33 <= mu_tool P = 3.0, and the tool's back contact keeps N3 = 0.25 - 0.25 mu_t (0.5 + f)
    > 0: feasible. The mode is ``S-1 B2 S-3 S-4 R5 R6 S-7``."""
    system = part_and_tool(0.3, 0.1, 0.9)
    pred = feasible_modes(system)
    assert pred.labels == ["S-1 B2 S-3 S-4 R5 R6 S-7"]
    m = pred.all_modes[0]
    np.testing.assert_allclose(m.qdot, [2, 0, 4, 1, 0, 0], atol=1e-9)
    # The forces are indeterminate (seven unknowns, six equations): the member with N1 = 0 is
    # the one derived above -- t = rot90((1, 0)) = (0, 1) at the tool contact, c_t = f > 0
    # lifts the part; the wall pushes with Nw = P.
    fit = nearest_certificate(system, m.mode, unloaded=[0])
    assert fit is not None
    P = 0.5 / 0.15
    np.testing.assert_allclose(fit.forces[4], [P, 1 + 0.1 * P], rtol=1e-6)
    np.testing.assert_allclose(fit.forces[6], [P, 0.1 * P], rtol=1e-6)
    assert fit.forces[2, 0] == pytest.approx(0.25 - 0.25 * 0.3 * (0.5 + 1 + 0.1 * P))


def test_file_round_trip_and_single_body_files_unchanged(tmp_path) -> None:
    """A multi-body system saved and loaded again gives the same W, loads and bodies; a one-body
    file as saved has no multi-body keys."""
    system = load_system(STACK)
    path = save_system(system, tmp_path / "stack.json")
    again = load_system(path)
    np.testing.assert_array_equal(again.W, system.W)
    np.testing.assert_array_equal(again.g_obj, system.g_obj)
    assert again.contact_bodies == system.contact_bodies
    assert len(again.workpieces) == 2
    one = System.from_contacts(points=[[0, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.3,
                               external_wrench=[0, -1, 0],
                               contact_velocities=[[0, 0.1], [0, 0.1]])
    saved = json.loads(save_system(one, tmp_path / "one.json").read_text())
    assert "workpieces" not in saved and all("other" not in c for c in saved["contacts"])
    assert one.contact_bodies == ((0, -1), (0, -1)) and one.n_bodies == 1


@pytest.mark.parametrize("mutate, message", [
    (lambda d: d.update(external_wrench=[0, 0, 0]), "'external_wrench': expected no"),
    (lambda d: d["contacts"][2].update(other=5), "contact 3 other: expected a workpiece index"),
    (lambda d: d["contacts"][2].update(other=1), "expected two different bodies"),
    (lambda d: d["contacts"][0].update(other=1), "expected either 'other'"),
    (lambda d: d["workpieces"][0].pop("mass"), "expected 'polygon' and 'mass' together"),
    (lambda d: d["workpieces"][1].update(external_wrench=[1, 2]), "expected a list of 3"),
    (lambda d: d["manipulator"]["contact_velocities"][2].__setitem__(0, 1.0),
     "zero manipulator velocity for a contact between two workpieces"),
])
def test_bad_multibody_files_say_what_was_expected(mutate, message) -> None:
    data = json.loads(STACK.read_text())
    mutate(data)
    with pytest.raises(FileFormatError, match=message):
        system_from_dict(data)


def test_body_keys_refused_in_one_body_files() -> None:
    data = {"contacts": [{"point": [0, 0], "normal": [0, 1], "mu": 0.3, "body": 0}],
            "manipulator": {"contact_velocities": [[0, 0]]}}
    with pytest.raises(FileFormatError, match="only in a file with a top-level 'workpieces'"):
        system_from_dict(data)


def test_system_checks_load_and_body_shapes() -> None:
    with pytest.raises(InputError, match="external_wrench: expected shape \\(6,\\)"):
        System.from_contacts(points=[[0, 0]], normals=[[0, 1]], mu=0.3, bodies=[(1, 0)],
                             external_wrench=[0, -1, 0], contact_velocities=[[0, 0]])
    with pytest.raises(InputError, match="expected a body index in 0..1"):
        System.from_contacts(points=[[0, 0]], normals=[[0, 1]], mu=0.3, bodies=[(2, -1)],
                             n_bodies=2, contact_velocities=[[0, 0]])


def test_cli_modes_on_a_multibody_file() -> None:
    """``qsplan modes`` on the shipped stacked-blocks file: exit 0, the derived mode (a)."""
    out = subprocess.run([sys.executable, "-m", "qsplan.cli", "modes", str(STACK)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "mode R1 R2 S-3 S-4 R5" in out.stdout and "status: unique" in out.stdout


def test_friction_map_of_the_wall_threshold() -> None:
    """A 1-D friction-space map (Figs. 3, 6) over the wall coefficient: by the derivation of
    test_part_against_wall_jams_when_the_wall_grips the part climbs for mu_w < 0.25 and
    everything jams for mu_w > 0.25 (mu_t = 0.3, mu_tool = 0.9, where mu_tool >= 0.5 - mu_w
    makes the climb feasible already at N1 = 0)."""
    from planner.friction.muspace import mu_grid

    system = part_and_tool(0.3, 0.1, 0.9)
    grid = mu_grid(system, vary=(6,), base_mu=system.mu, mu_range=(0.0, 0.5), n=51)
    for mu_w, mode_set in zip(grid.axes[0], grid.mode_sets()):
        if mu_w > 0.25 + 1e-9:
            assert mode_set == "jam", mu_w
        elif mu_w < 0.25 - 1e-9:
            # the part climbs: contact 1 slides back, 2 lifts, the wall contact slides; the
            # tool slides along (S-3 S-4) or, near the threshold where the push grows, tips
            # (B3 R4 S+6): the part's motion and equilibrium are the same
            climbs = [m for m in mode_set.split(" | ")
                      if m.split()[0] == "S-1" and m.split()[1] == "B2" and m.endswith("S-7")]
            assert climbs, (mu_w, mode_set)
            if mu_w <= 0.1:
                assert "S-1 B2 S-3 S-4 R5 R6 S-7" in climbs, mu_w


def test_friction_map_agrees_with_feasible_modes_pointwise() -> None:
    """A 2-D map of the stacked blocks (table coefficient of contact 1, interface coefficient
    of contact 3) labels each point with the mode set feasible_modes finds there."""
    from planner.friction.muspace import mu_grid

    system = load_system(STACK)
    grid = mu_grid(system, vary=(0, 2), base_mu=[0.0, 0.1, 0.0, 0.9, 0.0], mu_range=(0.05, 1.0),
                   n=7)
    sets = grid.mode_sets().ravel()
    assert len(set(sets)) >= 2  # the map is not one region
    for mu, mode_set in zip(grid.points(), sets):
        pred = feasible_modes(system, mu)
        if not pred.on_boundary:
            assert mode_set == " | ".join(sorted(pred.labels)) or \
                sorted(mode_set.split(" | ")) == sorted(pred.labels) or \
                (mode_set == "jam" and not pred.labels), (mu, mode_set, pred.labels)


def test_ruler_carrying_a_block() -> None:
    """scenarios/data/ruler_block.json: a ruler (1 N at x = 0) with a block (1 N at x = -0.3)
    on two fingers at x = -0.4 and 0.25 approaching each other (Sec. 5.1 with a payload). The
    joint centre of mass is at x = -0.15, so the left finger carries 2 * 0.4 / 0.65 = 1.231 N
    and the right 0.769 N. Both fingers' friction forces are equal and opposite (the block and
    ruler carry no other horizontal load), so the finger with the smaller limit mu_i N_i slides
    and the other sticks: at mu = 0.4 the right one (0.308 < 0.492): ``R1 S-2 R3 R4``, the
    friction force 0.4 * 0.769 = 0.308 N; at mu = (0.2, 0.5) the left one (0.246 < 0.385):
    ``S+1 R2 R3 R4``. The block rides along (its interface carries no net horizontal force)."""
    system = load_system(DATA_DIR / "ruler_block.json")
    right = feasible_modes(system, [0.4, 0.4, 0.5, 0.5])
    assert right.labels == ["R1 S-2 R3 R4"]
    f = right.all_modes[0].contact_forces
    np.testing.assert_allclose(f[:2, 0], [0.8 / 0.65, 2 - 0.8 / 0.65], rtol=1e-7)
    np.testing.assert_allclose(f[1, 1], 0.4 * (2 - 0.8 / 0.65), rtol=1e-7)
    np.testing.assert_allclose(f[2:4, 1].sum(), 0.0, atol=1e-9)
    left = feasible_modes(system, [0.2, 0.5, 0.5, 0.5])
    assert left.labels == ["S+1 R2 R3 R4"]


def test_ruler_block_friction_map_boundary() -> None:
    """The (mu_1, mu_2) map of the ruler carrying a block: the left finger slides where
    mu_1 N1 < mu_2 N2, i.e. above the line mu_2 = mu_1 * N1 / N2 = 1.6 mu_1 (derivation in
    test_ruler_carrying_a_block), the right one below it."""
    from planner.friction.muspace import mu_grid

    system = load_system(DATA_DIR / "ruler_block.json")
    grid = mu_grid(system, vary=(0, 1), base_mu=system.mu, mu_range=(0.05, 1.0), n=20)
    ratio = 0.8 / (2 * 0.65 - 0.8)  # N1 / N2
    for (m1, m2), mode_set in zip(grid.points()[:, :2], grid.mode_sets().ravel()):
        if m2 > ratio * m1 * 1.02:
            assert mode_set == "S+1 R2 R3 R4", (m1, m2)
        elif m2 < ratio * m1 / 1.02:
            assert mode_set == "R1 S-2 R3 R4", (m1, m2)


def test_jacobian_form_with_several_workpieces() -> None:
    """The stacked blocks with the pusher as one prismatic joint along +x (j_n = n . e_x = 1,
    j_t = t . e_x = 0 at contact 5; zero rows elsewhere): the same modes as the
    contact-velocity file; a non-zero row at a contact between two workpieces is refused."""
    data = json.loads(STACK.read_text())
    rows = [[[0.0], [0.0]]] * 4 + [[[1.0], [0.0]]]
    data["manipulator"] = {"jacobian": rows, "joints": [{"velocity": 1.0}]}
    system = system_from_dict(data)
    assert system.n_joints == 1 and system.dof == 6
    assert feasible_modes(system).labels == feasible_modes(load_system(STACK)).labels
    data["manipulator"]["jacobian"] = [[[0.0], [0.0]]] * 2 + [[[0.5], [0.0]]] + rows[3:]
    with pytest.raises(FileFormatError, match="zero Jacobian rows for a contact between two"):
        system_from_dict(data)


def test_chain_form_with_several_workpieces() -> None:
    """The pusher as a prismatic chain joint along x: contacts off the chain (environment and
    between workpieces) have ``null`` links and zero Jacobian rows; the modes are those of the
    contact-velocity file. A link given for a contact between two workpieces is refused."""
    data = json.loads(STACK.read_text())
    data["manipulator"] = {"chain": {"joints": [{"type": "prismatic"}]}, "q": [0.0],
                           "contact_links": [None, None, None, None, 0],
                           "joints": [{"velocity": 1.0}]}
    system = system_from_dict(data)
    np.testing.assert_array_equal(system.J[:8], 0.0)
    assert feasible_modes(system).labels == ["R1 R2 S-3 S-4 R5"]
    data["manipulator"]["contact_links"] = [None, None, 0, None, 0]
    with pytest.raises(FileFormatError, match="between two workpieces touches no link"):
        system_from_dict(data)
