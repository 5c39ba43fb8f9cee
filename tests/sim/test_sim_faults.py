"""Simulator trouble is reported as a fault with its reason, never as a pass.

Covered kinds (``sim.run.FaultKind``): NaN load and NaN / infinite / huge commands (MuJoCo
resets the state after its ``mjWARN_BADQPOS``/``BADQVEL`` warnings, so only the warning counter
shows it), a body leaving the scene, penetration beyond tolerance, contact lost at the start,
MuJoCo's own capacity warnings (``mjWARN_CONTACTFULL``/``CNSTRFULL``) and exceptions swallowed
inside pymunk's cffi collision callbacks.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sim_helpers import example, example_scene

import sim.backends.mujoco_engine as mujoco_backend
from planner.predict.feasibility import feasible_modes
from sim.backends import make_backend
from sim.backends.pymunk_engine import PymunkBackend
from sim.classify import Thresholds
from sim.expectation import ModeSet
from sim.judge import judge_modes
from sim.run import EngineWatch, FaultKind, RunSettings, run_scene
from sim.scene import Load
from sim.verdict import Expect, Outcome

ENGINES = ("pymunk", "mujoco")
SPEED = 1e-3


def _scene(gap: float = 0.0, mu=(0.2, 0.3, 0.1)):
    return example_scene("example_4_1", 0.01, SPEED, mu, mass=0.01, gap=gap)


def _settings(**kw):
    base = dict(duration=0.3, dt=1e-3, slip_speed=0.05 * SPEED, penetration_tol=1e-3)
    base.update(kw)
    return RunSettings(**base)


def _judge(rec, mu=(0.2, 0.3, 0.1)):
    # steps before the settling time are never judged, so a fault there is only a fault
    th = Thresholds.for_drive(SPEED, 1.0, settle=0.1)
    system = example("example_4_1", 0.01, SPEED).with_mu(mu)
    exp = ModeSet(tuple(feasible_modes(system).all_modes), system, 1.0, ("workpiece",), SPEED,
                  0.37, 1.0)
    return judge_modes(rec, exp, th)[0]


@pytest.mark.parametrize("engine", ENGINES)
def test_nan_load_is_a_fault(engine, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT into the working directory
    scene = _scene()
    scene = dataclasses.replace(scene, loads=(Load("workpiece", (np.nan, -1.0), 0.0),))
    rec = run_scene(scene, make_backend(engine), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.NAN
    cmp = _judge(rec)
    assert cmp.outcome == Outcome.FAULT and "nan" in cmp.reason
    assert cmp.fault is not None and cmp.fault.kind == FaultKind.NAN
    assert not cmp.held(Expect.AGREE) and not cmp.held(Expect.DISAGREE)


@pytest.mark.parametrize("engine", ENGINES)
def test_contact_lost_at_start(engine):
    rec = run_scene(_scene(gap=1e-3), make_backend(engine), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.CONTACT_LOST_AT_START
    assert "not touching" in rec.fault.reason
    assert _judge(rec).outcome == Outcome.FAULT


@pytest.mark.parametrize("engine", ENGINES)
def test_body_leaving_the_scene(engine):
    scene = dataclasses.replace(_scene(), loads=(Load("workpiece", (-15.0, 50.0), 0.0),),
                                bounds=(-0.3, -0.3, 0.3, 0.3))
    rec = run_scene(scene, make_backend(engine), _settings(duration=2.0, penetration_tol=1.0))
    assert rec.fault is not None and rec.fault.kind == FaultKind.LEFT_SCENE
    assert "outside bounds" in rec.fault.reason


@pytest.mark.parametrize("engine", ENGINES)
def test_penetration_beyond_tolerance(engine):
    rec = run_scene(_scene(), make_backend(engine), _settings(penetration_tol=1e-7))
    assert rec.fault is not None and rec.fault.kind == FaultKind.PENETRATION
    assert "> tolerance" in rec.fault.reason
    assert _judge(rec).outcome == Outcome.FAULT


def test_clean_run_has_no_fault():
    rec = run_scene(_scene(), make_backend("pymunk"), _settings())
    assert rec.fault is None and len(rec.times) == 300


def _command_after(scene, value, t0=0.05):
    """Finger 1's twist becomes ``(value, 0, 0)`` after ``t0`` seconds."""
    finger = scene.bodies[1]
    nominal = finger.twist
    bad = dataclasses.replace(
        finger, twist=lambda t, s: (value, 0.0, 0.0) if t > t0 else nominal(t, s))
    return dataclasses.replace(scene, bodies=(scene.bodies[0], bad, *scene.bodies[2:]))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("value", [np.nan, np.inf, 1e13])
