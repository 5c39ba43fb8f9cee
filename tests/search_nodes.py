"""Helpers for tests of the exact search's nodes (tests/planner/test_search.py,
tests/planner/test_native_search.py)."""

from __future__ import annotations

from planner.model.modes import ROLL, SLIDE
from planner.predict.search import CONTACT, FREE


def mode_in_subtree(states, xi, mode) -> bool:
    """Whether the feasible ``mode`` lies in the subtree of the node ``states``/``xi``."""
    for st, x, code, mx in zip(states, xi, mode.codes, mode.xi):
        if st == FREE:
            continue
        if st == CONTACT:
            if code not in (ROLL, SLIDE):
                return False
        elif st != code or (st == SLIDE and x != mx):
            return False
    return True
