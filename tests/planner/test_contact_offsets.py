"""Guarantees over the contacts' positions along their features (docs/planning.md, "Contact
positions"): the hand file's ``uncertainty.contacts``, the one-row-one-column structure, a band
derived by hand, dense sampling of the whole set on random hands with a mutation, and the
defaults reproducing the plans.

The hand-derived case is the field's block tilting at its start pose (the derivation of ``N*``:
tests/planner/test_load_uncertainty.py).  Moving the pivot (vertex 1 on the table, tangent
``rot90((0, 1)) = (-1, 0)``) by ``s_2`` puts it at ``w - s_2``; moving the tip on the top edge
(tangent ``rot90((0, -1)) = (1, 0)``) by ``s_3`` puts it at ``x_f + s_3``; the moments about the
pivot then give::

    N*(s) = (w - s_2 - c_x) m g / (mu H - (w - s_2 - x_f - s_3)),

increasing as ``s_2`` and ``s_3`` decrease, so over ``|s_i| <= d`` the robust band is
``(N*(-d, -d), inf)``; vertex 0 breaks (``B1``) and its offset does not enter.
"""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.errors import DegenerateError, FileFormatError, InputError
from planner.files.hand_file import hand_file_from_dict, load_hand_file
from planner.model.load_set import LoadSet
from planner.model.validation import friction_interval
from planner.plan.guarantee import guarantee
from planner.plan.hand_planner import plan_hand
from planner.plan.load_bounds import load_bands
from planner.plan.load_margins import Tolerance, command_guaranteed, holds, tolerated
from planner.plan.offset_bounds import (
    candidate_arrays,
    lifted_interval,
    offset_box,
    offset_corners,
    uniform_stages,
)
from planner.plan.partition import guaranteed_at, joint_inputs
from planner.plan.plan_file import plan_body
from planner.sweeps.random_hands import random_hand
from planner.sweeps.set_samples import (
    finger_point_jacobian,
    friction_corners,
    set_interior,
    set_vertices,
    set_violations,
    with_uncertainty,
)
from qsplan.commands.plan import uncertainty_words

ROOT = Path(__file__).resolve().parents[2]
TILT = ROOT / "scenarios" / "data" / "block_tilting.json"
W, H, XF, G = 0.075, 0.075, 0.045, 9.81
CLAIM = "B1 R2 R3"


def n_star(m: float, cx: float, mu: float, s2: float, s3: float) -> float:
    """The hand-derived lower end (module docstring)."""
    return (W - s2 - cx) * m * G / (mu * H - (W - s2 - XF - s3))


def _data(path: Path) -> dict:
    return json.loads(path.read_text())


@pytest.fixture(scope="module")
def tilt():
    hf = load_hand_file(TILT)
    return hf.hand, hf.q0, joint_inputs(hf.hand, (0,), [0.01])


def _set(d: float = 0.0, bodies: tuple = (), mass=(0.5, 0.5), cx=(0.0375, 0.0375)) -> LoadSet:
    return LoadSet(tuple(mass), (tuple(cx), (0.0375, 0.0375)), 0.5, (0.0375, 0.0375), d, bodies)


# ---- the file section -----------------------------------------------------------------------
def test_section_reads_a_number_and_per_body_offsets():
    d = _data(TILT)
    d["uncertainty"] = {"contacts": 0.002}
    hand = hand_file_from_dict(d).hand
    assert hand.contact_offsets().tolist() == [0.002, 0.002, 0.002]
    assert hand.load_set.trivial and hand.load_vertices(np.zeros(5)) is None
    d["uncertainty"] = {"contacts": {"finger": 0.003, "*": 0.001}}
    hand = hand_file_from_dict(d).hand
    assert hand.contact_offsets().tolist() == [0.001, 0.001, 0.003]
    assert hand.load_set.to_dict()["contacts"] == {"finger": 0.003, "*": 0.001}
    d["uncertainty"] = {"contacts": {"table": 0.002}}
    assert hand_file_from_dict(d).hand.contact_offsets().tolist() == [0.002, 0.002, 0.0]
    d["uncertainty"] = {"contacts": 0}
    hand = hand_file_from_dict(d).hand
    assert hand.contact_offsets() is None and "contacts" not in hand.load_set.to_dict()


@pytest.mark.parametrize("value, message", [
    (-0.001, "uncertainty.contacts: expected a number >= 0, got -0.001"),
    ({"thumb": 0.001}, "uncertainty.contacts: expected body names among ['palm', 'table', "
                       "'finger'] (the palm, environment surfaces and fingers) or '*', got "
                       "'thumb'"),
    ({"finger": -1}, "uncertainty.contacts.finger: expected a number >= 0, got -1"),
    ("2 mm", "uncertainty.contacts: expected a finite number, got"),
])
def test_section_errors_name_the_field(value, message):
    d = _data(TILT)
    d["uncertainty"] = {"contacts": value}
    with pytest.raises(FileFormatError, match=re.escape(message)):
        hand_file_from_dict(d)


