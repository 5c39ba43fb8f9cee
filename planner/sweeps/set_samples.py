"""Points of a hand's whole uncertainty set and the full mode enumeration there: the independent
check of a band guaranteed over friction, mass, centre of mass and contact positions
(docs/planning.md, "Uncertainty beyond friction", "Contact positions").

A point of the set is ``(m, c, s)``: the workpiece's mass ``m`` [kg], its centre of mass ``c``
(body frame) [m] and the offsets ``s (n_c,)`` [m] of the contacts along their features
(:class:`planner.model.load_set.LoadSet`, :meth:`planner.model.hand.Hand.contact_offsets`).
:func:`sampled_system` builds the system at one point *without the planner's offset formulas*:
the contact points moved along ``t_i = rot90(n_i)``, the normals kept, the load ``f0 m / m0`` at
the moved centre of mass (eq. 2), and the finger Jacobian (eqs. 3, 5) by central differences of
the link frames (:meth:`planner.model.hand.Hand.links_at`) at the moved points -- not the chain's
point Jacobian.  :func:`set_violations` then runs :func:`planner.predict.feasibility.feasible_modes`
(the full enumeration, eqs. 13-32) at every point, friction and effort and returns the samples
where the claimed mode is not the only feasible one.

:func:`with_uncertainty` adds the section to a hand-file dict; :func:`set_vertices` and
:func:`set_interior` list points of the set; :func:`friction_corners` the friction box's corners.

Units: kg, m, N, N m (efforts in the joints' units).
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from planner.model.geometry import rot90
from planner.model.hand import Hand
from planner.model.hand_parts import rotation
from planner.model.system import System
from planner.plan.bounds import box_points
from planner.predict.feasibility import feasible_modes

#: central-difference step of the finger Jacobian [rad or m]
FD_STEP = 1e-7


class SetPoint(NamedTuple):
    """One point of the set: mass [kg], centre of mass (body frame) [m], contact offsets
    ``(n_c,)`` [m]."""

    mass: float
    com: tuple[float, float]
    offsets: tuple[float, ...]


class SetViolation(NamedTuple):
    """A sample where the claimed mode is not the only feasible one: the point, the friction
    ``(n_c,)``, the efforts ``(|E|,)`` and the modes ``feasible_modes`` found."""

    point: SetPoint
    mu: tuple[float, ...]
    tau: tuple[float, ...]
    labels: tuple[str, ...]


def with_uncertainty(data: dict[str, Any], mass: float, com: float,
                     contacts: float = 0.0) -> dict[str, Any]:
    """A copy of the hand-file dict ``data`` with an ``uncertainty`` section: mass
    ``m0 (1 +- mass)`` (a fraction), centre of mass ``c0 +- com`` [m] in both body coordinates
    and, when ``contacts > 0``, every contact ``+- contacts`` [m] along its feature
    (docs/file-formats.md, hand file; ``m0``, ``c0``: the file's ``workpiece.mass`` and
    ``workpiece.com``, defaults 0.1 kg and the origin)."""
    d = copy.deepcopy(data)
    wp = d["workpiece"]
    m, (cx, cy) = wp.get("mass", 0.1), wp.get("com", [0.0, 0.0])
    d["uncertainty"] = {"mass": [m * (1 - mass), m * (1 + mass)],
                        "com": [[cx - com, cx + com], [cy - com, cy + com]]}
    if contacts > 0:
        d["uncertainty"]["contacts"] = contacts
    return d


def _half_widths(hand: Hand) -> np.ndarray:
    half = hand.contact_offsets()
    return np.zeros(hand.n_contacts) if half is None else np.asarray(half, dtype=float)


def _nominal(hand: Hand) -> tuple[tuple[float, float], tuple[tuple[float, float], ...]]:
    ls = hand.load_set
    if ls is None:
        m, c = float(hand.mass), (float(hand.com[0]), float(hand.com[1]))
        return (m, m), ((c[0], c[0]), (c[1], c[1]))
    return ls.mass, ls.com


def set_vertices(hand: Hand) -> list[SetPoint]:
    """Every vertex of mass interval x centre-of-mass box x offset box (an axis of zero width
    counted once): at most ``8 * 2^m`` points, ``m`` the contacts that may move."""
    mass, com = _nominal(hand)
    half = _half_widths(hand)
    ends = [sorted({-h, h}) for h in half]
    return [SetPoint(float(m), (float(x), float(y)), tuple(float(v) for v in s))
            for m in sorted(set(mass)) for x in sorted(set(com[0])) for y in sorted(set(com[1]))
            for s in itertools.product(*ends)]


def set_interior(hand: Hand, rng: np.random.Generator, n: int) -> list[SetPoint]:
    """``n`` points drawn uniformly in the set's box (mass, centre of mass, offsets)."""
    mass, com = _nominal(hand)
    half = _half_widths(hand)
    return [SetPoint(float(rng.uniform(*mass)),
                     (float(rng.uniform(*com[0])), float(rng.uniform(*com[1]))),
                     tuple(float(v) for v in rng.uniform(-half, half)))
            for _ in range(n)]


