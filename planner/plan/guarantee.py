"""Guarantees (Section 5.2, Figures 11-13): the torques that make one mode the only possible one
for every friction value in a box, i.e. its guaranteed band minus the union of every rival's band.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.system import System
from planner.plan.bounds import ModeBand, mode_bands
from planner.plan.intervals import EMPTY, Interval, subtract
from planner.plan.load_bounds import load_bands
from planner.plan.offset_bounds import OffsetBox
from planner.predict.stages import DEFAULT_TOL


@dataclass(frozen=True)
class Guarantee:
    """Torque set that guarantees ``claim`` and excludes every rival (eq. 28 over the friction
    interval).  ``pieces``: disjoint intervals, ascending; ``bands``: every admissible mode's
    :class:`ModeBand`; ``rivals``: labels of the modes that can occur for some ``tau``."""

    claim: str
    pieces: tuple[Interval, ...]
    bands: tuple[ModeBand, ...]
    exact: bool

    @property
    def claim_band(self) -> ModeBand | None:
        return next((b for b in self.bands if b.label == self.claim), None)

    @property
    def rivals(self) -> tuple[str, ...]:
        return tuple(b.label for b in self.bands if b.label != self.claim and not b.possible.empty)

    def best(self) -> Interval:
        """The widest piece (infinite pieces first); EMPTY when none."""
        if not self.pieces:
            return EMPTY
        return max(self.pieces, key=lambda p: (p.upper - p.lower, -abs(p.lower)))

    def rivals_at(self, tau: float) -> tuple[str, ...]:
        return tuple(b.label for b in self.bands
                     if b.label != self.claim and b.possible.contains(tau))


def guarantee(
    system: System, claim: str, mu: Any, *, model: str = "common", tol: float = DEFAULT_TOL,
    loads: Any = None, box: OffsetBox | None = None,
) -> Guarantee:
    """Torques that make ``claim`` (a mode label, or a family such as ``"4S"``) the only
    possible mode for every friction in ``mu`` (Section 5.2, Figures 11-13) and, with
    ``loads (K, n_q)``, every external wrench in their convex hull (the workpiece's uncertain
    mass and centre of mass: :func:`planner.plan.load_bounds.load_bands`); with ``box`` (a box
    of contact offsets), every contact position in it too (:mod:`planner.plan.offset_bounds`)."""
    if box is not None:
        G = np.asarray(system.g_obj, dtype=float)[None] if loads is None else loads
        bands = load_bands(system, mu, G, model=model, tol=tol, box=box)
    elif loads is None:
        bands = mode_bands(system, mu, model=model, tol=tol)
    else:
        bands = load_bands(system, mu, loads, model=model, tol=tol)
    label = resolve_claim(claim, [b.label for b in bands], [b.mode.family for b in bands])
    own = next((b for b in bands if b.label == label), None)
    if own is None:
        return Guarantee(claim, (), bands, all(b.exact for b in bands))
    rivals = [b.possible for b in bands if b.label != label]
    pieces = subtract(own.guaranteed, rivals)
    return Guarantee(label, tuple(pieces), bands, all(b.exact for b in bands))


def resolve_claim(claim: str, labels: list[str], families: list[str]) -> str:
    """A full mode label, or a family (``"4S"``) that names exactly one admissible mode."""
    if claim in labels:
        return claim
    hits = [lab for lab, fam in zip(labels, families) if fam == claim]
    if len(hits) == 1:
        return hits[0]
    if not hits:
        return claim  # not admissible here: the caller sees an empty guarantee
    raise InputError(f"claim {claim!r}: expected one mode, got several admissible: {hits}")
