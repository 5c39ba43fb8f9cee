"""A hand file's contacts checked against its geometry, as a system file's contacts are
(:mod:`planner.model.features`): the two features of every contact touch at the start
configuration, the contact lies on both features, and its normal points into the workpiece.

A hand contact is a pair of features (``docs/two-finger-task.md``): a workpiece vertex on the
palm, on a fixed surface or on a finger's side, or a fingertip on a workpiece edge.  Its point
and normal follow from them (:meth:`planner.model.hand.Hand.contact_frame`): the surface's
normal, ``side * rot90`` of the finger link's axis, or the edge's inward normal.  Three checks,
each an :class:`planner.errors.InputError` naming the contact by its features (the words of the
planner's diagnoses, :func:`planner.plan.wording.contact_label`), the distance or angle, and the
fix (docs/conventions.md, "Geometry of contacts"):

1. **Touching at the start.** At the written configuration (``workpiece.pose`` and the fingers'
   angles or positions) every contact's signed gap is within :data:`START_GAP` times the
   workpiece's size.  The loader re-closes the configuration (Gauss-Newton,
   :meth:`planner.model.hand.Hand.close`), so written coordinates may be rounded; a gap or an
   overlap of a quarter of the workpiece's size ``L`` is no rounding but a wrong pose, angle or
   feature index: it is below the edge length ``L sin(pi / n)`` of a regular polygon of up to
   12 edges (``0.26 L`` at 12), the step a neighbouring vertex or edge index makes, and far
   above what rounded angles leave (the shipped files: at most ``0.1 L``, a finger angle written
   0.15 rad off).
2. **On both features.** At the closed configuration the contact point lies on the palm or
   surface segment, along the finger link, or on the workpiece edge: its fraction along the
   feature is in ``[0, 1]`` to :data:`GEOMETRY_TOL`.
3. **Normal into the workpiece.** At the closed configuration a vertex contact's normal lies in
   the polygon's inward normal cone at that vertex (between the inward normals of its two
   edges) to :data:`GEOMETRY_TOL` rad: otherwise the surface or finger cuts into the workpiece
   (a reversed surface edge, a finger ``side`` of the wrong sign).  A tip contact's normal is its
   edge's inward normal by construction; the tip must lie on the edge's outer side (check 1).
"""

from __future__ import annotations

import math

import numpy as np

from planner.errors import DegenerateError, InputError
from planner.model.features import GEOMETRY_TOL, Feature, cone_angle, fmt_vec
from planner.model.hand import ContactSpec, Hand
from planner.plan.wording import contact_label, finger_words

#: Largest signed gap (or overlap) of a contact at the written start configuration, as a
#: fraction of the workpiece's size (:attr:`planner.model.hand.Hand.length_scale`).
START_GAP = 0.25

__all__ = ["START_GAP", "check_hand_contacts"]


def check_hand_contacts(hand: Hand, q_start: np.ndarray) -> None:
    """Check every contact of ``hand`` at the written start configuration ``q_start
    (3 + n_joints,)`` (m, rad; before closing) and at its closed configuration (module
    docstring).  Raises :class:`InputError`; returns None when every contact is consistent.
    A configuration that cannot be closed is left to the loader's own message."""
    size = hand.length_scale
    for i in range(hand.n_contacts):
        gap = hand.contact_frame(q_start, i)[2]
        if abs(gap) > START_GAP * size:
            what = f"a gap of {gap:.3g} m" if gap > 0 else f"an overlap of {-gap:.3g} m"
            raise InputError(
                f"{contact_label(hand, i)}: expected its features to touch at the start "
                f"configuration (workpiece.pose and the fingers' angles or positions, re-closed "
                f"on load), got {what}, more than {START_GAP:g} of the workpiece's size "
                f"{size:.3g} m; move the pose or the finger to where the features touch, or "
                f"name the features that do ({_index_hint(hand.contacts[i])})"
            )
    try:
        q = hand.close(q_start, fixed=hand.default_fixed(q_start))
    except (DegenerateError, InputError):
        return
    V = hand.world_vertices(q)
    for i, c in enumerate(hand.contacts):
        _check_span(hand, q, i)
        if c.kind == "tip":
            continue
        n = hand.contact_frame(q, i)[1]
        angle, nearest = cone_angle(n, V, Feature("vertex", c.vertex, 0.0, V[c.vertex]))
        if angle > GEOMETRY_TOL:
            raise InputError(
                f"{contact_label(hand, i)}: expected the contact normal to point into the "
                f"workpiece, got {fmt_vec(n)}, {math.degrees(angle):.3g} deg outside the "
                f"inward normals at vertex {c.vertex} (nearest {fmt_vec(nearest)}): "
                f"{_cuts_into(hand, c)} cuts into the workpiece there; "
                + _normal_fix(hand, c, -n, V)
            )


def _check_span(hand: Hand, q: np.ndarray, i: int) -> None:
    """Check 2: the contact point within its features (fraction along them in [0, 1])."""
    c = hand.contacts[i]
    s = hand.contact_frame(q, i)[3]
    if -GEOMETRY_TOL <= s <= 1.0 + GEOMETRY_TOL:
        return
    if c.kind in ("palm", "surface"):
        (a, b), _ = hand.surface(c)
        length = float(np.linalg.norm(b - a))
        where = "the palm's edge" if c.kind == "palm" else (
            f"the {hand.environment[c.surface][0]}'s edge")
        fix = "extend the edge's two points or move the workpiece's pose"
    elif c.kind == "side":
        length = hand.fingers[c.finger].chain_links[c.link].length
        where = f"{finger_words(hand, c.finger)}'s link {c.link}"
        fix = "move the finger or the workpiece, or put the vertex on another finger"
    else:
        a, b = hand.edge(q, c.edge)
        length = float(np.linalg.norm(b - a))
        where = f"edge {c.edge}"
        fix = "put the tip on the edge it reaches, or move the finger"
    beyond = (-s if s < 0 else s - 1.0) * length
    raise InputError(
        f"{contact_label(hand, i)}: expected the contact point on {where} (fraction 0..1 "
        f"along it), got {s:.3g}, {beyond:.3g} m beyond its end at the start configuration; "
        f"{fix}"
    )


def _cuts_into(hand: Hand, c: ContactSpec) -> str:
    if c.kind == "palm":
        return "the palm"
    if c.kind == "surface":
        return f"the {hand.environment[c.surface][0]}"
    return finger_words(hand, c.finger)


def _normal_fix(hand: Hand, c: ContactSpec, flipped: np.ndarray, V: np.ndarray) -> str:
    """The fix of a normal outside the cone: the other side of a finger or surface when that
    normal fits, else another vertex."""
    fits = cone_angle(flipped, V, Feature("vertex", c.vertex, 0.0, V[c.vertex]))[0] <= GEOMETRY_TOL
    if c.kind == "side" and fits:
        return f"use \"side\": {-c.side} (the other face of the finger)"
    if c.kind == "surface" and fits:
        return ("give the surface's edge points in the other order (its inward normal is "
                "rot90 of first -> second)")
    return ("put on it a vertex the workpiece lies behind (one whose two edges both leave it on "
            "the inward side), or turn the workpiece's pose")


def _index_hint(c: ContactSpec) -> str:
    if c.kind == "tip":
        return f"\"edge\": {c.edge}, \"finger\": {c.finger}"
    return f"\"vertex\": {c.vertex}"
