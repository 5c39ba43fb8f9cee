"""Own hands with sticking contacts, written from the docs and checked against statics by hand
(docs/planning.md, "Own sticking hands").

``tests/data/own_pivot_left.json``: a flat 0.12 x 0.04 m box of 0.2 kg pivoted counter-clockwise
about its bottom-LEFT corner (vertex 0) by a point finger on its top face 0.01 m right of that
corner, dragged to the left (box_pivot_up mirrored, at another size), friction per body: table
[0.5, 0.8], finger [0.6, 1.0].  ``tests/data/own_tilt_small.json``: a 0.02 m cube of 0.02 kg tilted
counter-clockwise about its bottom-left edge by a finger at 0.3 of the edge from the pivot
(block tilting mirrored at a quarter of the size), one coefficient in [0.7, 0.9] for both.

By hand (forces on the workpiece, world frame, pivot ``P`` = vertex 0, finger force
``F = (F_x, -tau)`` with ``tau`` the gantry's downward effort, ``c`` the finger's contact point,
``g`` the centre of mass, ``m g`` the weight): moments about the pivot,
``(c - P) x F - m g (g - P)_x = 0``, give ``F_x = -((c - P)_x tau + m g (g - P)_x) / (c - P)_y``;
the pivot sticks iff ``|F_x| <= mu_table (tau + m g)``; the finger sticks iff its tangential
force ``T = F . t`` is within ``mu_finger`` times its normal force ``N = -F . n`` (``n``, ``t`` the
top face's outward normal and tangent).  Each is affine in ``tau``, so the efforts that hold the
mode form an interval.  At the start (the face level, the contact ``a`` right of the pivot on a
face of height ``h``) this is ``tau >= m g g_x / (h mu_f - a)`` and
``(m g g_x + a tau) / h <= mu_t (tau + m g)``: both contacts need friction above ``a / h``.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from planner.files.hand_file import load_hand_file
from planner.plan.hand_planner import plan_hand
from planner.plan.task_contacts import with_contacts
from planner.predict.feasibility import feasible_modes

DATA = Path(__file__).resolve().parents[1] / "data"
#: name -> (contact's distance from the pivot a, face height h, centre of mass (x, y), weight)
HANDS = {"own_pivot_left": (0.01, 0.04, (0.06, 0.02), 0.2 * 9.81),
         "own_tilt_small": (0.006, 0.02, (0.01, 0.01), 0.02 * 9.81)}
#: The gantry finger's tip radius (half its link width): the sticking (``R``) tip rolls on the
#: turning face, so its contact point is the tip centre minus ``R_TIP`` times the face's normal.
R_TIP = 0.002


def _effort_interval(hf, q, mu_table, mu_finger):
    """The downward efforts at configuration ``q`` for which the pivot and the finger stick (the
    statics of the module docstring; ``[lo, hi]``, ``hi`` inf when unbounded)."""
    x, y, phi, j0, j1 = q
    s, c = math.sin(phi), math.cos(phi)
    pivot_px, pivot_py = hf.data["fingers"][0]["pivot"]
    tip = np.array([pivot_px + 0.03 + j0, pivot_py - 0.05 - j1])  # joint 1 moves the tip along -y
    n = np.array([-s, c])  # the top face's outward normal; its tangent t = (c, s)
    cp = tip - R_TIP * n - np.array([x, y])  # contact point from the pivot (vertex 0 at the origin)
    _, _, (gx, gy), mg = HANDS[hf.data["name"]]
    g_arm = gx * c - gy * s
    # F_x = kx tau + k0; F = (F_x, -tau); every condition below is  alpha tau <= beta
    kx, k0 = -cp[0] / cp[1], -mg * g_arm / cp[1]
    N = (kx * s + c, k0 * s)         # N = F_x s + tau c
    T = (kx * c - s, k0 * c)         # T = F_x c - tau s
    rows = [(kx - mu_table, mu_table * mg - k0), (-kx - mu_table, mu_table * mg + k0),
            (T[0] - mu_finger * N[0], mu_finger * N[1] - T[1]),
            (-T[0] - mu_finger * N[0], mu_finger * N[1] + T[1]), (-1.0, 0.0)]
    lo, hi = -math.inf, math.inf
    for alpha, beta in rows:
        if alpha > 0:
            hi = min(hi, beta / alpha)
        elif alpha < 0:
            lo = max(lo, beta / alpha)
        else:
            assert beta >= 0
    return lo, hi


def _worst_corner(name):
    """(mu_table, mu_finger) where the efforts' set is smallest: both lower ends."""
    return (0.5, 0.6) if name == "own_pivot_left" else (0.7, 0.7)


