"""The simulation loop: drive a backend, emulate static/kinetic friction, detect faults, record.

Faults (simulator trouble, never a pass): ``NAN`` (a non-finite state), ``LEFT_SCENE`` (a
moving body's origin outside ``scene.bounds``: an escaping workpiece, or a driven body commanded
out of the scene), ``PENETRATION`` (a contact deeper than
``penetration_tol``), ``CONTACT_LOST_AT_START`` (a pair not touching after the first step:
the scene was built touching), ``ENGINE_WARNING`` (the engine's own alarm: a MuJoCo warning counter
``data.warning[mjWARN_*]`` that rose during the step -- ``BADQPOS``/``BADQVEL``/``BADQACC`` are
reported as ``NAN`` because MuJoCo silently resets the state after them, so NaN never reaches
the recorded poses -- or an exception that the engine swallowed during the step, e.g. pymunk's
cffi collision callbacks print "Exception ignored" and carry on with a missing contact reading).
An observed *jam* (Fig. 3 "Jam": the fingers cannot move the
workpiece without growing force) is not a fault: the loop stops early once the total contact
normal force exceeds ``jam_force`` for ``jam_window`` seconds and records ``jammed_at``.
"""

from __future__ import annotations

import sys
import threading
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

import numpy as np

from sim.scene import Backend, BodyKind, Scene


class FaultKind(str, Enum):
    NAN = "nan"
    LEFT_SCENE = "left_scene"
    PENETRATION = "penetration"
    CONTACT_LOST_AT_START = "contact_lost_at_start"
    ENGINE_WARNING = "engine_warning"


#: MuJoCo warnings that mean a non-finite or huge state (MuJoCo resets the state after them).
_MUJOCO_BAD_STATE = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


_SINKS = threading.local()
_HOOK_LOCK = threading.Lock()
_PREVIOUS_HOOK: list[Any] = []


def _dispatch_unraisable(unraisable: Any) -> None:
    """``sys.unraisablehook``: to the current thread's running :class:`EngineWatch`, if any;
    otherwise to the hook that was installed before."""
    sink = getattr(_SINKS, "sink", None)
    if sink is not None:
        sink.append(unraisable)
    else:
        (_PREVIOUS_HOOK[0] if _PREVIOUS_HOOK else sys.__unraisablehook__)(unraisable)


def _install_unraisable_dispatch() -> None:
    with _HOOK_LOCK:
        if sys.unraisablehook is not _dispatch_unraisable:
            _PREVIOUS_HOOK[:] = [sys.unraisablehook]
            sys.unraisablehook = _dispatch_unraisable


class EngineWatch:
    """The engine's own alarms during one step, for any backend.

    * MuJoCo (a backend with ``data.warning``, an ``MjData``): the counter of every
      ``mjtWarning`` is remembered before the step; a counter that rose is reported with its
      name and ``lastinfo`` (the DOF / size MuJoCo names).
    * Any engine: exceptions that the engine swallowed during the step. Python reports them to
      ``sys.unraisablehook`` (pymunk's cffi callbacks do this: a failing ``post_solve`` prints
      "Exception ignored from cffi callback" and the step goes on without that reading).

    An interrupt swallowed that way -- a ``KeyboardInterrupt`` (Ctrl-C, or the command line's
    own SIGTERM/SIGHUP interrupt, a subclass), a ``SystemExit``, any ``BaseException`` that is
    not an ``Exception`` -- is no engine alarm: the user or the system asked the run to stop,
    so :meth:`step` raises it again once the engine's step has returned
    (:func:`swallowed_interrupt`), and it never becomes a fault or a verdict.
    """

    def __init__(self, backend: Any) -> None:
        self.backend = backend
        self._names: tuple[str, ...] = ()
        data = getattr(backend, "data", None)
        if data is not None and hasattr(data, "warning"):
            import mujoco  # only with a MuJoCo backend

            self._names = tuple(
                nm for nm in mujoco.mjtWarning.__members__ if nm.startswith("mjWARN_"))
            self._index = {nm: int(getattr(mujoco.mjtWarning, nm)) for nm in self._names}
        self._counts = self._read()
        self.swallowed: list[Any] = []

    def _read(self) -> np.ndarray:
        """All warning counters at once, indexed by ``mjtWarning`` (one vectorised read)."""
        if not self._names:
            return np.zeros(0, dtype=np.int64)
        return np.array(self.backend.data.warning.number, dtype=np.int64)

    def step(self, dt: float) -> None:
        """``backend.step(dt)`` with swallowed exceptions collected (per thread, so runs in
        parallel threads neither mix their reports nor leave a stale hook behind)."""
        _install_unraisable_dispatch()
        outer = getattr(_SINKS, "sink", None)
        _SINKS.sink = self.swallowed
        try:
            self.backend.step(dt)
        finally:
            _SINKS.sink = outer
        interrupt = swallowed_interrupt(self.swallowed)
        if interrupt is not None:
            self.swallowed.clear()
            raise interrupt

    def check(self) -> tuple[FaultKind, str] | None:
        """``(kind, detail)`` of the first alarm raised since the last call, else ``None``."""
        if self.swallowed:
            u = self.swallowed[0]
            self.swallowed.clear()
            where = f" ({u.err_msg})" if getattr(u, "err_msg", None) else ""
            return (FaultKind.ENGINE_WARNING,
                    f"engine swallowed {u.exc_type.__name__}: {u.exc_value}{where}")
        if not self._names:
            return None
        now = self._read()
        rose = now > self._counts
        self._counts = now  # also follows counters reset by mj_resetData
        if not np.any(rose):
            return None
        risen = [nm for nm in self._names if rose[self._index[nm]]]
        data = self.backend.data
        detail = "; ".join(
            f"MuJoCo {nm} (count {now[self._index[nm]]}, "
            f"info {int(data.warning[self._index[nm]].lastinfo)})" for nm in risen)
        bad_state = any(nm in _MUJOCO_BAD_STATE for nm in risen)
        if bad_state:
            detail = "NaN/Inf/huge state, reset by MuJoCo: " + detail
        return (FaultKind.NAN if bad_state else FaultKind.ENGINE_WARNING), detail


