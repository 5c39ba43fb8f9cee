"""The planner's diagnoses in plain words: contacts named by their features, joints by their
fingers, the workpiece's motion by its direction (docs/planning.md, "Reading a plan").

Every sentence names what the hand file names: workpiece vertices and edges by their index in
``workpiece.vertices`` (edge ``e`` runs from vertex ``e`` to vertex ``e + 1``), fingers by their
``name``, surfaces by theirs.  Directions are in the world frame (``x`` right, ``y`` up,
counter-clockwise positive, docs/conventions.md).
"""

from __future__ import annotations

import math

import numpy as np

from planner.model.hand import ContactSpec, Hand
from planner.model.kinematics import REVOLUTE


def finger_words(hand: Hand, k: int) -> str:
    """``"the left finger"`` (a finger's ``name`` that says ``finger`` is used as it is)."""
    name = hand.fingers[k].name
    return name if "finger" in name.lower() else f"the {name} finger"


def finger_link(hand: Hand, j: int) -> tuple[int, int]:
    """``(finger, link)`` of joint ``j`` (counting every finger's joints in order)."""
    start = 0
    for k, f in enumerate(hand.fingers):
        if j < start + f.n_joints:
            return k, j - start
        start += f.n_joints
    raise IndexError(f"joint {j}: expected an index below {start}")


def joint_words(hand: Hand, j: int) -> str:
    """Joint ``j`` (counting every finger's joints in order): ``"the right finger"`` for a
    single-link finger, ``"joint 1 of the right finger"`` in a chain."""
    k, link = finger_link(hand, j)
    return (finger_words(hand, k) if hand.fingers[k].n_joints == 1
            else f"joint {link} of {finger_words(hand, k)}")


def drive_words(hand: Hand, j: int, rate: float) -> str:
    """``"the right finger turning counter-clockwise at 0.02 rad/s"`` (revolute) or
    ``"joint 1 of the right finger extending at 0.01 m/s"`` (prismatic)."""
    k, link = finger_link(hand, j)
    kind = hand.fingers[k].chain_links[link].kind
    if kind == REVOLUTE:
        how = "counter-clockwise" if rate > 0 else "clockwise"
        return f"{joint_words(hand, j)} turning {how} at {abs(rate):.3g} rad/s"
    how = "extending" if rate > 0 else "retracting"
    return f"{joint_words(hand, j)} {how} at {abs(rate):.3g} m/s"


def effort_unit(hand: Hand, joints: tuple[int, ...]) -> str:
    """Unit of the efforts of ``joints``: ``"N m"`` (revolute), ``"N"`` (prismatic), ``""``
    when they differ or there are none (a margin is then in mixed units or a slack)."""
    kinds = {hand.fingers[k].chain_links[link].kind for k, link in
             (finger_link(hand, j) for j in joints)}
    if len(kinds) != 1:
        return ""
    return "N m" if kinds.pop() == REVOLUTE else "N"


def contact_words(hand: Hand, c: ContactSpec) -> str:
    """A contact by its features: ``"vertex 3 on the left finger"``, ``"vertex 0 on the
    palm"``, ``"vertex 2 on the table"``, ``"the right finger's tip on edge 1"``, ``"vertex 4
    on link 1 of the right finger"``."""
    if c.kind == "palm":
        return f"vertex {c.vertex} on the palm"
    if c.kind == "surface":
        return f"vertex {c.vertex} on the {hand.environment[c.surface][0]}"
    f = finger_words(hand, c.finger)
    if c.kind == "side":
        link = f"link {c.link} of " if hand.fingers[c.finger].n_joints > 1 else ""
        return f"vertex {c.vertex} on {link}{f}"
    return f"{_possessive(f)} tip on edge {c.edge}"


def contact_label(hand: Hand, i: int) -> str:
    """``"contact 3 (vertex 3 on the left finger)"``: the number every output uses, with its
    features."""
    return f"contact {i + 1} ({contact_words(hand, hand.contacts[i])})"


def meets_words(hand: Hand, c: ContactSpec) -> str:
    """A new contact: ``"vertex 4 meets the left finger"``, ``"the left finger's tip meets
    edge 3"``."""
    if c.kind == "tip":
        return f"{_possessive(finger_words(hand, c.finger))} tip meets edge {c.edge}"
    return contact_words(hand, c).replace(" on ", " meets ", 1)


def clearance_words(hand: Hand, name: str, q: np.ndarray) -> str:
    """A new contact named by :meth:`planner.model.hand.Hand.clearances` (``"vertex 4 -
    left"``, ``"left tip - workpiece"``) in plain words, at configuration ``q``: ``"vertex 4
    meets the left finger"``, ``"the left finger's tip meets vertex 3"`` (the tip's nearest
    workpiece feature)."""
    for k, f in enumerate(hand.fingers):
        if name == f"{f.name} tip - workpiece":
            return f"{_possessive(finger_words(hand, k))} tip meets {_nearest_feature(hand, q, k)}"
    head, _, where = name.partition(" - ")
    fixed = {"palm": "the palm", **{e[0]: f"the {e[0]}" for e in hand.environment}}
    if where in fixed:
        return f"{head} meets {fixed[where]}"
    for k, f in enumerate(hand.fingers):
        if where == f.name:
            return f"{head} meets {finger_words(hand, k)}"
        for j in range(f.n_joints):
            if where == f"{f.name} link {j}":
                return f"{head} meets link {j} of {finger_words(hand, k)}"
    return f"{name} touches"


