"""Simulator trouble is reported as a fault with its reason, never as a pass."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from planner.io import load_system
from scenarios.paper_sims import DATA, _status
from sim.classify import Outcome, Thresholds, compare, observed_modes
from sim.paper_scene import FingertipSpec, example_scene, scaled_system
from sim.run import FaultKind, RunSettings, run_scene
from sim.scene import Load, make_backend

ENGINES = ("pymunk", "mujoco")
SPEED = 1e-3


def _scene(finger: FingertipSpec | None = None, mu=(0.2, 0.3, 0.1)):
    system = scaled_system(load_system(DATA / "example_4_1.json"), 0.01, SPEED).with_mu(mu)
    return example_scene(system, speed=SPEED, mass=0.01, finger=finger)


def _settings(**kw):
    base = dict(duration=0.3, dt=1e-3, slip_speed=0.05 * SPEED, penetration_tol=1e-3)
    base.update(kw)
    return RunSettings(**base)


def _judge(rec):
    th = Thresholds.for_drive(SPEED, 1.0, settle=0.0)
    return compare(rec, observed_modes(rec, th), ["S+1 S-2 S-3"], th)


@pytest.mark.parametrize("engine", ENGINES)
def test_nan_load_is_a_fault(engine, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes MUJOCO_LOG.TXT into the working directory
    scene = _scene()
    scene = dataclasses.replace(scene, loads=(Load("workpiece", (np.nan, -1.0), 0.0),))
    rec = run_scene(scene, make_backend(engine), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.NAN
    cmp = _judge(rec)
    assert cmp.outcome == Outcome.FAULT and "nan" in cmp.reason
    assert not _status(cmp.outcome.value, "agree")
    assert not _status(cmp.outcome.value, "disagree")


@pytest.mark.parametrize("engine", ENGINES)
def test_contact_lost_at_start(engine):
    rec = run_scene(_scene(FingertipSpec(overlap=-1e-3)), make_backend(engine), _settings())
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