def swallowed_interrupt(swallowed: list[Any]) -> BaseException | None:
    """The first interrupt among swallowed exceptions (``sys.unraisablehook`` arguments): an
    exception that is a ``BaseException`` but not an ``Exception`` (``KeyboardInterrupt`` and
    its subclasses, ``SystemExit``), ready to be raised again; ``None`` when there is none."""
    for u in swallowed:
        kind = getattr(u, "exc_type", None)
        if isinstance(kind, type) and issubclass(kind, BaseException) and not issubclass(
                kind, Exception):
            value = getattr(u, "exc_value", None)
            return value if isinstance(value, BaseException) else kind()
    return None


@dataclass(frozen=True)
class Fault:
    kind: FaultKind
    time: float
    detail: str

    @property
    def reason(self) -> str:
        return f"{self.kind.value} at t={self.time:.4f} s: {self.detail}"


@dataclass(frozen=True, eq=False)
class Recording:
    """Time series of one run; ``T`` recorded steps, ``P`` pairs, ``B`` bodies.

    times (T,) [s]; poses (T, B, 3) [m, m, rad]; present (T, P) bool; points, normals
    (T, P, 2); normal_force, tangent_force (T, P) [N]; slip_velocity (T, P) [m/s];
    depth (T, P) [m]; mu_used (T, P) the Coulomb coefficient in force during the step;
    correction (T, B, 3) [m, m, rad] the part of each body's displacement since the start that
    its velocities do not account for (the sum over steps of ``pose change - twist * dt``): an
    engine that removes overlap by moving bodies apart outside its velocity solve (pymunk's
    bias velocities, docs/simulation-measurements.md "Position correction") shows it here, an
    engine whose positions are integrated from its velocities (MuJoCo, DART) keeps it at
    rounding level. ``None`` in recordings made without it.
    """

    engine: str
    pair_names: tuple[str, ...]
    body_names: tuple[str, ...]
    times: np.ndarray
    poses: np.ndarray
    present: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    normal_force: np.ndarray
    tangent_force: np.ndarray
    slip_velocity: np.ndarray
    depth: np.ndarray
    mu_used: np.ndarray
    fault: Fault | None = None
    jammed_at: float | None = None
    correction: np.ndarray | None = None

    def until(self, t: float) -> Recording:
        """The steps recorded at or before ``t`` [s], without the fault or jam that ended the
        run (what the run showed before its end)."""
        k = int(np.searchsorted(self.times, t + 1e-12, side="right"))
        cut = {f: getattr(self, f)[:k] for f in (
            "times", "poses", "present", "points", "normals", "normal_force", "tangent_force",
            "slip_velocity", "depth", "mu_used")}
        if self.correction is not None:
            cut["correction"] = self.correction[:k]
        return replace(self, fault=None, jammed_at=None, **cut)


