"""Negative controls of plans: commands the planner itself predicts to fail.

:func:`outside_torques`: torque vectors outside every waypoint's guaranteed region of a
planned segment (:class:`planner.plan.model.Segment`, any hand), where the planner predicts a
mode other than the claim at the given friction -- a simulator run of them must disagree with the
plan. (The reversed-torque control of a whole
task is :func:`planner.plan.model.negative_control`.)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand


def outside_torques(plan: Any, hand: Hand, mu: float | Sequence[float] | np.ndarray,
                    *, reach: float = 3.0) -> np.ndarray:
    """(n_waypoints, p) torque vectors outside every waypoint's region for a negative control.

    From each waypoint's region's Chebyshev centre ``c`` (radius ``r``; whatever command the
    plan's policy chose there, so the control does not depend on the policy) along the outward
    normal ``a`` of a facet of ``A tau <= b`` (nearest facet first):
    ``c + (slack + k max(r, |c|)) a`` for ``k = reach, 3 reach``, the first point where the
    planner's own prediction (:func:`planner.predict.feasibility.feasible_modes`) at ``mu``
    does not contain the claim (a rival instead). Raises :class:`InputError` for a plan without
    effort joints or a waypoint where no such point is found."""
    from planner.plan.partition import joint_inputs
    from planner.predict.feasibility import feasible_modes

    E = list(plan.effort_joints)
    if not E:
        raise InputError("outside_torques: expected a plan with effort-controlled joints, got "
                         "none (a velocity-only plan has no torque to move outside)")
    out = []
    if len(plan.regions) != len(plan.waypoints):
        raise InputError(f"outside_torques: expected a planned segment with one guaranteed region "
                         f"per waypoint, got {len(plan.regions)} for {len(plan.waypoints)}")
    for w, reg in zip(plan.waypoints, plan.regions):
        c = np.asarray(reg.centre, dtype=float).reshape(len(E))
        r = float(reg.margin)
        if not (np.all(np.isfinite(c)) and np.isfinite(r)):  # no centre: the command itself
            c, r = np.asarray(w.torque_commands, dtype=float), float(w.margin)
        A, b = np.asarray(reg.A, dtype=float), np.asarray(reg.b, dtype=float)
        norms = np.linalg.norm(A, axis=1)
        slack = (b - A @ c) / np.where(norms > 0, norms, np.inf)
        system = hand.system(w.q, mu, joint_inputs(hand, plan.velocity_joints,
                                                   w.velocity_commands))
        inputs = np.array(system.joint_inputs)
        size = max(r, float(np.linalg.norm(c)))
        found = None
        for i in np.argsort(slack):  # nearest facet first, then further ones
            if not np.isfinite(slack[i]):
                continue
            for k in (reach, 3.0 * reach):
                tau = c + (slack[i] + k * size) * A[i] / norms[i]
                inputs[E] = tau
                if plan.claim not in feasible_modes(system.with_joint_inputs(inputs)).labels:
                    found = tau
                    break
            if found is not None:
                break
        if found is None:
            raise InputError(f"outside_torques: no torque past a facet of the region at t = "
                             f"{w.t:.3g} s rules out {plan.claim} at mu = {mu}")
        out.append(found)
    return np.array(out)
