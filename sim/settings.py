"""How each engine runs each kind of scene: the one settings table of the simulation pipeline.

Every run (``qsplan simulate``, ``validate``, ``scenarios run``, ``demo``, the validation
campaign) takes its engine settings from :data:`SETTINGS`, keyed by the kind of scene
(:class:`SceneKind`) and the engine; nothing else holds per-engine constants. Each value below
says where it comes from: a derivation, or a measurement recorded in docs/simulation.md (the
reference) and docs/simulation-measurements.md (the record).

Scene kinds:

``system``
    any system file: fingertips driven at their contact velocities, fixed environment surfaces,
    chains of links, several workpieces (:mod:`sim.scenes.system`); also the paper's examples;
``hand``
    a hand at a configuration executing a plan (:mod:`sim.scenes.hand`): joints commanded by
    velocity or effort, held from waypoint to waypoint;
``ruler``
    the rod on two approaching fingers with static and kinetic friction (Sec. 5.1,
    :mod:`sim.scenes.ruler`).

Scale and speed (the same rule for every kind, :func:`scene_scale`, :func:`drive_speed`): a
scene whose size (largest distance of the workpiece from its centre of mass) lies outside
:data:`SIZE_RANGE` is simulated as a similar scene of the nearest size inside it
(:mod:`sim.similarity`; a uniform scaling of lengths leaves the quasistatic modes and the
contact forces unchanged), and the fastest manipulator contact moves at ``rate x size``,
at most ``max_speed`` (slow motion: a positive scaling of the velocity inputs leaves the modes
unchanged and scales the workpiece's twist by the same factor).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum

import numpy as np

from planner.errors import InputError


class SceneKind(str, Enum):
    """The kinds of scene the pipeline builds (module docstring)."""

    SYSTEM = "system"
    HAND = "hand"
    RULER = "ruler"


#: Scene sizes [m] at which the engine settings were measured: the shipped boxes (0.07 m), the
#: campaign's random boxes and trapezoids (0.03-0.15 m), the hands (0.05-0.2 m), the ruler
#: (0.05 m half length) and the paper's examples at 0.37 m (docs/simulation.md, "Scale"). A
#: scene outside is simulated as a similar scene at the nearest end of this range: the
#: engines' absolute tolerances (pymunk's collision slop, MuJoCo's ``solimp`` width of 1 mm,
#: its contact margins and solver tolerances) are not scale-free, so Example 4.1 at its own
#: 37 m size and a 2 mm part both left the range where the settings hold.
SIZE_RANGE = (0.03, 0.4)

#: MuJoCo solimp ``(d0, dwidth, width [m], midpoint, power)`` of every contact pair with a
#: static body (a resting support: a table, a palm). The stiff default impedance (0.99-0.999)
#: made a box pushed along a table stick and jump; 0.9 slides it at the drive speed
#: (docs/simulation.md, "MuJoCo: resting supports").
SUPPORT_SOLIMP = (0.9, 0.9, 0.001, 0.5, 2.0)
#: MuJoCo solref ``(time constant [s], damping ratio)`` of every ``carry`` pair
#: (:mod:`sim.backends.roles`: a driven manipulator moving along the contact tangent under a
#: load, the ruler's fingers): 10 time steps of 1 ms. With the stiff default (4 steps) a
#: sliding, load-carrying contact lifts off and bounces after every velocity change, and the
#: sticking contact slips during the bounces (docs/simulation.md, "MuJoCo: contact roles").
CARRY_SOLREF = (0.01, 1.0)
#: MuJoCo ``impratio`` of a scene whose pairs are all ``carry`` or ``support``: with 1, a
#: sliding contact at kinetic friction >= 0.6 that carries more than half the load climbs out
#: of its penetration until it bounces (docs/simulation.md, "MuJoCo: contact roles").
CARRY_IMPRATIO = 10.0
#: MuJoCo solref and impratio of every ``support`` pair of system scenes: the ``carry`` pairs'
#: values, for the same physics -- a contact that slides while it carries the load. With the
#: defaults a box pushed along a table at friction >= 0.45 stick-slips and rocks
#: (docs/simulation.md, "MuJoCo: sliding supports").
SUPPORT_SOLREF, SUPPORT_IMPRATIO = CARRY_SOLREF, CARRY_IMPRATIO
#: MuJoCo solimp ``d0`` of every ``squeeze`` pair of system scenes, rising to the stiff
#: default's 0.99 over the load width (:func:`sim.backends.mujoco_roles.load_width`): the
#: elliptic cone pushes a lightly loaded sliding finger apart at the stiff impedance
#: (lift ratio 2-8); at 0.9 it stays below 1 (docs/simulation.md, "MuJoCo: the sliding
#: lift-off"). The value is the support pairs', measured there.
SQUEEZE_D0 = 0.9
#: MuJoCo solref of the soft ``squeeze`` pairs: the default stiffness with twice its damping,
#: 0.002 s being MuJoCo's smallest time constant at the 1 ms step (``2 dt``); the soft
#: impedance removes the velocity term that damped a three-finger pinch (docs/simulation.md,
#: "MuJoCo: the sliding lift-off").
SQUEEZE_SOLREF = (0.002, 2.0)
#: MuJoCo: mass of a driven body (and armature of a velocity-controlled joint, per length
#: scale squared) over the heaviest dynamic body's. Hands and rulers: 1e6 (their measured
#: setting). System scenes: 1e4 -- the driven body's share of a contact's inverse effective mass
#: is 1e-4, far below every tolerance, while MuJoCo's solver scales its stopping tests by the
#: mean diagonal inertia, which loosened the workpiece's forces by 10-30 % of the force scale at
#: 1e6 (docs/simulation.md, "MuJoCo: the driven bodies' mass").
HEAVY_RATIO, SYSTEM_HEAVY_RATIO = 1e6, 1e4
#: MuJoCo's soft contacts sink in by about ``(contact force / mass) x solref time constant^2``,
#: so the fraction of its size a scene's contacts sink in grows with its load acceleration per
#: size ``|load| / (workpiece mass x size)`` [1/s^2] -- the "load" part of a scene's similarity
#: (loads and efforts are explicit forces: the masses change only the dynamics, never the
#: prediction). A scene above the largest value its settings were measured at gets its masses
#: scaled up to it (:func:`with_mass_for_load`): the two-finger hand (0.08 N on 0.1 kg at
#: 86.8 mm: 9.2; docs/simulation.md, "Two-finger hand") for hands, the campaign's boxes for
#: system scenes (0.981 N on 0.1 kg at sizes from 0.035 m: 280).
MUJOCO_REFERENCE_LOAD_PER_SIZE = 0.08 / (0.1 * 0.0868)
SYSTEM_REFERENCE_LOAD_PER_SIZE = 0.981 / (0.1 * 0.035)


#: DART's creep floor [m/s]. DART adds constraint force mixing (1e-5, compiled in) to every
#: constraint row, so a sticking contact slips at ``1e-5 x |f_t| x dt x w`` (``w`` the
#: contact's inverse effective mass along ``t``): measured 2.5e-8 m/s (a 1 kg box on an incline
#: at mu 0.3), 6e-8 (the ruler's sticking finger, 2 ms), 1.5e-7 (the 10 kg ladder holding
#: 80 N of floor friction, the same at every mu from 0.83 to 1: not a cone effect). The floor
#: is that slip for a friction force accelerating its body by up to 100 m/s^2 (10 g) at 1 ms,
#: ``1e-5 x 100 x 1e-3``; the judge's slip threshold ``10 x creep`` = 1e-5 m/s stays below
#: ``0.05 x`` every drive of the table (the ruler's 0.3 mm/s: 1.5e-5 m/s), so the drive, not
#: the creep, sets it (docs/engine-dart.md, "The creep floor").
DART_CREEP = 1e-5 * 100.0 * 1e-3


@dataclass(frozen=True)
class EngineSettings:
    """How one engine runs one kind of scene (the fields' sources: :data:`SETTINGS`).

    Run: ``dt`` [s] time step; ``creep`` [m/s] the engine's creep floor of a sticking contact
    (the slip threshold's lower bound); ``settle`` [s] start transient not judged;
    ``duration`` [s] default run length of a system scene; ``start_ramp`` [s] a system scene's
    drive rises from rest over this time (smoothstep, :func:`sim.run.ramped`) where two contacts
    can wedge the workpiece at the start (:func:`planner.model.wedge.wedge_pairs`), or always
    with ``ramp_always``; otherwise it starts at its speed (the quasistatic model's initial
    condition); ``ramp`` [s] linear ramp of a plan's command change at a waypoint;
    ``record_every`` steps.

    Speed: ``rate`` [1/s] the fastest contact moves this many scene sizes per second, at most
    ``max_speed`` [m/s] (:func:`drive_speed`).

    Backend options: ``iterations`` (pymunk); ``mass_scale`` factor on the scene's masses
    (dynamics only: loads are explicit forces); MuJoCo ``solref`` of every pair,
    ``z_stiffness`` [N/m] of the spring holding dynamic bodies in the plane, ``contact_force``
    [N] and ``stick_speed`` [m/s] (MuJoCo's ``impratio`` is raised until a contact holding
    its friction coefficient times ``contact_force`` creeps slower than ``stick_speed``:
    :func:`with_stick_limits`; ``None``: no such bound), the impedance of
    each contact role (:mod:`sim.backends.roles`): ``support_solimp``, ``support_solref``,
    ``support_impratio``, ``carry_solref``, ``carry_impratio``, ``squeeze_d0`` (None: the stiff
    default), ``squeeze_solref``, and ``heavy_ratio`` (driven-body mass over the heaviest
    dynamic body's).
    """

    dt: float = 1e-3
    creep: float = 1e-9
    settle: float = 0.2
    duration: float = 1.5
    start_ramp: float = 0.0
    ramp_always: bool = False
    ramp: float = 0.05
    record_every: int = 1
    rate: float = 0.02
    max_speed: float = 2e-3
    iterations: int = 60
    mass_scale: float = 1.0
    solref: tuple[float, float] = (0.004, 1.0)
    z_stiffness: float = 0.0
    support_solimp: tuple[float, ...] | None = SUPPORT_SOLIMP
    support_solref: tuple[float, float] | None = None
    support_impratio: float | None = None
    carry_solref: tuple[float, float] | None = CARRY_SOLREF
    carry_impratio: float = CARRY_IMPRATIO
    squeeze_d0: float | None = None
    squeeze_solref: tuple[float, float] | None = SQUEEZE_SOLREF
    heavy_ratio: float = HEAVY_RATIO
    load_per_size: float | None = None
    contact_force: float | None = None
    stick_speed: float | None = None

    def drive_speed(self, size: float) -> float:
        """Speed [m/s] of the fastest manipulator contact in a scene of ``size`` [m]."""
        return min(self.rate * size, self.max_speed)


#: The one settings table: ``SETTINGS[(kind, engine)]``.
#:
#: * system, pymunk: 1 ms steps (pymunk resolves stick/slip thresholds to 2e-4 deg at this
#:   step, docs/simulation.md "Engines"), creep floor 1e-9 m/s (measured), 0.3 s settling,
#:   1.5 s runs, 0.02 sizes per second up to 2 mm/s (the paper examples' measured speed); the
#:   drive starts at its speed -- the model's initial condition; ramped from rest it passes
#:   through speeds where the load, not the drive, moves the workpiece: Example 4.3 at
#:   mu = .05 .15 .85 then slid into an unpredicted branch (S-1 S-2 B3, then S-1 R2 B3) after
#:   any ramp from 2 to 60 ms, and showed the predicted S+1 B2 R3 from a step -- except where two
#:   contacts can wedge it: a step wedged Example 4.3 at mu = .86 .42 .95 (33 N in the first
#:   step at a 1 N load), ramped over 0.15 s it shows the predicted S-1 R2 B3;
#: * system, MuJoCo: 1 ms, creep floor 1e-8 m/s (elliptic cone with noslip, measured), 1 s
#:   settling (soft contacts), 2.5 s runs, 0.005 sizes per second up to 0.5 mm/s (sliding
#:   contacts chatter above a few mm/s: 3 % of steps lost contact at 10 mm/s), the drive always
#:   ramped over 0.5 s (a velocity step makes soft contacts bounce), the soft squeeze pairs,
#:   the sliding supports' impedance and driven bodies 1e4 x the workpiece;
#: * hand: the settings measured on the two-finger hand (docs/simulation.md, "Two-finger
#:   hand"): pymunk at 1 ms; MuJoCo with a 0.01 s solref, masses x 0.1 (then scaled up by the
#:   load per size, :data:`MUJOCO_REFERENCE_LOAD_PER_SIZE`), a 1e3 N/m in-plane spring, 0.3 s
#:   settling, ``impratio`` raised per run so a sticking contact's soft-friction creep stays
#:   below half the slip threshold (:func:`with_stick_limits`, docs/simulation.md "MuJoCo:
#:   friction creep"); commands ramped over 0.05 s at a waypoint; plans run at their own speed up to
#:   the drive limit (2 mm/s pymunk, 1.5 mm/s MuJoCo: the two-finger plan runs at 1.2 mm/s in
#:   both);
#: * ruler: pymunk at 2 ms and 0.3 mm/s, MuJoCo at 1 ms and 0.15 mm/s per finger for the
#:   rod of 0.1 m (size 0.05 m: 0.006 and 0.003 sizes per second), every 5th step recorded:
#:   the switch positions converge to the closed form as the speed drops (inertial lag of a
#:   hand-over); MuJoCo's 4th/5th switches miss 2 % at 0.3 mm/s, not at
#:   0.15 (docs/simulation.md, "The ruler against its closed form");
#: * DART (the referee with true stiction, docs/engine-dart.md): pymunk's run settings in
#:   every kind -- both solve rigid contacts under the exact Coulomb law, so the same step,
#:   speed, settling and duration resolve the same thresholds (measured through the pipeline:
#:   docs/engine-dart.md, "Settings") -- and its creep floor :data:`DART_CREEP` (derived there).
SETTINGS: dict[tuple[SceneKind, str], EngineSettings] = {
    (SceneKind.SYSTEM, "pymunk"): EngineSettings(
        dt=1e-3, creep=1e-9, settle=0.3, duration=1.5, start_ramp=0.15, rate=0.02,
        max_speed=2e-3),
    (SceneKind.SYSTEM, "mujoco"): EngineSettings(
        dt=1e-3, creep=1e-8, settle=1.0, duration=2.5, start_ramp=0.5, ramp_always=True,
        rate=0.005,
        max_speed=5e-4, heavy_ratio=SYSTEM_HEAVY_RATIO, squeeze_d0=SQUEEZE_D0,
        squeeze_solref=SQUEEZE_SOLREF, support_solref=SUPPORT_SOLREF,
        support_impratio=SUPPORT_IMPRATIO, load_per_size=SYSTEM_REFERENCE_LOAD_PER_SIZE),
    (SceneKind.HAND, "pymunk"): EngineSettings(
        dt=1e-3, creep=1e-9, settle=0.2, ramp=0.05, rate=0.05, max_speed=2e-3),
    (SceneKind.HAND, "mujoco"): EngineSettings(
        dt=1e-3, creep=1e-8, settle=0.3, ramp=0.05, rate=0.05, max_speed=1.5e-3,
        mass_scale=0.1, solref=(0.01, 1.0), z_stiffness=1000.0,
        load_per_size=MUJOCO_REFERENCE_LOAD_PER_SIZE),
    (SceneKind.RULER, "pymunk"): EngineSettings(
        dt=2e-3, creep=1e-9, settle=0.2, rate=0.006, max_speed=3e-4, record_every=5),
    (SceneKind.RULER, "mujoco"): EngineSettings(
        dt=1e-3, creep=1e-8, settle=0.2, rate=0.003, max_speed=1.5e-4, record_every=5),
    (SceneKind.SYSTEM, "dart"): EngineSettings(
        dt=1e-3, creep=DART_CREEP, settle=0.3, duration=1.5, start_ramp=0.15, rate=0.02,
        max_speed=2e-3),
    (SceneKind.HAND, "dart"): EngineSettings(
        dt=1e-3, creep=DART_CREEP, settle=0.2, ramp=0.05, rate=0.05, max_speed=2e-3),
    (SceneKind.RULER, "dart"): EngineSettings(
        dt=2e-3, creep=DART_CREEP, settle=0.2, rate=0.006, max_speed=3e-4, record_every=5),
}

#: Every engine the table knows, in the order reports list them: the choices wherever a user
#: names an engine (``--engine``, ``--engines``, a scenario's engines).
ENGINES: tuple[str, ...] = tuple(dict.fromkeys(engine for _, engine in SETTINGS))
#: The engines of the validation campaign's default and the parametrised tests: the two every
#: install has. ``qsplan demo`` runs every installed engine instead
#: (:func:`sim.backends.installed_engines`: DART too with the ``dart`` extra,
#: docs/engine-dart.md: what it is for and its cost, 2-6x pymunk's time per step).
DEFAULT_ENGINES: tuple[str, ...] = ("pymunk", "mujoco")


def check_engine(engine: str) -> str:
    """``engine`` if the settings table knows it, else an :class:`InputError`."""
    if engine not in ENGINES:
        raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    return engine


def settings_for(kind: SceneKind | str, engine: str) -> EngineSettings:
    """The table's settings for a scene ``kind`` in ``engine``."""
    check_engine(engine)
    try:
        key = (SceneKind(kind), engine)
    except ValueError:
        raise InputError(f"scene kind: expected one of {', '.join(k.value for k in SceneKind)}, "
                         f"got {kind!r}") from None
    return SETTINGS[key]


def scene_scale(size: float) -> float:
    """Factor [-] by which a scene of ``size`` [m] is scaled for simulation: 1 inside
    :data:`SIZE_RANGE`, else the factor to its nearest end."""
    if not (size > 0 and size < float("inf")):
        raise InputError(f"scene size: expected a finite size > 0 [m], got {size}")
    lo, hi = SIZE_RANGE
    return lo / size if size < lo else hi / size if size > hi else 1.0


def with_mass_for_load(settings: EngineSettings, load: float, mass: float,
                       size: float) -> EngineSettings:
    """``settings`` with the masses scaled up so the scene's load acceleration per size,
    ``load / (mass x size)`` [1/s^2], is no more than ``settings.load_per_size`` (the largest
    the settings were measured at; module constants above); unchanged without that rule or
    below it. ``load`` [N]: the larger of the external load and the squeeze the effort joints
    exert; ``mass`` [kg] the workpiece's; ``size`` [m] the simulated scene's."""
    ref = settings.load_per_size
    if ref is None or not (mass > 0 and size > 0):
        return settings
    ratio = load / (mass * size) / ref
    return replace(settings, mass_scale=settings.mass_scale * ratio) if ratio > 1.0 else settings


def with_stick_limits(settings: EngineSettings, force: float, speed: float) -> EngineSettings:
    """``settings`` with the friction a run's contacts must hold: ``force`` [N] the largest
    normal force a contact carries (a contact of friction ``mu`` holds at most ``mu force`` of
    friction), ``speed`` [m/s, at the simulated size] the slip speed a contact holding it may
    creep at. MuJoCo derives its ``impratio`` from them
    (:func:`sim.backends.mujoco_impedance.creep_impratio`; docs/simulation.md, "MuJoCo: friction
    creep"); the other engines solve Coulomb friction exactly and ignore them."""
    if not (np.isfinite(force) and force >= 0 and np.isfinite(speed) and speed > 0):
        raise InputError(f"stick limits: expected a finite force >= 0 [N] and a speed > 0 "
                         f"[m/s], got {force} and {speed}")
    return replace(settings, contact_force=float(force), stick_speed=float(speed))