def _segment_hand(hf):
    """The start's hand with vertex 1 released (the segment keeps vertex 0 and the tip)."""
    return with_contacts(hf.hand, (hf.hand.contacts[0], hf.hand.contacts[2]))


def _labels(hand, q, rate, tau, mu):
    system = hand.system(q, 0.0, [{"velocity": rate}, {"effort": float(tau)}])
    return feasible_modes(system, np.asarray(mu, dtype=float)).labels


@pytest.mark.parametrize("name,onset", [
    # m g g_x / (h mu_f - a): 0.2 * 9.81 * 0.06 / (0.04 * 0.6 - 0.01) and the table's
    # (2.943 + 0.25 tau) <= 0.5 (tau + 1.962), tau >= 7.85 N, weaker
    ("own_pivot_left", 0.2 * 9.81 * 0.06 / (0.04 * 0.6 - 0.01)),
    # 0.02 * 9.81 * 0.01 / (0.02 * 0.7 - 0.006) = 0.245 N; the table holds for every tau >= 0
    ("own_tilt_small", 0.02 * 9.81 * 0.01 / (0.02 * 0.7 - 0.006))])
def test_the_onset_effort_and_the_least_friction_by_hand(name, onset):
    """At the start the planner's mode enumeration admits ``R1 R2`` alone exactly above the
    hand-derived effort at the friction box's worst corner, and with friction below ``a / h``
    (0.25, 0.3) at either contact no effort tilts the workpiece with both contacts stuck."""
    hf = load_hand_file(DATA / f"{name}.json")
    a, h = HANDS[name][:2]
    lo, hi = _effort_interval(hf, hf.q0, *_worst_corner(name))
    assert lo == pytest.approx(onset, rel=1e-12) and hi == math.inf
    hand, rate = _segment_hand(hf), hf.segment.speeds[0]
    mu = _worst_corner(name)
    assert _labels(hand, hf.q0, rate, onset * 1.001, mu) == ["R1 R2"]
    assert "R1 R2" not in _labels(hand, hf.q0, rate, onset * 0.999, mu)
    for tau in (onset, 10 * onset, 1000 * onset):  # friction just below a / h: no effort works
        assert "R1 R2" not in _labels(hand, hf.q0, rate, tau, (0.9, a / h - 0.01))
        assert "R1 R2" not in _labels(hand, hf.q0, rate, tau, (a / h - 0.01, 0.9))
    assert _labels(hand, hf.q0, rate, 1000 * onset, (a / h + 0.01,) * 2) == ["R1 R2"]


@functools.cache
def _plan(name):
    return plan_hand(DATA / f"{name}.json")


@pytest.mark.long
@pytest.mark.parametrize("name", sorted(HANDS))
def test_planned_to_the_goal_with_the_bands_derived_by_hand(name):
    """One ``R1 R2`` segment to the goal: the pivot stays put, the box turns counter-clockwise
    by the goal's angle, each waypoint's band is the efforts that hold the mode at both ends of
    its hold interval (the hand-derived interval at the worst friction corner), and the commands'
    largest change between waypoints is the one the plan reports, within its stated bound."""
    plan = _plan(name)
    hf = load_hand_file(DATA / f"{name}.json")
    assert plan.reached and [s.claim for s in plan.segments] == ["R1 R2"]
    seg = plan.segments[0]
    assert seg.control == ("velocity", "effort")
    q = np.array([w.q for w in seg.waypoints])
    assert np.max(np.abs(q[:, :2])) < 1e-9  # vertex 0, the body origin, sticks in place
    assert np.all(np.diff(q[:, 2]) > 0)  # counter-clockwise all the way
    goal = hf.data["goal"]  # 30 and 32 degrees counter-clockwise, to 0.02 rad
    assert q[-1, 2] >= goal["pose"][2] - goal["tolerance"]["angle"] - 1e-9
    corner = _worst_corner(name)
    ends = [_effort_interval(hf, qk, *corner) for qk in q]
    for k, w in enumerate(seg.waypoints):
        (lo, hi), = w.bands
        want = max(ends[k][0], ends[min(k + 1, len(ends) - 1)][0])
        assert lo == pytest.approx(want, rel=1e-6), (k, w.t)
        assert hi is None or hi == math.inf
        assert lo < w.torque_commands[0]
    taus = seg.torques()[:, 0]
    change = float(np.max(np.abs(np.diff(taus))))
    report = seg.extra["commands"]
    assert report["policy"] == "smooth" and report["within_bound"]
    assert report["largest_change"] == pytest.approx(change, rel=1e-9, abs=1e-15)
    assert report["bound"] == 0.0 and change <= 1e-6 * float(np.max(np.abs(taus)))