def test_broken_command_is_a_fault(engine, value, tmp_path, monkeypatch):
    """MuJoCo resets the state after a NaN/huge qpos or qvel; only its warning shows it."""
    monkeypatch.chdir(tmp_path)
    rec = run_scene(_command_after(_scene(), value), make_backend(engine), _settings())
    assert rec.fault is not None, f"{engine} passed a run with a {value} command"
    assert rec.fault.time > 0.05
    assert _judge(rec).outcome == Outcome.FAULT
    if engine == "mujoco":
        assert rec.fault.kind == FaultKind.NAN
        assert "reset by MuJoCo" in rec.fault.reason
        assert ("mjWARN_BADQPOS" in rec.fault.reason) or ("mjWARN_BADQVEL" in rec.fault.reason)
    elif np.isfinite(value):
        assert rec.fault.kind == FaultKind.LEFT_SCENE  # the finger is gone, the load wins
    else:
        assert rec.fault.kind == FaultKind.NAN


def test_mujoco_bad_state_warning_needs_the_watch(tmp_path, monkeypatch):
    """Without reading MuJoCo's warning counters the same run would have no NaN fault."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(EngineWatch, "check", lambda self: None)
    rec = run_scene(_command_after(_scene(), np.nan), make_backend("mujoco"), _settings())
    assert rec.fault is None  # the broken run would have passed
    assert np.all(np.isfinite(rec.poses))  # MuJoCo's reset hid the NaN from the poses


def test_mujoco_capacity_warning(tmp_path, monkeypatch):
    """Arena too small for the contacts: MuJoCo drops them and says so in data.warning."""
    monkeypatch.chdir(tmp_path)
    real = mujoco_backend.mujoco.MjSpec

    def small_arena():
        spec = real()
        spec.memory = 2000  # bytes
        return spec

    monkeypatch.setattr(mujoco_backend.mujoco, "MjSpec", small_arena)
    rec = run_scene(_scene(), make_backend("mujoco"), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.ENGINE_WARNING
    assert "mjWARN_CNSTRFULL" in rec.fault.reason or "mjWARN_CONTACTFULL" in rec.fault.reason
    assert _judge(rec).outcome == Outcome.FAULT


class _FailingReadout(PymunkBackend):
    """pymunk backend whose post-solve contact readout fails from ``t_fail`` on."""

    t_fail = 0.1

    def _post_solve(self, arbiter, space, name):
        if self.t >= self.t_fail:
            raise RuntimeError(f"readout of {name} failed")
        super()._post_solve(arbiter, space, name)


def test_pymunk_swallowed_callback_exception(capsys):
    """pymunk's cffi callbacks swallow exceptions ("Exception ignored"); the contact reading is
    then missing, which looks like a breaking contact. The loop reports it instead."""
    rec = run_scene(_scene(), _FailingReadout(), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.ENGINE_WARNING
    assert "swallowed RuntimeError: readout of c" in rec.fault.reason
    assert rec.fault.time == pytest.approx(_FailingReadout.t_fail + 1e-3, abs=1.5e-3)
    assert _judge(rec).outcome == Outcome.FAULT
    assert "Exception ignored" not in capsys.readouterr().err  # collected, not printed


def test_swallowed_exception_would_otherwise_pass(monkeypatch):
    """The anomaly is real: without the watch the run ends with no fault at all."""
    monkeypatch.setattr(EngineWatch, "check", lambda self: None)
    rec = run_scene(_scene(), _FailingReadout(), _settings())
    assert rec.fault is None
    assert not rec.present[-1].any()  # every reading lost after t_fail


@pytest.mark.parametrize("engine", ENGINES)
def test_clean_run_raises_no_engine_alarm(engine, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rec = run_scene(_scene(), make_backend(engine), _settings())
    assert rec.fault is None and len(rec.times) == 300


def test_swallowed_exceptions_stay_with_their_thread(monkeypatch):
    """Runs in parallel threads (a thread-pool executor): each run gets only its own engine's
    swallowed exceptions, and outside a run the previously installed hook still gets them."""
    import sys
    from concurrent.futures import ThreadPoolExecutor

    import sim.run

    seen = []
    monkeypatch.setattr(sim.run, "_PREVIOUS_HOOK", [])  # restored with the hook after the test
    monkeypatch.setattr(sys, "unraisablehook", seen.append)
    with ThreadPoolExecutor(max_workers=2) as pool:
        failing = pool.submit(run_scene, _scene(), _FailingReadout(), _settings())
        clean = pool.submit(run_scene, _scene(), PymunkBackend(), _settings())
        rec_failing, rec_clean = failing.result(), clean.result()
    assert rec_failing.fault is not None and rec_failing.fault.kind == FaultKind.ENGINE_WARNING
    assert rec_clean.fault is None and len(rec_clean.times) == 300
    assert seen == []  # nothing leaked to the outer hook during the runs

    class Boom:
        def __del__(self):
            raise RuntimeError("outside any run")

    Boom()  # an unraisable exception outside a run goes to the hook installed before
    assert [str(u.exc_value) for u in seen] == ["outside any run"]
