"""Own side-push hand files for tests, written from docs/file-formats.md, and the band of
vertical efforts at which the grip sticks, derived by hand (tests/planner/test_side_push.py's
docstring)."""

from __future__ import annotations

import math


def band_by_hand(weight: float, mu_table: float, mu_hand: float) -> tuple[float, float]:
    """The vertical efforts at which both hand contacts stick (module docstring)."""
    m = mu_table * mu_hand
    return -m * weight / (1.0 + m), m * weight / (1.0 - m)


def side_push(a: float, weight: float, mu_table: float, mu_hand: float, *,
              mirrored: bool = False, goal: float = 0.03) -> dict:
    """A hand file written from docs/file-formats.md: an ``a`` m cube of ``weight`` N on a
    table, a gantry finger's vertical pusher (width 4 mm, its tip 2 mm below the table line)
    flat against its left face (``mirrored``: its right face), both face vertices on it; the
    goal ``goal`` m further in the push's direction with every contact kept."""
    w, reach = 0.004, 0.03
    length = a + 0.0165
    if mirrored:
        pivot, side, face = [a + w / 2 - reach, length - 0.002], -1, (1, 2)
    else:
        pivot, side, face = [-w / 2 - reach, length - 0.002], 1, (0, 3)
    contacts = [{"kind": "surface", "vertex": 0, "surface": "table"},
                {"kind": "surface", "vertex": 1, "surface": "table"}] + [
        {"kind": "side", "vertex": v, "finger": 0, "link": 1, "side": side} for v in face]
    return {
        "format": "qsplan-hand", "version": 1, "name": "own side push",
        "palm": {"edge": [[-0.3, 0.3], [-0.3, -0.01]]},
        "environment": [{"name": "table", "edge": [[-0.2, 0.0], [0.4, 0.0]]}],
        "fingers": [{"name": "pusher", "pivot": pivot, "links": [
            {"type": "prismatic", "length": reach, "width": w, "offset": 0.0, "position": 0.0},
            {"type": "prismatic", "length": length, "width": w, "offset": -math.pi / 2,
             "position": 0.0}]}],
        "workpiece": {"vertices": [[0, 0], [a, 0], [a, a], [0, a]], "com": [a / 2, a / 2],
                      "mass": weight / 9.81, "pose": [0, 0, 0]},
        "contacts": contacts,
        "load": {"force": [0.0, -weight]},
        "segment": {"drive": 0, "speed": 0.01, "max_time": 10.0, "steps": 50,
                    "mode": f"S{'+' if mirrored else '-'}1 S{'+' if mirrored else '-'}2 R3 R4"},
        "mu": {"bodies": {"table": [mu_table, mu_table], "pusher": [mu_hand, mu_hand]}},
        "goal": {"pose": [-goal if mirrored else goal, 0.0, 0.0],
                 "tolerance": {"position": 0.001, "angle": 0.02},
                 "contacts": contacts, "max_segments": 2},
    }