def _nearest_feature(hand: Hand, q: np.ndarray, k: int) -> str:
    """The workpiece edge or vertex nearest finger ``k``'s tip at ``q``."""
    tip = hand.tip_centre(q, k)
    V = hand.world_vertices(q)
    best = (math.inf, "")
    for e in range(len(V)):
        a, b = V[e], V[(e + 1) % len(V)]
        s = float(np.clip((tip - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0))
        d = float(np.linalg.norm(tip - (a + s * (b - a))))
        what = (f"vertex {e}" if s <= 1e-6 else f"vertex {(e + 1) % len(V)}" if s >= 1 - 1e-6
                else f"edge {e}")
        best = min(best, (d, what))
    return best[1]


def runs_off_words(hand: Hand, i: int, s: float) -> str:
    """Contact ``i`` leaves its feature (``s`` its position along it, outside ``[0, 1]``):
    ``"vertex 3 runs off the end of the left finger"``, ``"the right finger's tip runs off
    edge 1 past vertex 2"``."""
    c = hand.contacts[i]
    if c.kind == "tip":
        n_v = len(hand.vertices)
        past = c.edge if s < 0 else (c.edge + 1) % n_v
        return (f"{_possessive(finger_words(hand, c.finger))} tip runs off edge {c.edge} past "
                f"vertex {past}")
    words = contact_words(hand, c)
    vertex, feature = words.split(" on ", 1)
    if c.kind == "side":
        end = "its tip end" if s > 1 else "its base end"
        return f"{vertex} runs off {feature} at {end}"
    return f"{vertex} runs off the end of {feature}"


def motion_words(start: np.ndarray, end: np.ndarray, length_scale: float) -> str:
    """Which way the workpiece moves from pose ``start`` to ``end`` ``(x, y, phi)``:
    ``"moves 1.60 mm left, turning 0.30 deg clockwise"`` (mm below 1 m, else m; below 1e-6 of
    ``length_scale`` ``"stays in place"``, or ``"turns 11.5 deg counter-clockwise about its frame
    origin"`` when it turns: the frame origin is the turning point the user chose)."""
    d = np.asarray(end[:2], dtype=float) - np.asarray(start[:2], dtype=float)
    turn = math.degrees(math.remainder(float(end[2]) - float(start[2]), 2 * math.pi))
    dist = float(np.linalg.norm(d))
    rot = ("without turning" if abs(turn) < 1e-3 else
           f"turning {abs(turn):.3g} deg {'counter-clockwise' if turn > 0 else 'clockwise'}")
    if dist <= 1e-6 * length_scale:
        return ("stays in place" if rot == "without turning" else
                f"turns {rot.removeprefix('turning ')} about its frame origin")
    size = f"{1e3 * dist:.3g} mm" if dist < 1.0 else f"{dist:.3g} m"
    sectors = ("right", "up and to the right", "up", "up and to the left", "left",
               "down and to the left", "down", "down and to the right")
    sector = sectors[int(round(math.atan2(d[1], d[0]) / (math.pi / 4))) % 8]
    return f"moves {size} {sector}, {rot}"


def token_change_words(before: str, after: str) -> str:
    """What a contact does when its mode token changes (``S+`` -> ``R``: ``"stops sliding"``)."""
    a, b = before[0], after[0]
    if b == "B":
        return "lifts off"
    if a == "S" and b == "R":
        return "stops sliding"
    if a == "R" and b == "S":
        return "starts sliding"
    if a == "S" and b == "S":
        return "reverses its sliding direction"
    if a == "B":
        return "closes"
    return f"changes from {before} to {after}"


def mode_change_words(hand: Hand, label: str, labels: list[str]) -> str:
    """Why mode ``label`` ends, given the modes ``labels`` admissible just past its end: the
    contacts that change in the nearest one (``"contact 5 (the top finger's tip on edge 2)
    stops sliding (next admissible mode: S+1 S+2 S-3 S-4 R5)"``), or a sentence saying that no
    other mode is admissible."""
    labels = [lab for lab in labels if lab != label]
    if not labels:
        return "no other mode of these contacts is kinematically admissible there"
    own = _tokens(label)
    best = min(labels, key=lambda lab: sum(a != b for a, b in zip(own, _tokens(lab))))
    new = _tokens(best)
    changed = [f"{contact_label(hand, i)} {token_change_words(a, b)}"
               for i, (a, b) in enumerate(zip(own, new)) if a != b]
    return f"{' and '.join(changed) or 'the motion'} (next admissible mode: {best})"


def _tokens(label: str) -> list[str]:
    """Per-contact tokens of a mode label without their indices (``S`` without a sign: a
    contact on the boundary between sliding directions)."""
    return [t.rstrip("0123456789") for t in label.split()]


def _possessive(name: str) -> str:
    return f"{name}'" if name.endswith("s") else f"{name}'s"
