"""Round shapes moved off a polygon edge's line for pymunk (:mod:`sim.backends.pymunk_edges`).

Chipmunk reports a circle whose centre lies exactly on the line of a polygon edge, beyond the
edge's end, as overlapping that edge by its whole radius along the edge's normal; the backend
moves such a shape ``1e-9 x`` the scene's length scale outside the line.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.backends.pymunk_edges import EDGE_LINE_OFFSET, edge_line_offsets, off_line_shift
from sim.scene import Body, BodyKind, Capsule, Circle, ContactPair, Polygon, Scene

BOX = np.array([[0.0, 0.0], [0.4, 0.0], [0.4, 0.2], [0.0, 0.2]])


def test_a_centre_on_a_side_line_below_a_corner_moves_outside() -> None:
    tol = 1e-9
    shift = off_line_shift([np.array([0.0, -0.016])], BOX, tol)
    assert np.allclose(shift, [-tol, 0.0], atol=1e-18)  # out of the left side's line
    assert not np.any(off_line_shift([np.array([0.1, -0.016])], BOX, tol))  # under the edge
    assert not np.any(off_line_shift([np.array([-0.01, -0.016])], BOX, tol))  # clear of it


def test_a_capsule_end_and_a_rotated_body() -> None:
    """A link ending under the corner, on a body turned by 90 deg: the offset is in its frame."""
    link = Body("link", (Capsule((0.0, 0.0), (0.1, 0.0), 0.016),), pose=(0.0, -0.016, np.pi / 2),
                kind=BodyKind.DRIVEN, twist=lambda t, s: (0.0, 0.0, 0.0))
    box = Body("box", (Polygon(tuple(map(tuple, BOX.tolist()))),), mass=1.0)
    scene = Scene(bodies=(box, link), pairs=(ContactPair("c1", "link", "box", 0.5),),
                  length_scale=0.4)
    off = edge_line_offsets(scene)
    d = EDGE_LINE_OFFSET * 0.4
    # world shift (-d, 0) is (0, d) in a frame turned by +90 deg
    assert off[("link", 0)] == pytest.approx((0.0, d), abs=1e-18)
    assert ("box", 0) not in off


def test_shapes_off_every_line_are_left_alone() -> None:
    box = Body("box", (Polygon(tuple(map(tuple, BOX.tolist()))),), mass=1.0)
    tip = Body("tip", (Circle((0.2, -0.016), 0.016),), kind=BodyKind.STATIC)
    scene = Scene(bodies=(box, tip), pairs=(ContactPair("c1", "tip", "box", 0.5),),
                  length_scale=0.4)
    assert edge_line_offsets(scene) == {}
