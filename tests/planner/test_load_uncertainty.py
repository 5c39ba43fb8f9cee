"""Guarantees over the workpiece's uncertain mass and centre of mass (docs/planning.md,
"Uncertainty beyond friction"): the hand file's section, a band derived by hand, the dense
single-point check with a mutation, and the defaults reproducing the friction-only plans.

The hand-derived case is the field's block tilting (scenarios/data/block_tilting.json) at its
start pose: a cube of side ``w = H = 0.075 m`` on a table, the finger's tip on the top face at
``x_f = 0.045 m`` (0.4 of the edge from the pivot, vertex 1 at ``(w, 0)``), joint 0 dragging the tip
along ``+x`` (velocity-controlled), joint 1 pressing it down with the force ``N`` [N]
(effort-controlled).  The claim ``B1 R2 R3``: vertex 0 lifts, the block rolls about vertex 1 and
the tip sticks.  The block's weight ``m g`` acts at ``(c_x, c_y)`` (pose 0: the body frame is the
world frame); the finger pushes ``(f_x, -N)`` on the block at ``(x_f, H)``.  Moments about the
pivot (counter-clockwise positive)::

    (w - x_f) N - H f_x + (w - c_x) m g = 0   =>   f_x = ((w - x_f) N + (w - c_x) m g) / H.

The tip sticks while ``f_x <= mu N`` (``mu`` the finger's coefficient):

    N >= N*(m, c_x, mu) = (w - c_x) m g / (mu H - (w - x_f))      (mu H > w - x_f),

and below ``N*`` the rival ``R1 R2 S-3`` (the tip slides back over the resting block, vertex 0
still loaded: the same moment with ``f_x = mu N``) is possible -- so ``N*`` is both the claim's
lower end and the rival's upper end.  The pivot sticks when ``f_x <= mu (N + m g)``, which with
``mu H = 0.06 > w - x_f = 0.03`` and ``c_x < w`` always holds once the tip sticks.  Over a mass
interval, a centre-of-mass box and a friction interval the guaranteed efforts are therefore
``(max N*, inf)`` with the maximum at ``m = m_hi``, ``c_x = c_x,lo``, ``mu = mu_lo``; ``c_y`` does
not enter (the weight is vertical at this pose).  ``g = 9.81`` (the file's load is
``0.5 kg * 9.81``).
"""

from __future__ import annotations

import itertools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.errors import FileFormatError, InputError
from planner.files.hand_file import hand_file_from_dict, load_hand_file
from planner.model.load_set import LoadSet
from planner.plan.guarantee import guarantee
from planner.plan.hand_planner import plan_hand
from planner.plan.load_bounds import row_union, with_load
from planner.plan.load_margins import command_guaranteed, holds, tolerated
from planner.plan.partition import guaranteed_at, joint_inputs
from planner.plan.polytope import torque_region
from planner.predict.feasibility import feasible_modes

ROOT = Path(__file__).resolve().parents[2]
TILT = ROOT / "scenarios" / "data" / "block_tilting.json"
W, H, XF, G = 0.075, 0.075, 0.045, 9.81
CLAIM = "B1 R2 R3"


def n_star(m: float, cx: float, mu: float) -> float:
    """The hand-derived lower end (module docstring)."""
    return (W - cx) * m * G / (mu * H - (W - XF))


@pytest.fixture(scope="module")
def tilt():
    hf = load_hand_file(TILT)
    system = hf.hand.system(hf.q0, 0.0, joint_inputs(hf.hand, (0,), [0.01]))
    return hf.hand, hf.q0, system


def load_set(mass=(0.5, 0.5), cx=(0.0375, 0.0375), cy=(0.0375, 0.0375)) -> LoadSet:
    return LoadSet(tuple(mass), (tuple(cx), tuple(cy)), 0.5, (0.0375, 0.0375))


@pytest.mark.parametrize("mass, cx, cy, mu", [
    ((0.4, 0.6), (0.0325, 0.0425), (0.0375, 0.0375), (0.8, 0.8)),
    ((0.5, 0.5), (0.0325, 0.0425), (0.0375, 0.0375), (0.8, 0.8)),
    ((0.45, 0.5), (0.0375, 0.0375), (0.0375, 0.0375), (0.8, 0.8)),
    ((0.4, 0.6), (0.0325, 0.0425), (0.03, 0.045), (0.7, 0.8)),
])
def test_tilting_band_is_the_hand_derived_intersection(tilt, mass, cx, cy, mu):
    hand, q0, system = tilt
    loads = replace(hand, load_set=load_set(mass, cx, cy)).load_vertices(q0)
    g = guarantee(system, CLAIM, mu, loads=loads)
    expect = n_star(mass[1], cx[0], mu[0])
    assert len(g.pieces) == 1
    assert g.pieces[0].lower == pytest.approx(expect, rel=1e-9)
    assert g.pieces[0].upper == np.inf
    # the nominal plan's band is the point value; the set only ever shrinks it
    g0 = guarantee(system, CLAIM, mu)
    assert g0.pieces[0].lower == pytest.approx(n_star(0.5, 0.0375, mu[0]), rel=1e-9)
    assert g0.pieces[0].lower <= g.pieces[0].lower + 1e-12


