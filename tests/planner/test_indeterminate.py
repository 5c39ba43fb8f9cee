"""Relaxed utility (end of Sec. 3.2): statically indeterminate modes such as 2R."""

from __future__ import annotations

import numpy as np
import pytest
from certify import check_certificate

from planner import Status, System, feasible_modes


def carried_block(mu, drag=0.1, speed=0.1):
    """A block on a platform that translates in +x (one velocity-controlled prismatic joint).

    Both support contacts are on the same rigid platform, so the two-rolling mode (the block is
    carried) has four kinematic constraints for three unknowns: its contact forces are
    statically indeterminate.  ``drag`` is a support-friction load opposing the motion.
    """
    return System.from_contacts(
        points=[[-1.0, 0.0], [1.0, 0.0]], normals=[[0.0, 1.0], [0.0, 1.0]], mu=mu,
        external_wrench=[-drag, -1.0, 0.0],
        jacobian=[[[0.0], [-1.0]], [[0.0], [-1.0]]],  # platform x-velocity in (n, t) frames
        joints=[{"velocity": speed}],
    )


@pytest.mark.parametrize("mu", [0.1, 0.2, 0.8])
def test_carried_block_is_force_indeterminate_2r(mu):
    s = carried_block(mu)
    pred = feasible_modes(s)
    assert pred.status is Status.UNIQUE
    assert not pred.modes and len(pred.indeterminate_modes) == 1
    fm = pred.indeterminate_modes[0]
    assert fm.label == "R1 R2" and fm.force_indeterminate and fm.mode.family == "2R"
    np.testing.assert_allclose(fm.qdot, [0.1, 0.0, 0.0], atol=1e-12)
    check_certificate(s, fm)
    assert fm.on_boundary == (mu == 0.1)


def test_carried_block_slips_below_drag_ratio():
    pred = feasible_modes(carried_block(0.05))
    assert pred.status is Status.JAMMED  # 2S has rank W_A = 2 (condition 30): not a mode
    # one contact rolling forces the other to roll too: sliding there is a kinematic boundary
    # case (xi = 0, written "S" without a sign), but at mu = 0.05 no forces carry the drag 0.1
    # (at most 0.05 of friction): not a boundary-tolerance mode either
    assert pred.boundary_modes == ()
    # at mu = 0.2 the zero-speed slider's friction (force-tested towards +t: c_t = -mu c_n,
    # i.e. +mu c_n along world x on the block) and the roller carry the drag: both are listed
    assert sorted(m.label for m in feasible_modes(carried_block(0.2)).boundary_modes) == [
        "R1 S2", "S1 R2"]


def test_indeterminate_search_can_be_disabled():
    pred = feasible_modes(carried_block(0.5), indeterminate=False)
    assert pred.status is Status.JAMMED and not pred.indeterminate_modes
