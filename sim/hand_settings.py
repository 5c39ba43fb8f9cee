"""Engine settings and drive speed of hand runs (:mod:`sim.hand_run`, :mod:`sim.region_run`).

One :class:`sim.backends.EngineSettings` per engine, measured on the two-finger hand
(docs/simulation.md, "Two-finger hand"), and the two rules that carry them to other hands:
MuJoCo's masses scaled with the contact force per size (:func:`hand_engine_settings`,
:func:`effort_force`) and the
classifier's drive speed from the velocity-controlled joints' contact-point speeds
(:func:`contact_drive_speed`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from planner.errors import InputError
from planner.model.hand import Hand
from sim.backends import EngineSettings, check_engine

#: Hand-scene settings per engine (docs/simulation.md, "Two-finger hand").
ENGINE_SETTINGS: dict[str, EngineSettings] = {
    "pymunk": EngineSettings(dt=1e-3),
    "mujoco": EngineSettings(dt=1e-3, mass_scale=0.1, solref=(0.01, 1.0), creep=1e-8,
                             settle=0.3, z_stiffness=1000.0),
}


#: Load acceleration per size [1/s^2], ``|load force| / (workpiece mass x length scale)``, of
#: the scene the MuJoCo hand settings were measured on (the two-finger hand of Sec. 5.2:
#: 0.08 N on 0.1 kg, 86.8 mm; docs/simulation.md, "Two-finger hand").
MUJOCO_REFERENCE_LOAD_PER_SIZE = 0.08 / (0.1 * 0.0868)


def hand_engine_settings(hand: Hand, engine: str, force: float = 0.0) -> EngineSettings:
    """:data:`ENGINE_SETTINGS` of ``engine`` for ``hand``. MuJoCo's soft contacts sink in
    by about ``(contact force / mass) x solref time constant^2``: a hand whose contact forces
    accelerate its workpiece more per unit size than the reference
    (:data:`MUJOCO_REFERENCE_LOAD_PER_SIZE`; a block under gravity on a table) gets its masses
    scaled up by that ratio, so its contacts sink in the same fraction of its size (masses
    change only the dynamics: the loads and efforts are explicit forces). The force is the
    larger of the load and ``force`` [N] (the contact force the effort-controlled joints
    exert, :func:`effort_force`; a squeeze can exceed the load many times: measured in
    docs/simulation.md, "Chain manipulators"). Hands at or below the reference keep the
    settings."""
    es = ENGINE_SETTINGS[check_engine(engine)]
    if engine != "mujoco":
        return es
    f = max(float(np.linalg.norm(hand.load_force)), float(force))
    per_size = f / (hand.mass * hand.length_scale)
    ratio = per_size / MUJOCO_REFERENCE_LOAD_PER_SIZE
    return replace(es, mass_scale=es.mass_scale * ratio) if ratio > 1.0 else es


def effort_force(hand: Hand, q0: np.ndarray, controls: Sequence[str],
                 commands: np.ndarray) -> float:
    """Contact normal force [N] the effort-controlled joints exert, estimated from eq. 3
    without friction: joint ``j``'s effort ``tau_j = sum_i J_i,nj c_in`` carried by its
    contact with the longest normal lever ``max_i |J_i,nj(q0)|`` (the normal row of
    :meth:`planner.model.hand.Hand.jacobian`; m for a revolute joint, 1 for a prismatic one),
    so ``c_n = |tau_j| / max_i |J_i,nj|``; the largest over the effort joints and the
    waypoints' ``commands`` ``(n, n_theta)`` (N m or N). 0 without effort joints or when an
    effort joint's contacts all have zero normal lever (it presses on nothing)."""
    E = [j for j, c in enumerate(controls) if c == "effort"]
    if not E:
        return 0.0
    lever = np.max(np.abs(hand.jacobian(q0)[:, 0, E]), axis=0)  # (|E|,)
    tau = np.max(np.abs(np.asarray(commands, dtype=float)[:, E]), axis=0)  # (|E|,)
    ok = lever > 0
    return float(np.max(tau[ok] / lever[ok])) if np.any(ok) else 0.0


def contact_drive_speed(hand: Hand, q0: np.ndarray, controls: Sequence[str],
                        commands: np.ndarray) -> float:
    """Drive speed [m/s] of a run (classifier thresholds, SIM-NOTES): the fastest manipulator
    contact-point velocity the velocity-controlled joints give at ``q0``, ``max_k max_i
    |J_i(q0)[:, V] thetadot_V,k|`` over the waypoints' commands ``(n, n_theta)`` (eqs. 3, 5);
    for a single revolute driving finger this is its contact radius times its fastest rate.
    A driving joint that touches nothing: its links' length times its rate."""
    V = [j for j, c in enumerate(controls) if c == "velocity"]
    if not V:
        raise InputError("controls: expected at least one velocity-controlled joint, got none")
    J = hand.jacobian(q0)[:, :, V]  # (n_c, 2, |V|)
    rates = np.asarray(commands, dtype=float)[:, V]  # (n, |V|)
    speed = float(np.max(np.linalg.norm(np.einsum("cij,kj->kci", J, rates), axis=2)))
    if speed > 0:
        return speed
    reach = [sum(lk.length for lk in f.chain_links) for f in hand.fingers
             for _ in range(f.n_joints)]
    return float(max(np.max(np.abs(rates[:, i])) * reach[j] for i, j in enumerate(V)))