def friction_corners(lo: Any, hi: Any, common: bool) -> np.ndarray:
    """``(k, n_c)`` the friction box's corners; with one shared coefficient (``common``) its
    two ends on the diagonal."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if common:
        return np.array([np.full(len(lo), lo[0]), np.full(len(lo), hi[0])])
    return box_points(lo, hi, 2)[0]


def finger_point_jacobian(hand: Hand, q: Any, points: np.ndarray,
                          normals: np.ndarray) -> np.ndarray:
    """``(n_c, 2, n_theta)``: the velocity of the finger body point at ``points[i]`` (world,
    [m]) per joint rate by central differences (:data:`FD_STEP`) of the link frames
    (:meth:`Hand.links_at`), in the contact frame ``(n_i, rot90(n_i))`` -- independent of the
    chain's point Jacobian and of the planner's offset geometry.  Palm and surface rows are
    zero."""
    J = np.zeros((hand.n_contacts, 2, hand.n_joints))
    for i, c in enumerate(hand.contacts):
        if c.kind in ("palm", "surface"):
            continue
        body = c.link if c.kind == "side" else hand.fingers[c.finger].n_joints - 1
        st, d = hand.links_at(q, c.finger)[body]
        a, b = (points[i] - st) @ d, (points[i] - st) @ rot90(d)
        for j in range(hand.n_joints):
            ends = []
            for sgn in (1.0, -1.0):
                qq = np.array(q, dtype=float)
                qq[3 + j] += sgn * FD_STEP
                s2, d2 = hand.links_at(qq, c.finger)[body]
                ends.append(s2 + a * d2 + b * rot90(d2))
            v = (ends[0] - ends[1]) / (2 * FD_STEP)
            J[i, 0, j], J[i, 1, j] = normals[i] @ v, rot90(normals[i]) @ v
    return J


def sampled_system(hand: Hand, q: Any, point: SetPoint, joints: Sequence[Any]) -> System:
    """The system (eqs. 1-5) of ``hand`` at configuration ``q`` and one point of the set, built
    from the moved contact points directly (module docstring); ``joints`` as in
    :meth:`Hand.system`."""
    pts, nrm, _ = hand.contact_geometry(q)
    s = np.asarray(point.offsets, dtype=float)
    pts = pts + s[:, None] * np.array([rot90(n) for n in nrm])
    f = hand.load_force * point.mass / hand.mass
    r = rotation(q[2]) @ np.asarray(point.com, dtype=float) + np.asarray(q[:2], dtype=float)
    g = np.array([f[0], f[1], r[0] * f[1] - r[1] * f[0]])
    return System.from_contacts(points=pts, normals=nrm, mu=0.0, external_wrench=g,
                                jacobian=finger_point_jacobian(hand, q, pts, nrm),
                                joints=list(joints))


def set_violations(hand: Hand, q: Any, joints: Sequence[Any], claim: str,
                   taus: Sequence[Any], points: Sequence[SetPoint],
                   mus: Sequence[Any] | Any, *, first: bool = False) -> tuple[int,
                                                                            list[SetViolation]]:
    """``(samples, violations)``: every effort of ``taus`` (each ``(|E|,)``, the
    effort-controlled joints of ``joints`` in order) at every point of ``points`` and friction
    of ``mus`` (``(k, n_c)``, or a callable ``point -> (k, n_c)``) through the full mode
    enumeration at the point's system (:func:`sampled_system`); a violation is a sample where
    the feasible modes are not exactly ``[claim]``.  ``first``: stop at the first violation."""
    bad: list[SetViolation] = []
    samples = 0
    for point in points:
        system = sampled_system(hand, q, point, joints)
        E = list(system.effort_joints)
        for mu in (mus(point) if callable(mus) else mus):
            for tau in taus:
                inputs = np.array(system.joint_inputs, dtype=float)
                inputs[E] = np.asarray(tau, dtype=float)
                labels = feasible_modes(system.with_joint_inputs(inputs), mu).labels
                samples += 1
                if labels != [claim]:
                    bad.append(SetViolation(point, tuple(float(x) for x in mu),
                                            tuple(float(x) for x in np.atleast_1d(tau)),
                                            tuple(labels)))
                    if first:
                        return samples, bad
    return samples, bad
