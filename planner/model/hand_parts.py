"""Parts of a hand (:mod:`planner.model.hand`): links, fingers, contact feature pairs, distances.

A finger is a planar serial chain of revolute and prismatic joints based at its pivot, each
joint moving one capsule link (Trinkle & Zeng 1994, eqs. 3, 5: the chain's point Jacobians give
the contact Jacobians).  Units: m, kg, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.model.kinematics import PRISMATIC, REVOLUTE, Chain, JointSpec

CONTACT_KINDS = ("palm", "surface", "side", "tip")
JOINT_KINDS = (REVOLUTE, PRISMATIC)


def rotation(phi: float) -> np.ndarray:
    """(2, 2) rotation matrix by ``phi`` [rad], counter-clockwise."""
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class Link:
    """One link of a finger: joint ``kind`` (``"revolute"`` or ``"prismatic"``), capsule
    ``length`` and ``width`` (m, radius ``width/2``), fixed ``offset`` (rad) of the joint's
    direction from the previous link's axis (first link: from world ``+x``), ``mass`` (kg)."""

    kind: str
    length: float
    width: float
    offset: float = 0.0
    mass: float = 0.05
    name: str = ""

    @property
    def radius(self) -> float:
        return 0.5 * self.width


@dataclass(frozen=True)
class Finger:
    """One finger with its chain based at ``pivot`` (world, m).  ``links`` empty: the paper's
    single revolute link of ``length`` and ``width`` (m, tip radius ``width/2``) and ``mass``
    (kg, simulators only); otherwise ``links`` from the pivot out and ``length``, ``width``,
    ``mass`` describe the first link.  ``tip_offset`` ``(along, across)`` [m]: the rounded
    tip's centre moved from its last link's end in that link's frame (``along`` its axis,
    ``across`` to its left, ``rot90`` of the axis); default ``(0, 0)``, the tip at the end.  The
    joints and the links' capsules do not move: the tip is its own shape (a finger that touches
    the workpiece elsewhere than where its kinematics ends; docs/planning.md, "Validating at
    points of the set")."""

    name: str
    pivot: tuple[float, float]
    length: float
    width: float
    mass: float = 0.05
    links: tuple[Link, ...] = ()
    tip_offset: tuple[float, float] = (0.0, 0.0)

    @property
    def radius(self) -> float:
        return 0.5 * self.width

    @property
    def chain_links(self) -> tuple[Link, ...]:
        """The links of the chain (a single revolute link when ``links`` is empty)."""
        if self.links:
            return self.links
        one = self.__dict__.get("_one_link")  # built once: the fields are frozen
        if one is None:
            one = (Link(REVOLUTE, self.length, self.width, 0.0, self.mass),)
            object.__setattr__(self, "_one_link", one)
        return one

    @property
    def n_joints(self) -> int:
        return len(self.chain_links)

    @property
    def tip_radius(self) -> float:
        return self.chain_links[-1].radius

    def chain(self) -> Chain:
        """The finger as a :class:`planner.model.kinematics.Chain` (base at ``pivot``): joint
        ``j`` sits at the end of link ``j - 1`` (origin ``(length_{j-1}, 0)`` in its frame).
        Built and checked once per finger (its fields are frozen)."""
        built = self.__dict__.get("_chain")
        if built is not None:
            return built
        specs = []
        prev = 0.0
        for j, link in enumerate(self.chain_links):
            specs.append(JointSpec(kind=link.kind, parent=j - 1, origin=(prev, 0.0),
                                   angle=link.offset, name=link.name))
            prev = link.length
        built = Chain(tuple(specs), (self.pivot[0], self.pivot[1], 0.0))
        object.__setattr__(self, "_chain", built)
        return built


@dataclass(frozen=True)
class ContactSpec:
    """One contact's feature pair.  ``kind`` in :data:`CONTACT_KINDS`; ``vertex`` (palm,
    surface, side) or ``edge`` (tip) indexes the workpiece polygon; ``finger`` indexes the
    fingers (side, tip) and ``link`` the finger's links (side); ``side`` is +1/-1 for ``side``
    contacts; ``surface`` indexes :attr:`Hand.environment` (surface contacts)."""

    kind: str
    vertex: int = -1
    edge: int = -1
    finger: int = -1
    side: int = 1
    link: int = 0
    surface: int = -1


def capsule_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, r: float) -> float:
    """Signed distance (m) of point ``p`` to the capsule of segment ``a``-``b``, radius ``r``."""
    ab = b - a
    t = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab))) - r


def polygon_distance(p: np.ndarray, V: np.ndarray) -> float:
    """Signed distance of ``p`` to a convex counter-clockwise polygon (negative inside)."""
    n = len(V)
    inside = True
    best = np.inf
    for i in range(n):
        a, b = V[i], V[(i + 1) % n]
        ab = b - a
        if (ab[0] * (p - a)[1] - ab[1] * (p - a)[0]) < 0:
            inside = False
        t = float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
        best = min(best, float(np.linalg.norm(p - (a + t * ab))))
    return -best if inside else best