@dataclass(frozen=True)
class RunSettings:
    """Loop settings: ``duration``, ``dt`` [s]; ``slip_speed`` [m/s] threshold for switching a
    pair from static to kinetic friction; ``penetration_tol`` [m]; ``jam_force`` [N] (total
    normal force) and ``jam_window`` [s]; ``jam_after`` [s]: the loop never stops on a jam
    before this time (set it past the settling time, so a jammed run still has judged steps);
    ``start_ramp`` [s]: driven bodies' twist commands rise from rest over this time
    (:func:`ramped`; 0: a velocity step at ``t = 0``).

    ``open_at_start``: names of pairs allowed to be apart at the first step (contacts a later
    part of the run gains; no ``CONTACT_LOST_AT_START`` for them). ``control_switches``:
    ``(time [s], joint name, "velocity" | "effort")`` -- from the first step starting at or
    after ``time`` the joint is driven with that control (the backend's ``set_control``);
    its command callback must then return the new control's quantity."""

    duration: float
    dt: float
    slip_speed: float
    penetration_tol: float
    jam_force: float = np.inf
    jam_window: float = 0.05
    jam_after: float = 0.0
    record_every: int = 1
    start_ramp: float = 0.0
    open_at_start: tuple[str, ...] = ()
    control_switches: tuple[tuple[float, str, str], ...] = ()


def ramped(command: Any, ramp: float) -> Any:
    """``command(t, states)`` times the smoothstep ``3 a^2 - 2 a^3`` of ``a = t / ramp`` for
    ``t < ramp`` [s]: a driven body starts from rest with continuous acceleration instead of a
    velocity jump (the jump's first-step impulses are many times the load and can wedge a
    workpiece between two fingers, docs/simulation.md "Validation campaign"). The wrapper's
    ``unramped`` attribute is ``command`` (its direction decides MuJoCo's contact roles,
    :mod:`sim.backends.roles`)."""
    def command_ramped(t: float, states: Any) -> tuple[float, float, float]:
        v = command(t, states)
        if t >= ramp:
            return v
        a = max(0.0, t / ramp)
        f = a * a * (3.0 - 2.0 * a)
        return (v[0] * f, v[1] * f, v[2] * f)
    command_ramped.unramped = command  # type: ignore[attr-defined]
    return command_ramped


def with_start_ramp(scene: Scene, ramp: float) -> Scene:
    """``scene`` with every driven body's twist command :func:`ramped` over ``ramp`` [s]
    (``ramp <= 0``: unchanged)."""
    if not ramp > 0:
        return scene
    bodies = tuple(replace(b, twist=ramped(b.twist, ramp))
                   if b.kind == BodyKind.DRIVEN and b.twist is not None else b
                   for b in scene.bodies)
    return replace(scene, bodies=bodies)


