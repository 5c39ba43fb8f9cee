"""Simulator backends behind the :class:`sim.scene.Backend` protocol, their one settings type and
their one factory.

:mod:`sim.backends.pymunk_engine` (Chipmunk2D) and :mod:`sim.backends.mujoco_engine` are imported
lazily, so importing :mod:`sim` costs neither engine.
"""

from __future__ import annotations

from dataclasses import dataclass

from planner.errors import InputError
from sim.scene import Backend

#: MuJoCo solimp ``(d0, dwidth, width [m], midpoint, power)`` of every contact pair with a
#: static body (a resting support: a table, a palm). The stiff default impedance (0.99-0.999)
#: made a box pushed along a table stick and jump; 0.9 slides it at the drive speed
#: (docs/simulation.md, "MuJoCo: resting supports").
SUPPORT_SOLIMP = (0.9, 0.9, 0.001, 0.5, 2.0)

#: MuJoCo solref ``(time constant [s], damping ratio)`` of every ``carry`` pair
#: (:mod:`sim.backends.roles`: a driven manipulator moving along the contact tangent under a
#: load, the ruler's fingers): 10 time steps of 1 ms. With the stiff default (4 steps) a sliding,
#: load-carrying contact lifts off and bounces for seconds after every velocity change, and the
#: sticking contact slips during the bounces (docs/simulation.md, "MuJoCo: contact roles").
CARRY_SOLREF = (0.01, 1.0)

#: MuJoCo ``impratio`` of a scene whose pairs are all ``carry`` or ``support`` (no ``squeeze``):
#: with 1, a sliding contact at kinetic friction >= 0.6 that carries more than half the load
#: climbs out of its penetration until it bounces (docs/simulation.md). It is a model-wide
#: option: with a prescribed squeeze it changed the mode MuJoCo picks where two are feasible
#: (Example 4.3 at mu = .05 .15 .85), so such scenes keep 1.
CARRY_IMPRATIO = 10.0

#: MuJoCo solref and impratio of every ``support`` pair in system scenes
#: (:data:`sim.system_run.SYSTEM_SETTINGS`; ``EngineSettings.support_solref`` /
#: ``support_impratio``): the ``carry`` pairs' values (:data:`CARRY_SOLREF`,
#: :data:`CARRY_IMPRATIO`), for the same physics -- a contact that slides while it carries the
#: load. With the defaults (solref 0.004 s, impratio 1) a box pushed along a table at friction
#: >= 0.45 stick-slips and rocks in MuJoCo (docs/simulation.md, "MuJoCo: sliding supports").
#: The impratio is model-wide and set only in scenes with a support pair (the paper examples,
#: squeezed without one, keep 1).
SUPPORT_SOLREF, SUPPORT_IMPRATIO = CARRY_SOLREF, CARRY_IMPRATIO

#: MuJoCo solimp ``d0`` (the impedance at zero penetration) of every ``squeeze`` pair when
#: ``EngineSettings.squeeze_d0`` is set (off by default); the impedance rises to the stiff
#: default's 0.99 over the *load width*
#: (:func:`sim.backends.mujoco_squeeze.load_width`: the penetration at which the contact would
#: carry the scene's load at ``d0``). MuJoCo's elliptic cone pushes a sliding contact apart by
#: ``friction B_t |v_t|`` [m/s^2] (``B_t`` its friction rows' damping): it stays closed only
#: while the lift ratio ``rho = friction B_t |v_t| / ((1 + mu^2) f_n R_n)`` is below 1, and
#: ``R_n = (1 - imp) / imp x diagA``. At the stiff 0.99 a finger that slides under 13 % of the
#: load has ``rho`` 2-8 and chatters; at 0.9 ``R_n`` is 11 x larger and ``rho`` < 1, while
#: contacts pressed deeper than the load width (squeezes of many times the load) stay as stiff
#: as before (docs/simulation.md, "MuJoCo: the sliding lift-off"). The value is the support
#: pairs' (:data:`SUPPORT_SOLIMP`), measured there. The default of system scenes
#: (:data:`sim.system_run.SYSTEM_SETTINGS`), not of the registered scenarios and hands: a jam,
#: a velocity-step start and the hand plans change (measured in the same section).
SQUEEZE_D0 = 0.9

#: MuJoCo solref of every ``squeeze`` pair that gets :data:`SQUEEZE_D0`: the same stiffness as the
#: default ``(0.004, 1)`` (``K = 1 / (d_width timeconst dampratio)^2``) with twice its damping
#: (``B = 2 / (d_width timeconst)``), 0.002 s being MuJoCo's smallest time constant at the 1 ms
#: step (``2 dt``, "refsafe"). The soft impedance takes away the velocity term that damped the
#: three-finger pinch of Example 4.1 in 3S (a lightly loaded slider at lift ratio ~0.9 carries
#: its normal force mostly by it): without more damping the pinch flickers
#: (docs/simulation.md, "MuJoCo: the sliding lift-off").
SQUEEZE_SOLREF = (0.002, 2.0)

