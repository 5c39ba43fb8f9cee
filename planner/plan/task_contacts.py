"""Contact sets of a whole task: which feature pairs touch, and how an event changes the set.

A task (:mod:`planner.plan.task`) is a chain of segments; each keeps one contact set (the hand's
``contacts``, :class:`planner.model.hand.ContactSpec`) closed.  At a segment's end the set changes
with the event (:mod:`planner.plan.trajectory`):

* ``new contact``: every feature pair now touching (``|gap| <= tol`` and the contact point on
  its feature, ``0 <= s <= 1``) joins the set -- edge-to-edge contact arrives as a second
  vertex on the same link side, i.e. two contacts;
* ``lost contact``: the contact whose point ran off its feature leaves; pairs that touch there
  (e.g. a finger's rounded tip on the workpiece edge whose vertex just left the link side) join;
* ``mode change`` / ``time limit`` / ``goal``: the set is kept.

The next segment may release contacts (their mode is ``B``: they open) so that the set it
keeps closed has ``3 + n_theta - (driven joints)`` contacts, what the trajectory's closure
(:meth:`planner.model.hand.Hand.close`) needs.  Everything here uses the hand's public geometry
(:meth:`Hand.contact_frame`); lengths in m.
"""

from __future__ import annotations

import itertools
from dataclasses import replace
from typing import Any

import numpy as np

from planner.model.hand import ContactSpec, Hand


def with_contacts(hand: Hand, contacts: tuple[ContactSpec, ...]) -> Hand:
    """The same hand with another contact set."""
    return replace(hand, contacts=tuple(contacts))


def candidate_pairs(hand: Hand) -> list[ContactSpec]:
    """Every feature pair a hand can touch with: workpiece vertices on the palm, on each
    environment surface, on both sides of every link; every finger tip on every workpiece
    edge."""
    n_v = len(hand.vertices)
    out: list[ContactSpec] = []
    for v in range(n_v):
        out.append(ContactSpec("palm", vertex=v))
        out.extend(ContactSpec("surface", vertex=v, surface=e)
                   for e in range(len(hand.environment)))
        for k, f in enumerate(hand.fingers):
            for j in range(f.n_joints):
                out.extend(ContactSpec("side", vertex=v, finger=k, side=sd, link=j)
                           for sd in (1, -1))
    for k in range(hand.n_fingers):
        out.extend(ContactSpec("tip", edge=e, finger=k) for e in range(n_v))
    return out


def touching(hand: Hand, q: np.ndarray, tol: float | None = None) -> list[ContactSpec]:
    """Feature pairs touching at ``q``: ``|gap| <= tol`` (default ``1e-6`` of the workpiece
    size) with the contact point on its feature (``0 <= s <= 1``)."""
    tol = 1e-6 * hand.length_scale if tol is None else tol
    out = []
    for spec in candidate_pairs(hand):
        _, _, gap, s = with_contacts(hand, (spec,)).contact_frame(q, 0)
        if abs(gap) <= tol and -1e-9 <= s <= 1.0 + 1e-9:
            out.append(spec)
    return out


def after_event(hand: Hand, q: np.ndarray, kind: str) -> tuple[ContactSpec, ...]:
    """The contact set after a segment of ``hand`` ended at ``q`` with event ``kind`` (module
    docstring); contacts keep their order, new ones are appended."""
    contacts = list(hand.contacts)
    if kind == "lost contact" and contacts:
        _, _, s = hand.contact_geometry(q)
        off = int(np.argmin(np.minimum(s, 1.0 - s)))
        del contacts[off]
    if kind in ("new contact", "lost contact"):
        kept = set(contacts) | set(hand.contacts)
        contacts += [c for c in touching(hand, q) if c not in kept]
    return tuple(contacts)


def releases(n_contacts: int, n_keep: int) -> list[tuple[int, ...]]:
    """Every choice of contacts to release (indices) so that ``n_keep`` stay closed; empty when
    there are fewer than ``n_keep``."""
    if n_keep > n_contacts or n_keep < 1:
        return []
    return list(itertools.combinations(range(n_contacts), n_contacts - n_keep))


def contact_dict(hand: Hand, c: ContactSpec) -> dict[str, Any]:
    """A contact as a hand file's contact object (docs/two-finger-task.md)."""
    if c.kind == "palm":
        return {"kind": "palm", "vertex": c.vertex}
    if c.kind == "surface":
        return {"kind": "surface", "vertex": c.vertex, "surface": hand.environment[c.surface][0]}
    if c.kind == "side":
        d: dict[str, Any] = {"kind": "side", "vertex": c.vertex, "finger": c.finger,
                             "side": c.side}
        if hand.fingers[c.finger].n_joints > 1:
            d["link"] = c.link
        return d
    return {"kind": "tip", "edge": c.edge, "finger": c.finger}