def test_load_set_refuses_a_negative_half_width():
    with pytest.raises(InputError, match=r"contacts: expected a half-width >= 0 \[m\], finite, "
                                         "got -1"):
        _set(-1.0)


# ---- the structure (Lemma 1) ----------------------------------------------------------------
def test_an_offset_moves_one_normal_column_affinely_and_the_jacobian_matches_its_point():
    """Two-finger hand (revolute fingers): ``w_in``'s moment changes by ``-s_i``, ``w_it`` not;
    ``J``'s normal row is affine in ``s_i`` and equals the velocity of the moved finger point
    (finite differences of the link frames), its tangential row does not change."""
    hf = load_hand_file(ROOT / "scenarios" / "data" / "two_finger_hand.json")
    hand, q = hf.hand, hf.q0
    joints = joint_inputs(hand, (1,), [0.02])
    s = np.array([0.0, 0.0, 0.003, -0.002])
    a, b = hand.system(q, 0.0, joints), hand.system(q, 0.0, joints, offsets=s)
    h = hand.system(q, 0.0, joints, offsets=0.5 * s)
    dW = b.W - a.W
    assert np.allclose(dW[2, 0::2], -s, atol=1e-15) and np.allclose(dW[:2], 0, atol=1e-15)
    assert np.allclose(dW[:, 1::2], 0, atol=1e-15)
    assert np.allclose(h.J, 0.5 * (a.J + b.J), atol=1e-15)          # affine in s
    assert np.allclose(b.J[1::2], a.J[1::2], atol=1e-15)            # tangential rows
    assert np.allclose(b.J, finger_point_jacobian(hand, q, b.points, b.normals).reshape(b.J.shape),
                       atol=1e-7)


def test_offset_corners_keep_fixed_contacts_at_zero():
    c = offset_corners([0.0, 0.002, 0.0, 0.001])
    assert c.shape == (4, 4) and np.all(c[:, [0, 2]] == 0)
    assert {tuple(r) for r in c[:, [1, 3]]} == {(-0.002, -0.001), (-0.002, 0.001),
                                                  (0.002, -0.001), (0.002, 0.001)}


# ---- a band derived by hand -----------------------------------------------------------------
@pytest.mark.parametrize("d, mass, cx, mu", [
    (0.001, (0.5, 0.5), (0.0375, 0.0375), 0.8),
    (0.002, (0.5, 0.5), (0.0375, 0.0375), 0.8),
    pytest.param(0.005, (0.5, 0.5), (0.0375, 0.0375), (0.7, 0.8), marks=pytest.mark.long),
    pytest.param(0.002, (0.4, 0.6), (0.0325, 0.0425), (0.7, 0.8), marks=pytest.mark.long),
])
def test_tilting_band_is_the_hand_derived_corner(tilt, d, mass, cx, mu):
    hand, q0, joints = tilt
    h = replace(hand, load_set=_set(d, (), mass, cx))
    box = offset_box(h, q0, joints)
    assert box is not None and len(box.systems) == 8
    g = guarantee(hand.system(q0, 0.0, joints), CLAIM, mu, loads=h.load_vertices(q0), box=box)
    mu_lo = mu if isinstance(mu, float) else mu[0]
    assert len(g.pieces) == 1
    # exact at one friction value; over a shared interval a sliding force-indeterminate rival's
    # union is bounded over the friction box (docs/planning.md, "Contact positions")
    assert g.exact or not isinstance(mu, float)
    assert g.pieces[0].lower == pytest.approx(n_star(mass[1], cx[0], mu_lo, -d, -d), rel=1e-9)
    assert g.pieces[0].upper == np.inf


def test_only_the_moving_contacts_enter(tilt):
    """The tip alone: ``N*(0, -d)``; the breaking vertex 0 alone: the nominal band."""
    hand, q0, joints = tilt
    system = hand.system(q0, 0.0, joints)
    tip = replace(hand, load_set=_set(0.0, (("finger", 0.002),)))
    g = guarantee(system, CLAIM, 0.8, box=offset_box(tip, q0, joints))
    assert g.pieces[0].lower == pytest.approx(n_star(0.5, 0.0375, 0.8, 0.0, -0.002), rel=1e-9)
    nominal = guarantee(system, CLAIM, 0.8).pieces[0].lower
    assert nominal == pytest.approx(n_star(0.5, 0.0375, 0.8, 0.0, 0.0), rel=1e-12)
    assert g.pieces[0].lower > nominal