def _frictions(name, seg, rng):
    """Dense samples of the plan's friction set: the box's corners, a grid and uniform draws
    (per contact for per-body intervals, one shared coefficient for a common interval)."""
    (lo1, hi1), (lo2, hi2) = seg.mu_intervals
    if name == "own_tilt_small":
        m = np.concatenate([np.linspace(lo1, hi1, 9), rng.uniform(lo1, hi1, 6)])
        return np.stack([m, m], axis=1)
    g1, g2 = np.meshgrid(np.linspace(lo1, hi1, 5), np.linspace(lo2, hi2, 5))
    return np.concatenate([np.stack([g1.ravel(), g2.ravel()], axis=1),
                           rng.uniform((lo1, lo2), (hi1, hi2), size=(8, 2))])


@pytest.mark.long
@pytest.mark.parametrize("name", sorted(HANDS))
def test_bands_hold_under_dense_friction_sampling_and_a_widened_band_is_caught(name):
    """Independent of the planner's band rows: at efforts inside each checked waypoint's band
    (just above its lower end, the command, far above) and at both ends of its hold interval,
    the full mode enumeration finds ``R1 R2`` alone at every friction sample (0 violations).
    The band widened by 1 % (its lower end lowered by 1 % of itself) is caught at every checked
    waypoint: some sample then admits another mode or none."""
    seg = _plan(name).segments[0]
    hand = seg.hand_model[0]
    rng = np.random.default_rng(0)
    ws = seg.waypoints
    checked = list(range(0, len(ws) - 1, max(1, len(ws) // 6))) + [len(ws) - 1]
    violations, samples, caught = [], 0, 0
    for k in checked:
        w = ws[k]
        ends = [w.q, ws[min(k + 1, len(ws) - 1)].q]
        lo = w.bands[0][0]
        mus = _frictions(name, seg, rng)
        rate = w.velocity_commands[0]
        for q in ends:
            for tau in (lo * (1 + 1e-6), w.torque_commands[0], 3 * lo):
                for mu in mus:
                    labels = _labels(hand, q, rate, tau, mu)
                    samples += 1
                    if labels != ["R1 R2"]:
                        violations.append((k, tau, tuple(mu), labels))
        wide = 0.99 * lo
        caught += any(_labels(hand, q, rate, wide, mu) != ["R1 R2"] for q in ends for mu in mus)
    assert samples >= 2 * 3 * 15 * len(checked)
    assert violations == []
    assert caught == len(checked)


@pytest.mark.parametrize("name,lo,hi,contact", [
    ("own_pivot_left", (0.5, 0.2), (0.8, 1.0), "contact 2 (finger's tip on edge 2)"),
    ("own_pivot_left", (0.2, 0.6), (0.8, 1.0), "contact 1 (vertex 0 on the table)")])
def test_the_remedy_names_the_least_friction_by_hand(name, lo, hi, contact):
    """A friction box reaching below ``a / h`` = 0.25 at one contact guarantees nothing at the
    start; the diagnosis names that contact and the friction it needs, ``a / h`` (the moments
    of the module docstring with the squeeze growing without bound)."""
    from planner.plan.segment_planner import remedies

    hf = load_hand_file(DATA / f"{name}.json")
    a, h = HANDS[name][:2]
    out = remedies(_segment_hand(hf), hf.q0, (0,), np.array([hf.segment.speeds[0]]), "R1 R2",
                   np.array(lo), np.array(hi), "independent")
    named = [r for r in out if r.startswith(contact)]
    assert len(named) == 1, out
    need = float(named[0].split("at least ")[1].split(" ")[0])
    assert a / h <= need <= a / h + 0.005