def test_centre_of_mass_height_does_not_move_the_flat_block_band(tilt):
    hand, q0, system = tilt
    a = guarantee(system, CLAIM, 0.8, loads=replace(
        hand, load_set=load_set(cx=(0.0325, 0.0425))).load_vertices(q0))
    b = guarantee(system, CLAIM, 0.8, loads=replace(
        hand, load_set=load_set(cx=(0.0325, 0.0425), cy=(0.0, 0.07))).load_vertices(q0))
    assert a.pieces == b.pieces


def test_polytope_region_over_corner_vertex_pairs_matches(tilt):
    """The any-``p`` path (rows at friction corner x vertex load) gives the same lower end."""
    hand, q0, system = tilt
    loads = replace(hand, load_set=load_set((0.4, 0.6), (0.0325, 0.0425))).load_vertices(q0)
    reg = torque_region(system, CLAIM, (0.7, 0.8), model="independent", method="polytope",
                        loads=loads)
    lower = -reg.b[np.flatnonzero(reg.A[:, 0] < 0)] / -reg.A[reg.A[:, 0] < 0, 0]
    assert np.max(lower) == pytest.approx(n_star(0.6, 0.0325, 0.7), rel=1e-9)


def bad_samples(system, loads_at, taus, mus):
    """Samples (tau, mu, m, cx, cy) where the plain single-point prediction (the full mode
    enumeration at one friction and one load) finds another mode than the claim."""
    bad = []
    for (m, cx, cy), mu in itertools.product(loads_at, mus):
        s = with_load(system, loads_at[(m, cx, cy)])
        for tau in taus:
            labels = feasible_modes(s.with_joint_inputs([0.01, tau]), np.full(3, mu)).labels
            if labels != [CLAIM]:
                bad.append((tau, mu, m, cx, cy, labels))
    return bad


def test_dense_samples_confirm_the_region_and_catch_a_widened_one(tilt):
    """Interior points of the set too (not only its vertices): 0 violations inside the robust
    region, violations as soon as its lower end is moved 4 % down."""
    hand, q0, system = tilt
    ms, cxs, cys, mus = (np.linspace(0.4, 0.6, 4), np.linspace(0.0325, 0.0425, 4),
                         np.linspace(0.0325, 0.0425, 2), np.linspace(0.7, 0.8, 3))
    loads_at = {}
    for m, cx, cy in itertools.product(ms, cxs, cys):  # one load: the weight m g at (cx, cy)
        loads_at[(m, cx, cy)] = np.array([0.0, -m * G, -cx * m * G])
    ls = replace(hand, load_set=load_set((0.4, 0.6), (0.0325, 0.0425), (0.0325, 0.0425)))
    g = guarantee(system, CLAIM, (0.7, 0.8), loads=ls.load_vertices(q0))
    lo = g.pieces[0].lower
    inside = lo * np.array([1.0 + 1e-6, 1.2, 2.0])
    assert bad_samples(system, loads_at, inside, mus) == []
    widened = lo * np.array([0.96, 0.99])
    assert len(bad_samples(system, loads_at, widened, mus)) > 0


def test_row_union_is_a_superset_and_empties_on_a_failing_flat_row():
    s1 = np.array([[1.0, -1.0, 0.0], [2.0, -1.0, 0.0]])
    s0 = np.array([[-1.0, 3.0, 1.0], [-4.0, 5.0, 1.0]])
    iv = row_union(s0, s1, np.ones(2), np.ones(2), np.array([True, True, True]), 1e-9)
    assert (iv.lower, iv.upper) == (1.0, 5.0)  # min of 1 and 2; max of 3 and 5
    s0[:, 2] = -1.0  # a row free of tau failing at every point: impossible everywhere
    assert row_union(s0, s1, np.ones(2), np.ones(2), np.array([True, True, True]), 1e-9).empty


def _data(path: Path) -> dict:
    return json.loads(path.read_text())


@pytest.mark.parametrize("section, message", [
    ({"mass": [0.6, 0.7]}, "uncertainty: mass interval: expected 0 < lo <= 0.5"),
    ({"mass": [0.6]}, "uncertainty.mass: expected [lo, hi], got"),
    ({"mass": [0.6, 0.4]}, "uncertainty.mass: expected lo <= hi, got [0.6, 0.4]"),
    ({"com": [[0.0, 0.01], [0.03, 0.04]]}, "expected x_lo <= 0.0375 (the workpiece's com.x)"),
    ({"com": [0.0, 0.1]}, "uncertainty.com[0]: expected [lo, hi], got"),
    ({"centre": 1}, "uncertainty"),
])
def test_hand_file_section_errors_name_the_field(section, message):
    d = _data(TILT)
    d["uncertainty"] = section
    with pytest.raises(FileFormatError, match=message.replace("[", r"\[").replace("(", r"\(")
                       .replace(")", r"\)")):
        hand_file_from_dict(d)