def run_scene(scene: Scene, backend: Backend, settings: RunSettings) -> Recording:
    """Build ``scene`` in ``backend`` and run it, recording every ``record_every`` steps."""
    scene = with_start_ramp(scene, settings.start_ramp)
    backend.build(scene)
    watch = EngineWatch(backend)
    pairs = scene.pairs
    names = tuple(p.name for p in pairs)
    body_names = tuple(b.name for b in scene.bodies)
    # every moving body must stay in the scene: a workpiece that leaves escaped, a driven body
    # that leaves was commanded out of it (a broken command, not physics)
    moving = [b.name for b in scene.bodies if b.kind != BodyKind.STATIC]
    n_steps = int(round(settings.duration / settings.dt))
    rows: dict[str, list] = {k: [] for k in (
        "t", "pose", "present", "point", "normal", "fn", "ft", "vt", "depth", "mu", "corr")}
    start = backend.state()
    prev_pose = np.array([start[b].pose for b in body_names], dtype=float)
    corr = np.zeros((len(body_names), 3))
    mu_now = np.array([p.mu_static for p in pairs], dtype=float)
    slipping = np.zeros(len(pairs), dtype=bool)
    fault: Fault | None = None
    jammed_at: float | None = None
    jam_steps = 0
    xmin, ymin, xmax, ymax = scene.bounds
    switches = sorted(settings.control_switches)
    for k in range(n_steps):
        while switches and switches[0][0] <= k * settings.dt + 1e-12:
            _, joint, control = switches.pop(0)
            backend.set_control(joint, control)
        for i, p in enumerate(pairs):
            if p.mu_kinetic is not None:
                mu_new = p.mu_kinetic if slipping[i] else p.mu_static
                if mu_new != mu_now[i]:
                    backend.set_friction(p.name, mu_new)
                    mu_now[i] = mu_new
        watch.step(settings.dt)
        t = (k + 1) * settings.dt
        states = backend.state()
        readings = backend.contacts()
        pose = np.array([states[b].pose for b in body_names], dtype=float)
        twist = np.array([states[b].twist for b in body_names], dtype=float)
        with np.errstate(invalid="ignore", over="ignore"):  # a non-finite state: fault below
            moved = pose - prev_pose
            moved[:, 2] = (moved[:, 2] + np.pi) % (2.0 * np.pi) - np.pi
            corr += moved - twist * settings.dt
        prev_pose = pose
        rd = [readings[nm] for nm in names]
        present = np.array([r.present for r in rd], dtype=bool)
        fn = np.array([r.normal_force for r in rd])
        vt = np.array([r.slip_velocity for r in rd])
        depth = np.array([r.depth for r in rd])
        # a pair that is momentarily not touching keeps its previous friction state
        slipping = np.where(present, np.abs(vt) > settings.slip_speed, slipping)
        if k % settings.record_every == 0:
            rows["t"].append(t)
            rows["pose"].append(pose)
            rows["present"].append(present)
            rows["point"].append([r.point for r in rd])
            rows["normal"].append([r.normal for r in rd])
            rows["fn"].append(fn)
            rows["ft"].append([r.tangent_force for r in rd])
            rows["vt"].append(vt)
            rows["depth"].append(depth)
            rows["mu"].append(mu_now.copy())
            rows["corr"].append(corr.copy())
        # -- faults ---------------------------------------------------------------------
        problem = backend.health()
        if problem:
            fault = Fault(FaultKind.NAN, t, problem)
            break
        alarm = watch.check()
        if alarm is not None:
            fault = Fault(alarm[0], t, alarm[1])
            break
        if not (np.all(np.isfinite(pose)) and np.all(np.isfinite(twist))
                and np.all(np.isfinite(fn[present]))):
            fault = Fault(FaultKind.NAN, t, "non-finite body state or contact force")
            break
        for b in moving:
            x, y, _ = states[b].pose
            if not (xmin <= x <= xmax and ymin <= y <= ymax):
                fault = Fault(FaultKind.LEFT_SCENE, t,
                              f"body {b!r} at ({x:.4g}, {y:.4g}) outside bounds "
                              f"{[round(float(v), 6) for v in scene.bounds]}")
                break
        if fault:
            break
        if np.any(present & (depth > settings.penetration_tol)):
            i = int(np.argmax(np.where(present, depth, -np.inf)))
            fault = Fault(FaultKind.PENETRATION, t,
                          f"pair {names[i]!r} depth {depth[i]:.3g} m > tolerance "
                          f"{settings.penetration_tol:.3g} m")
            break
        if k == 0 and not all(ok or nm in settings.open_at_start
                              for nm, ok in zip(names, present)):
            lost = [nm for nm, ok in zip(names, present)
                    if not ok and nm not in settings.open_at_start]
            fault = Fault(FaultKind.CONTACT_LOST_AT_START, t, f"pairs {lost} not touching")
            break
        if float(np.sum(np.where(present, fn, 0.0))) > settings.jam_force:
            jam_steps += 1
            if jam_steps * settings.dt >= settings.jam_window and t >= settings.jam_after:
                jammed_at = t
                break
        else:
            jam_steps = 0
    P = len(pairs)
    T = len(rows["t"])

    def arr(key: str, shape: tuple[int, ...]) -> np.ndarray:
        return np.asarray(rows[key], dtype=float).reshape((T, *shape))

    return Recording(
        engine=getattr(backend, "name", type(backend).__name__),
        pair_names=names,
        body_names=body_names,
        times=np.asarray(rows["t"], dtype=float),
        poses=arr("pose", (len(body_names), 3)),
        present=np.asarray(rows["present"], dtype=bool).reshape(T, P),
        points=arr("point", (P, 2)),
        normals=arr("normal", (P, 2)),
        normal_force=arr("fn", (P,)),
        tangent_force=arr("ft", (P,)),
        slip_velocity=arr("vt", (P,)),
        depth=arr("depth", (P,)),
        mu_used=arr("mu", (P,)),
        fault=fault,
        jammed_at=jammed_at,
        correction=arr("corr", (len(body_names), 3)),
    )
