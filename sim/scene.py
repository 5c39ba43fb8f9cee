"""Engine-neutral scene description and the backend interface.

A :class:`Scene` is plain frozen data: rigid bodies (polygon / circle / capsule shapes, mass,
centre of mass), joints of a body to the fixed base or to a parent body (revolute or prismatic,
each velocity- or effort-controlled with a per-step command callback; chains of links), bodies
driven at a prescribed planar twist (fingertips of the paper's Section 4 examples), named
contact pairs with static and kinetic friction, and constant external loads (the paper's
``g_obj``, eq. 2).

Backends (:mod:`sim.backends.pymunk_engine`, :mod:`sim.backends.mujoco_engine`,
:mod:`sim.backends.dart_engine`) implement
:class:`Backend`:

``build(scene)``
    create the engine model;
``step(dt)``
    advance by ``dt`` seconds (the backend applies commands, loads and per-pair friction);
``state()``
    ``{body name: BodyState}`` (pose of the body frame and twist of its origin, world frame);
``contacts()``
    ``{pair name: ContactReading}``: point, normal (unit, pointing into ``body_b``), normal
    force on ``body_b`` [N], tangential force on ``body_b`` along ``t = rot90(n)`` [N],
    relative tangential velocity of ``body_b``'s material point minus ``body_a``'s along ``t``
    [m/s], penetration depth [m] (``present`` False when the pair does not touch);
``set_friction(pair, mu)``
    change one pair's Coulomb coefficient between steps (used to emulate static/kinetic
    friction, Sec. 5.1);
``set_control(joint, control)``
    drive a revolute joint by velocity or by effort from the next step on (a task's segments
    may use other control partitions; :mod:`sim.backends.switching`);
``health()``
    ``None`` or the reason why the engine flagged numerical trouble.

With ``body_a`` = manipulator and ``body_b`` = workpiece, the reading follows
``docs/conventions.md``: ``n`` points into the workpiece, ``t = rot90(n)``, forces are the
manipulator's force on the workpiece, and ``v_t`` is eq. (5)'s ``v_it`` (workpiece minus
manipulator).

:func:`sim.run.run_scene` is the loop: it calls the backend, switches static/kinetic friction on
the measured slip, detects faults (NaN, penetration, a body leaving the scene, a contact missing
at the start) and records a :class:`sim.run.Recording`.

Example (a hand scene)::

    palm = Body("palm", (Polygon(((-.1, -.02), (.1, -.02), (.1, 0), (-.1, 0))),), kind="static")
    link = Body("f1", (Capsule((0, 0), (0, .1), .005),), mass=.05, com=(0, .05))
    joint = Joint("q1", body="f1", kind=JointKind.REVOLUTE, anchor=(-.05, 0),
                  control=Control.VELOCITY, command=lambda t, s: 0.01)
    scene = Scene(bodies=(palm, link, work), joints=(joint,),
                  pairs=(ContactPair("c1", "f1", "work", mu_static=.5),), loads=(...,))
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Protocol

import numpy as np

from planner.errors import InputError


class Control(str, Enum):
    """How a joint or driven body is actuated."""

    VELOCITY = "velocity"
    EFFORT = "effort"


class JointKind(str, Enum):
    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"


class BodyKind(str, Enum):
    """``dynamic``: free or jointed rigid body. ``driven``: moves with a prescribed twist
    (infinite inertia, transmits friction). ``static``: fixed (palm, environment)."""

    DYNAMIC = "dynamic"
    DRIVEN = "driven"
    STATIC = "static"


@dataclass(frozen=True)
class Polygon:
    """Convex polygon, vertices (k, 2) [m] counter-clockwise in the body frame."""

    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise InputError(f"polygon: expected (k>=3, 2) vertices, got shape {v.shape}")
        area = 0.5 * float(np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]))
        if not area > 0:
            raise InputError(f"polygon: expected counter-clockwise vertices, got area {area:.3g}")


@dataclass(frozen=True)
class Circle:
    """Circle of ``radius`` [m] centred at ``center`` (2,) [m], body frame."""

    center: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise InputError(f"circle radius: expected > 0, got {self.radius}")


@dataclass(frozen=True)
class Capsule:
    """Capsule from ``a`` to ``b`` (body frame, [m]) with rounding ``radius`` [m] (a link)."""

    a: tuple[float, float]
    b: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise InputError(f"capsule radius: expected > 0, got {self.radius}")


Shape = Polygon | Circle | Capsule
#: ``command(t, states) -> value``: joint velocity [rad/s or m/s] or effort [N m or N];
#: for a driven body a twist ``(v_x, v_y, omega)`` of the body-frame origin, world frame.
Command = Callable[[float, Mapping[str, "BodyState"]], Any]


@dataclass(frozen=True)
class Body:
    """A rigid body.

    Attributes
    ----------
    name : str
    shapes : tuple of Polygon | Circle | Capsule (body frame)
    mass : float [kg] (ignored for static and driven bodies)
    com : (2,) [m] centre of mass in the body frame
    inertia : float [kg m^2] about the COM; None = from the shapes (uniform density)
    pose : (3,) initial ``(x, y, theta)`` of the body frame in the world [m, m, rad]
    kind : BodyKind
    twist : Command, only for ``driven`` bodies
    """

    name: str
    shapes: tuple[Shape, ...]
    mass: float = 1.0
    com: tuple[float, float] = (0.0, 0.0)
    inertia: float | None = None
    pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    kind: BodyKind = BodyKind.DYNAMIC
    twist: Command | None = None

    def __post_init__(self) -> None:
        if not self.shapes:
            raise InputError(f"body {self.name!r}: expected at least one shape, got none")
        if self.kind == BodyKind.DYNAMIC and not self.mass > 0:
            raise InputError(f"body {self.name!r}: expected mass > 0, got {self.mass}")
        if self.kind == BodyKind.DRIVEN and self.twist is None:
            raise InputError(f"body {self.name!r}: a driven body needs a twist command")


@dataclass(frozen=True)
class Joint:
    """A joint between ``body`` and its ``parent`` body (``None``: the fixed base, world).

    ``anchor`` (2,) [m] world point of the revolute axis / a point on the prismatic line;
    ``axis`` (2,) unit direction of a prismatic joint (world); both at the scene's initial
    poses (a joint on a moving parent moves with it). ``command(t, states)`` returns the
    joint velocity (velocity control) or effort (effort control) for the next step: the rate /
    effort of ``body`` relative to ``parent`` (an effort acts on ``body`` and, opposite, on
    ``parent``). Chains (a finger's links): list a parent body before its children.
    """

    name: str
    body: str
    kind: JointKind
    anchor: tuple[float, float]
    control: Control
    command: Command
    axis: tuple[float, float] = (1.0, 0.0)
    parent: str | None = None


@dataclass(frozen=True)
class ContactPair:
    """A named contact between a shape of ``body_a`` (manipulator) and ``body_b`` (workpiece).

    ``shape_a`` indexes ``body_a.shapes`` (one contact site per shape, so one arbiter per
    contact). ``mu_kinetic`` None means a single Coulomb coefficient ``mu_static``.
    """

    name: str
    body_a: str
    body_b: str
    mu_static: float
    mu_kinetic: float | None = None
    shape_a: int = 0
    shape_b: int = 0

    def __post_init__(self) -> None:
        for v in (self.mu_static, self.mu_kinetic):
            if v is not None and not (np.isfinite(v) and v >= 0):
                raise InputError(f"pair {self.name!r}: expected friction >= 0, got {v}")


@dataclass(frozen=True)
class Load:
    """Constant external wrench on ``body``: force (2,) [N] through the body's COM plus a
    moment [N m] (the paper's ``g_obj`` with the COM at the world origin, eq. 2)."""

    body: str
    force: tuple[float, float]
    moment: float = 0.0


@dataclass(frozen=True)
class Scene:
    """Everything a backend needs. ``bounds`` (4,) ``(xmin, ymin, xmax, ymax)`` [m]: a dynamic
    body whose COM leaves it is a fault. ``length_scale`` [m] sets tolerances; ``only_pairs``
    restricts collisions to the declared pairs."""

    bodies: tuple[Body, ...]
    pairs: tuple[ContactPair, ...]
    joints: tuple[Joint, ...] = ()
    loads: tuple[Load, ...] = ()
    bounds: tuple[float, float, float, float] = (-10.0, -10.0, 10.0, 10.0)
    length_scale: float = 0.1
    meta: Mapping[str, Any] = field(default_factory=dict)
    #: True: only the shapes of declared pairs collide, with each other (MuJoCo always works
    #: this way; pymunk otherwise collides every pair of shapes, e.g. a finger link with the
    #: palm it is mounted on).
    only_pairs: bool = False

    def __post_init__(self) -> None:
        names = [b.name for b in self.bodies]
        if len(set(names)) != len(names):
            raise InputError(f"scene: expected unique body names, got {names}")
        for p in self.pairs:
            for nm in (p.body_a, p.body_b):
                if nm not in names:
                    raise InputError(
                        f"pair {p.name!r}: unknown body {nm!r}; expected one of {names}")
        jointed: set[str] = set()
        for j in self.joints:
            if j.body not in names:
                raise InputError(f"joint {j.name!r}: unknown body {j.body!r}")
            if j.body in jointed:
                raise InputError(f"joint {j.name!r}: expected one joint per body, got a "
                                 f"second joint on {j.body!r}")
            jointed.add(j.body)
            if j.parent is not None and (j.parent not in names or names.index(j.parent)
                                         >= names.index(j.body)):
                raise InputError(f"joint {j.name!r}: expected a parent body listed before "
                                 f"{j.body!r}, got {j.parent!r}")
        for ld in self.loads:
            if ld.body not in names:
                raise InputError(f"load: unknown body {ld.body!r}")

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise InputError(f"unknown body {name!r}")


@dataclass(frozen=True)
class BodyState:
    """Pose ``(x, y, theta)`` of the body frame and twist ``(v_x, v_y, omega)`` of its origin."""

    pose: tuple[float, float, float]
    twist: tuple[float, float, float]


@dataclass(frozen=True)
class ContactReading:
    """One named contact pair as the engine reports it (see module docstring for signs)."""

    present: bool
    point: tuple[float, float] = (np.nan, np.nan)
    normal: tuple[float, float] = (np.nan, np.nan)
    normal_force: float = 0.0
    tangent_force: float = 0.0
    slip_velocity: float = 0.0
    depth: float = 0.0


ABSENT = ContactReading(present=False)

#: Pre-load of every contact at the start, as a fraction of the scene's length scale: each
#: pair starts overlapped by this much (half of pymunk's collision slop of 1e-4 x scale), so a
#: pair built "exactly touching" never starts with a gap that rounding made +1e-17 m.
PRELOAD_OF_SCALE = 5e-5


def preload_depth(length_scale: float) -> float:
    """Initial overlap [m] of every contact pair of a scene of ``length_scale`` [m]."""
    return PRELOAD_OF_SCALE * length_scale


class Backend(Protocol):
    """The small interface every simulator backend implements."""

    name: str

    def build(self, scene: Scene) -> None: ...

    def step(self, dt: float) -> None: ...

    def state(self) -> dict[str, BodyState]: ...

    def contacts(self) -> dict[str, ContactReading]: ...

    def set_friction(self, pair: str, mu: float) -> None: ...

    def set_control(self, joint: str, control: Control | str) -> None: ...

    def health(self) -> str | None: ...


def point_velocity(state: BodyState, point: np.ndarray) -> np.ndarray:
    """Velocity (2,) [m/s] of the material point at world ``point`` of a body in ``state``."""
    x, y, _ = state.pose
    vx, vy, w = state.twist
    return np.array([vx - w * (point[1] - y), vy + w * (point[0] - x)])