def test_hand_file_section_reads_and_defaults_to_the_nominal_point():
    d = _data(TILT)
    d["uncertainty"] = {"mass": [0.4, 0.6]}
    ls = hand_file_from_dict(d).hand.load_set
    assert ls.mass == (0.4, 0.6) and ls.com == ((0.0375, 0.0375), (0.0375, 0.0375))
    assert len(ls.points()) == 2
    d["uncertainty"] = {}
    hf = hand_file_from_dict(d)
    assert hf.hand.load_set.trivial and hf.hand.load_vertices(hf.q0) is None
    assert hand_file_from_dict(_data(TILT)).hand.load_set is None


def test_load_set_checks_its_values():
    with pytest.raises(InputError, match="expected 0 < lo"):
        LoadSet((0.0, 1.0), ((0, 0), (0, 0)), 0.5, (0.0, 0.0))
    with pytest.raises(InputError, match="axis: expected 'mass', 'com' or 'contacts', got 'x'"):
        load_set().widened("x", 1.0)


def test_command_guaranteed_up_to_the_hand_derived_mass(tilt):
    """A press force ``N`` stays guaranteed while ``N > N*(m0 + d, c_x, mu)``: the largest mass
    half-width is ``d* = N (mu H - (w - x_f)) / ((w - c_x) g) - m0`` (module docstring)."""
    hand, q0, _ = tilt
    N, mu, cx = 9.0, 0.8, 0.0375
    d_star = N * (mu * H - (W - XF)) / ((W - cx) * G) - 0.5
    for d, expect in ((d_star * (1 - 1e-6), True), (d_star * (1 + 1e-6), False)):
        h = replace(hand, load_set=load_set().widened("mass", d))
        assert command_guaranteed(h, q0, (0,), [0.01], CLAIM, 0.8, "common", [N]) is expect


@pytest.mark.long
def test_tolerated_brackets_hold_and_fail():
    """The certified end holds at every waypoint; one resolution further fails."""
    d = _data(TILT)
    d["uncertainty"] = {"mass": [0.45, 0.55]}
    plan = plan_hand(hand_file_from_dict(d), waypoints=3, margins=False)
    tol = tolerated(plan, steps=5)
    base = plan.segments[0].hand_model[0].load_set
    assert 0.05 <= tol.mass_kg < 0.5 and 0 < tol.com_m < 0.075
    assert holds(plan, base.widened("mass", tol.mass_kg))
    assert not holds(plan, base.widened("mass", tol.mass_kg + tol.mass_resolution_kg))
    assert holds(plan, base.widened("com", tol.com_m))
    assert not holds(plan, base.widened("com", tol.com_m + tol.com_resolution_m))


def test_a_rival_union_can_end_inside_the_load_hull():
    """Why vertices do not suffice for rivals (docs/planning.md): rows ``tau >= g`` and
    ``tau >= -g`` over ``g in [-1, 1]`` make the rival possible for ``tau >= max(g, -g)``; the
    union's end is 0, at ``g = 0`` inside the hull, while both vertex loads give 1.  The row bound
    (-1) contains the union; the vertex hull (1) would not -- so the band is marked inexact."""
    g = np.array([-1.0, 1.0])  # the two vertex loads
    s0 = np.stack([-g, g, np.zeros(2)], axis=1)  # rows: tau - g, tau + g, (unused)
    s1 = np.stack([np.ones(2), np.ones(2), np.zeros(2)], axis=1)
    outer = row_union(s0, s1, np.ones(2), np.ones(2), np.array([True, True, False]), 1e-9)
    inner = min(max(x, -x) for x in g)
    exact_end = min(max(x, -x) for x in np.linspace(-1, 1, 201))
    assert outer.lower == -1.0 <= exact_end == 0.0 < inner == 1.0


def test_an_empty_region_names_the_load_set():
    """The table-push hand (no effort joint) tips over a centre of mass +-15 mm: the reason
    says the set was part of the question."""
    hf = load_hand_file(ROOT / "scenarios" / "data" / "table_push_hand.json")
    mu = [(0.3, 0.5), (0.3, 0.5), (0.0, 0.1)]
    wide = LoadSet((0.1, 0.1), ((0.005, 0.035), (0.005, 0.035)), 0.1, (0.02, 0.02))
    plain = guaranteed_at(hf.hand, hf.q0, (0,), np.array([0.05]), "S-1 S-2 S-3", mu,
                          "independent")
    assert not plain.empty
    gd = guaranteed_at(replace(hf.hand, load_set=wide), hf.q0, (0,), np.array([0.05]),
                       "S-1 S-2 S-3", mu, "independent")
    assert gd.empty and gd.reason().endswith("(with the workpiece's mass and centre-of-mass set)")