# ---- dense sampling of the whole set on random hands ----------------------------------------
def _random_case(template: str, seed: int, rel_mass: float, d_com: float, d_pos: float):
    data = random_hand(_data(ROOT / "scenarios" / "data" / template),
                       np.random.default_rng(seed))
    return hand_file_from_dict(with_uncertainty(data, rel_mass, d_com, d_pos))


#: (template, seed, mass +- fraction, centre of mass +- m, contacts +- m): random hands whose
#: band over the whole set is not empty (others are empty or refused at these sizes).
CASES = [("prismatic_finger_hand.json", 3, 0.05, 0.001, 0.0005),
         ("two_finger_hand.json", 3, 0.05, 0.001, 0.0005)]


@pytest.mark.long
@pytest.mark.parametrize("case", CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_dense_samples_confirm_the_band_and_catch_a_widened_one(case):
    template, seed, rel_mass, d_com, d_pos = case
    hf = _random_case(template, seed, rel_mass, d_com, d_pos)
    hand, q, seg = hf.hand, hf.q0, hf.segment
    joints = joint_inputs(hand, tuple(seg.drives), list(seg.speeds))
    system = hand.system(q, 0.0, joints)
    ivs = list(hf.mu_interval)
    common = len(ivs) == 1
    g = guarantee(system, seg.mode, ivs[0] if common else ivs,
                  model="common" if common else "independent",
                  loads=hand.load_vertices(q), box=offset_box(hand, q, joints))
    assert g.pieces, "the case's band is empty: pick another"
    piece = g.best()
    lo = np.array([a for a, _ in ivs] * (hand.n_contacts if common else 1))
    hi = np.array([b for _, b in ivs] * (hand.n_contacts if common else 1))
    rng = np.random.default_rng(seed)
    corners = friction_corners(lo, hi, common)
    vertices = set_vertices(hand)
    inner = set_interior(hand, rng, 40)
    mids = [lo + rng.random(hand.n_contacts) * (hi - lo) for _ in range(2)]
    a, b = piece.lower, piece.upper
    assert np.isfinite(a) and np.isfinite(b)
    taus = [[a + 1e-6 * (b - a)], [0.5 * (a + b)], [b - 1e-6 * (b - a)]]

    def bad(taus, points, mus):
        return set_violations(hand, q, joints, g.claim, taus, points, mus)[1]

    assert bad(taus, vertices, corners) == []
    assert bad(taus, inner, [corners[0], *mids]) == []
    step = 0.01 * max(abs(a), abs(b))
    for widened in (a - step, b + step):
        assert bad([[widened]], vertices, corners), widened
    # the band that ignores the contact positions is wider, and the sampling catches it
    g0 = guarantee(system, seg.mode, ivs[0] if common else ivs,
                   model="common" if common else "independent", loads=hand.load_vertices(q))
    p0 = g0.best()
    outside = [[t] for t in (0.5 * (p0.lower + a), 0.5 * (b + p0.upper)) if not a <= t <= b
               and p0.contains(t)]
    assert outside and bad(outside, vertices, corners)


# ---- defaults ---------------------------------------------------------------------------------
@pytest.mark.parametrize("rel", ["scenarios/data/prismatic_finger_hand.json",
                                 "scenarios/data/table_push_hand.json"])
def test_zero_offsets_reproduce_the_plans(rel):
    data = _data(ROOT / rel)
    plain = plan_hand(ROOT / rel)
    hf = hand_file_from_dict(dict(data, uncertainty={"contacts": 0.0}))
    assert hf.hand.contact_offsets() is None
    a, b = plan_body(plain), plan_body(plan_hand(hf, margins=False))
    for key in ("segments", "reached", "diagnosis", "mu", "policy"):
        assert a[key] == b[key], key


def test_several_effort_joints_are_refused_with_offsets_named():
    """Contact positions are guaranteed with one effort joint: a partition with none says so."""
    hf = load_hand_file(ROOT / "scenarios" / "data" / "table_push_hand.json")
    hand = replace(hf.hand, load_set=LoadSet((hf.hand.mass,) * 2,
                                             ((float(hf.hand.com[0]),) * 2,
                                              (float(hf.hand.com[1]),) * 2),
                                             hf.hand.mass, tuple(float(x) for x in hf.hand.com),
                                             0.001))
    with pytest.raises(DegenerateError, match="contact offsets: guaranteed with one "
                                              "effort-controlled joint, got 0"):
        guaranteed_at(hand, hf.q0, (0,), np.array([0.05]), "3S", (0.3, 0.5), "independent")


# ---- what the commands tolerate -------------------------------------------------------------
def test_command_guaranteed_up_to_the_hand_derived_offset(tilt):
    """A press force ``N`` stays guaranteed while ``N >= N*(-d, -d)``: the largest half-width
    of every contact is ``d* = (N (mu H - w + x_f) - (w - c_x) m g) / (2 N + m g)``."""
    hand, q0, _ = tilt
    N, mu, cx, m = 9.0, 0.8, 0.0375, 0.5
    d_star = (N * (mu * H - W + XF) - (W - cx) * m * G) / (2 * N + m * G)
    assert 0.001 < d_star < 0.02
    for d, expect in ((d_star * (1 - 1e-6), True), (d_star * (1 + 1e-6), False)):
        h = replace(hand, load_set=_set().widened("contacts", d))
        assert command_guaranteed(h, q0, (0,), [0.01], CLAIM, mu, "common", [N]) is expect


def test_tolerance_words_and_dict_carry_the_contact_axis():
    tol = Tolerance(0.1, 0.004, 0.001, 0.0001, 0.0021, 0.0001)
    assert tol.words().endswith("contact positions +-2.1 mm (each axis alone, the others as "
                                "planned)")
    d = tol.to_dict()
    assert d["contacts_m"] == 0.0021 and d["contacts_computed"] is True
    none = Tolerance(0.1, 0.004, 0.001, 0.0001)
    assert none.to_dict()["contacts_computed"] is False and "contact" not in none.words()
    unc = {"set": {"mass": [0.5, 0.5], "com": [[0.03, 0.03], [0.03, 0.03]],
                   "contacts": {"finger": 0.002, "*": 0.001}}, "tolerated": d}
    text = uncertainty_words(unc)
    assert "contact positions finger +-2 mm, other bodies +-1 mm" in text
    assert "centre of mass +-4 mm, contact positions +-2.1 mm (each axis alone" in text


@pytest.mark.long
def test_tolerated_contact_offset_brackets_hold_and_fail():
    """The plan of the tilting block with every contact +-1 mm: the certified contact
    tolerance holds at every waypoint, one resolution further fails."""
    d = _data(TILT)
    d["uncertainty"] = {"contacts": 0.001}
    plan = plan_hand(hand_file_from_dict(d), waypoints=3, margins=False)
    tol = tolerated(plan, steps=5)
    base = plan.segments[0].hand_model[0].load_set
    assert tol.contacts_m is not None and 0.001 <= tol.contacts_m < 0.075
    assert holds(plan, base.widened("contacts", tol.contacts_m))
    assert not holds(plan, base.widened("contacts", tol.contacts_m + tol.contacts_resolution_m))


# ---- two computations of a rival's union agree ------------------------------------------------
@pytest.mark.long
@pytest.mark.parametrize("name, drive, rate, mu", [
    ("block_tilting", (0,), [0.01], [(0.7, 0.8)] * 3),
    ("two_finger_hand", (1,), [0.02], [(0.2, 0.3), (0.25, 0.3), (0.4, 0.5), (0.3, 0.45)]),
])
def test_row_bound_at_vertices_equals_the_lifted_program(name, drive, rate, mu):
    """A determinate mode's possible set over friction box x contact box: the row bound at the
    vertex geometries (Lemma 2) and the one lifted linear program (exact union) -- two
    derivations, one answer."""
    hf = load_hand_file(ROOT / "scenarios" / "data" / f"{name}.json")
    hand, q0 = hf.hand, hf.q0
    joints = joint_inputs(hand, drive, rate)
    box = offset_box(replace(hand, load_set=_set_for(hand, 0.002)), q0, joints)
    system = hand.system(q0, 0.0, joints)
    G = system.g_obj[None]
    bands = load_bands(system, mu, G, model="independent", box=box)
    stage, index = uniform_stages(box.systems)[0]
    lo, hi = friction_interval(mu, hand.n_contacts)
    assert len(index) >= 2
    for k, i in enumerate(index):
        lifted = lifted_interval(box, candidate_arrays(stage, int(i)), lo, hi, G)
        row = bands[k].possible
        assert row.empty == lifted.empty, bands[k].label
        for x, y in ((row.lower, lifted.lower), (row.upper, lifted.upper)):
            assert x == pytest.approx(y, rel=1e-9, abs=1e-12), bands[k].label


def _set_for(hand, d: float) -> LoadSet:
    c = (float(hand.com[0]), float(hand.com[1]))
    return LoadSet((hand.mass, hand.mass), ((c[0], c[0]), (c[1], c[1])), hand.mass, c, d)