#: MuJoCo: mass of a driven body (and armature of a velocity-controlled joint, per length scale
#: squared) over the heaviest dynamic body's, the default of ``EngineSettings.heavy_ratio``. The
#: scenes measured before system scenes existed (the paper examples, the ruler, the hands) keep
#: 1e6; system scenes use :data:`SYSTEM_HEAVY_RATIO`.
HEAVY_RATIO = 1e6
#: MuJoCo driven-body mass ratio of system scenes (:mod:`sim.system_run`). The driven body's share
#: of a contact's inverse effective mass is ``1 / ratio`` (1e-4 here, far below every comparison
#: tolerance). The upper side: MuJoCo's solver scales its stopping tests (improvement, gradient
#: and line-search tolerance) by ``1 / (stat.meaninertia nv)``, and the mean diagonal inertia is
#: the driven bodies', so the tests loosen in proportion to the ratio for the workpiece's
#: degrees of freedom. At 1e6 the forces of lightly loaded contacts were off the certificate by
#: 10-30 % of the force scale (docs/simulation.md, "MuJoCo: the driven bodies' mass").
SYSTEM_HEAVY_RATIO = 1e4
#: Every engine :func:`make_backend` knows, in the order reports list them.
ENGINES = ("pymunk", "mujoco")


@dataclass(frozen=True)
class EngineSettings:
    """How one engine runs one kind of scene (justified in docs/simulation.md).

    ``dt`` [s] time step; ``creep`` [m/s] the engine's creep floor of a sticking contact (sets
    the slip threshold's lower bound); ``settle`` [s] start transient excluded from the
    comparison; ``mass_scale`` factor on the scene's masses (dynamics only: loads are explicit
    forces, so the quasistatic prediction does not depend on mass); ``ramp`` [s] command ramp at
    plan waypoints; ``record_every`` steps. Backend options: ``iterations`` (pymunk solver
    iterations); ``solref`` (MuJoCo contact time constant [s], damping ratio),
    ``z_stiffness`` [N/m] (MuJoCo spring holding dynamic bodies in the plane; their
    out-of-plane slide exists only for noslip) and ``support_solimp`` (MuJoCo solimp of every
    pair with a static body -- a table, a palm; :data:`SUPPORT_SOLIMP`, measured in
    docs/simulation.md; ``None``: the stiff default of all other pairs), ``carry_solref``
    (MuJoCo solref of every ``carry`` pair, :data:`CARRY_SOLREF`; ``None``: ``solref``) and
    ``carry_impratio`` (MuJoCo impratio of a scene without ``squeeze`` pairs,
    :data:`CARRY_IMPRATIO`); roles in :mod:`sim.backends.roles`. ``squeeze_d0`` (MuJoCo
    solimp ``d0`` of every ``squeeze`` pair, rising to 0.99 over the load width; ``None``, the
    default: the stiff ``(0.99, 0.999, 0.001)``; :data:`SQUEEZE_D0`) and ``squeeze_solref``
    (their solref when ``squeeze_d0`` is set, :data:`SQUEEZE_SOLREF`; ``None``: ``solref``);
    measured in docs/simulation.md, "MuJoCo: the sliding lift-off". :func:`soft_squeeze` gives
    both. ``heavy_ratio``: MuJoCo driven-body mass over the heaviest dynamic body's
    (:data:`HEAVY_RATIO`, :data:`SYSTEM_HEAVY_RATIO`). ``support_solref`` and
    ``support_impratio``: MuJoCo solref of every ``support`` pair and impratio of a scene with
    them where ``carry_impratio`` does not apply (``None``, the default: unchanged;
    :data:`SUPPORT_SOLREF`, :data:`SUPPORT_IMPRATIO`).
    """

    dt: float = 1e-3
    creep: float = 1e-9
    settle: float = 0.2
    mass_scale: float = 1.0
    ramp: float = 0.05
    record_every: int = 1
    iterations: int = 60
    solref: tuple[float, float] = (0.004, 1.0)
    z_stiffness: float = 0.0
    support_solimp: tuple[float, ...] | None = SUPPORT_SOLIMP
    carry_solref: tuple[float, float] | None = CARRY_SOLREF
    carry_impratio: float = CARRY_IMPRATIO
    squeeze_d0: float | None = None
    squeeze_solref: tuple[float, float] | None = SQUEEZE_SOLREF
    heavy_ratio: float = HEAVY_RATIO
    support_solref: tuple[float, float] | None = None
    support_impratio: float | None = None


def soft_squeeze(settings: EngineSettings | None = None) -> EngineSettings:
    """``settings`` (default: the defaults) with MuJoCo's soft, damped squeeze pairs
    (:data:`SQUEEZE_D0`, :data:`SQUEEZE_SOLREF`)."""
    from dataclasses import replace

    return replace(settings or EngineSettings(), squeeze_d0=SQUEEZE_D0,
                   squeeze_solref=SQUEEZE_SOLREF)


def check_engine(engine: str) -> str:
    """``engine`` if it is one of :data:`ENGINES`, else an :class:`InputError`."""
    if engine not in ENGINES:
        raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    return engine


def make_backend(engine: str, settings: EngineSettings | None = None) -> Backend:
    """The ``"pymunk"`` or ``"mujoco"`` backend (imported lazily) with ``settings``' options."""
    es = settings or EngineSettings()
    if check_engine(engine) == "pymunk":
        from sim.backends.pymunk_engine import PymunkBackend

        return PymunkBackend(iterations=es.iterations)
    from sim.backends.mujoco_engine import MujocoBackend

    return MujocoBackend(solref=es.solref, out_of_plane_stiffness=es.z_stiffness,
                         support_solimp=es.support_solimp, carry_solref=es.carry_solref,
                         carry_impratio=es.carry_impratio, squeeze_d0=es.squeeze_d0,
                         squeeze_solref=es.squeeze_solref, heavy_ratio=es.heavy_ratio,
                         support_solref=es.support_solref, support_impratio=es.support_impratio)
