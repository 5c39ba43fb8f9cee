"""Closed torque intervals (Figures 10-13): a mode's torque set at fixed friction is one interval
(eq. 28 is affine in the one effort-controlled torque), and a guarantee is a set of disjoint ones.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Interval:
    """A closed torque interval ``[lower, upper]`` (N m); empty when ``lower > upper``."""

    lower: float
    upper: float

    @property
    def empty(self) -> bool:
        return not self.lower <= self.upper

    def contains(self, tau: float) -> bool:
        return self.lower <= tau <= self.upper

    def margin(self, tau: float) -> float:
        """Distance from ``tau`` to the nearest bound (negative outside)."""
        return float(min(tau - self.lower, self.upper - tau))

    def to_list(self) -> list[float | None]:
        return [finite_or_none(self.lower), finite_or_none(self.upper)]


EMPTY = Interval(np.inf, -np.inf)


def finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None



def hull(intervals: Sequence[Interval]) -> Interval:
    """The smallest interval holding every non-empty one of ``intervals`` (EMPTY if none)."""
    got = [iv for iv in intervals if not iv.empty]
    return Interval(min(iv.lower for iv in got), max(iv.upper for iv in got)) if got else EMPTY


def subtract(band: Interval, rivals: list[Interval]) -> list[Interval]:
    """``band`` minus the union of closed ``rivals`` (the rivals' boundaries are excluded, so the
    pieces are returned closed but callers keep a margin from them)."""
    pieces = [] if band.empty else [band]
    for r in rivals:
        if r.empty:
            continue
        nxt = []
        for p in pieces:
            if r.upper < p.lower or r.lower > p.upper:
                nxt.append(p)
                continue
            if r.lower > p.lower:
                nxt.append(Interval(p.lower, r.lower))
            if r.upper < p.upper:
                nxt.append(Interval(r.upper, p.upper))
        pieces = nxt
    return pieces
