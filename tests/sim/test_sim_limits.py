"""sim.limits.check_scene: scenes beyond what pymunk and MuJoCo represent are bad input
(``InputError`` naming the body or shape, the value and the limit), refused before an engine
aborts the process, raises from its compiler or turns the state into NaN."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from planner.errors import InputError
from sim.limits import (
    ACCEL_MAX,
    COORD_MAX,
    COORD_OF_SCALE,
    LENGTH_SCALE_MIN,
    MASS_MAX,
    MASS_MIN,
    THICKNESS_OF_SCALE,
    check_scene,
    effective_inertias,
    polygon_inertia,
)
from sim.scene import (
    Body,
    BodyKind,
    Capsule,
    Circle,
    ContactPair,
    Control,
    Joint,
    JointKind,
    Load,
    Polygon,
    Scene,
)

ROOT = Path(__file__).resolve().parents[2]


def box(w=0.1, h=0.05, far=None):
    verts = [(-w, -h), (w, -h), (w, h), (-w, h)]
    if far is not None:
        verts = [(0.0, 0.0), (far, 0.0), (0.0, far)]
    return Polygon(tuple(verts))


def scene(work=None, finger=None, scale=0.1, loads=None, joints=(), pairs=None, offset=0.0):
    table = Body("table", (box(1.0, 0.05),), pose=(offset, -0.1, 0.0), kind=BodyKind.STATIC)
    work = work or Body("work", (box(),), mass=0.1, pose=(offset, 0.0, 0.0))
    finger = finger or Body("finger", (Circle((0.0, 0.0), 0.005),),
                            pose=(offset - 0.105, 0.0, 0.0), kind=BodyKind.DRIVEN,
                            twist=lambda t, s: (1e-4, 0.0, 0.0))
    pairs = pairs or (ContactPair("support", "table", "work", 0.5),
                      ContactPair("push", "finger", "work", 0.5))
    return Scene(bodies=(table, work, finger), pairs=pairs, joints=joints,
                 loads=loads if loads is not None else (Load("work", (0.0, -0.981)),),
                 bounds=(offset - 2, -2, offset + 2, 2), length_scale=scale)


def test_a_plain_scene_passes():
    check_scene(scene())


@pytest.mark.parametrize("make,message", [
    (lambda: scene(work=Body("work", (box(far=1e160),), mass=0.1)),
     "body 'work' shape 1 (polygon): expected coordinates of magnitude at most 1e+10 m"),
    (lambda: scene(offset=1e9),
     f"expected coordinates of magnitude at most {COORD_OF_SCALE:.3g} times the scene's "
     "length scale"),
    (lambda: scene(work=Body("work", (box(),), mass=5e-324)),
     f"body 'work': expected a mass in [{MASS_MIN:g}, {MASS_MAX:.3g}] kg (what both "
     "simulators represent), got 4.94066e-324 kg"),
    (lambda: scene(work=Body("work", (box(),), mass=1e300)), "got 1e+300 kg"),
    (lambda: scene(work=Body("work", (box(),), mass=0.1, inertia=1e-20)),
     "expected a rotational inertia (pymunk) finite and at least 1e-15 kg m^2, got 1e-20"),
    (lambda: scene(work=Body("work", (box(),), mass=0.1, inertia=1e-6)),
     "expected a rotational inertia (pymunk) at least 0.005 times mass x extent^2"),
    (lambda: scene(work=Body("work", (box(),), mass=0.1, inertia=1e12)),
     "expected a rotational inertia (mujoco) at most 1e+08 times mass x extent^2"),
    (lambda: scene(work=Body("work", (Polygon(((-0.1, -0.05), (0.1, -0.05), (0.1, -0.05),
                                               (0.1, 0.05), (-0.1, 0.05))),), mass=0.1)),
     "expected distinct consecutive vertices (a zero-length edge cannot be simulated), got "
     "vertex 3 repeating vertex 2 at (0.1, -0.05)"),
    (lambda: scene(work=Body("work", (Polygon(((-0.1, -0.05), (0.1, -0.05), (0.1, 0.05),
                                               (0.0, -0.03), (-0.1, 0.05))),), mass=0.1)),
     "expected a convex polygon (pymunk would simulate its convex hull), got a reflex vertex"),
    (lambda: scene(work=Body("work", (box(0.1, 1e-4),), mass=0.1)),
     f"expected a polygon at least {THICKNESS_OF_SCALE:g} times the scene's length scale "
     "thick"),
    (lambda: scene(finger=Body("finger", (Capsule((0.0, 0.0), (0.0, 0.0), 0.005),),
                               pose=(-0.105, 0.0, 0.0), kind=BodyKind.DRIVEN,
                               twist=lambda t, s: (0, 0, 0))),
     "body 'finger' shape 1 (capsule): expected a capsule longer than 1e-07 m"),
    (lambda: scene(finger=Body("finger", (Circle((0.0, 0.0), 0.005),),
                               pose=(-0.105, 0.0, 0.0), mass=0.01),
                   joints=(Joint("slide", "finger", JointKind.PRISMATIC, (-0.105, 0.0),
                                 Control.VELOCITY, lambda t, s: 0.0, axis=(0.0, 0.0)),)),
     "joint 'slide': expected a unit axis (MuJoCo: 'axis too small'), got (0, 0)"),
    (lambda: scene(loads=(Load("work", (0.0, -1e12)),)),
     f"load on body 'work': expected an acceleration (force / mass, moment / inertia) at "
     f"most {ACCEL_MAX:g}"),
    (lambda: scene(scale=1e-7), f"scene: expected a length scale in [{LENGTH_SCALE_MIN:g}"),
    (lambda: scene(pairs=(ContactPair("support", "table", "work", 1e100),)),
     "pair 'support': expected a friction coefficient at most 1e+06, got 1e+100"),
    (lambda: scene(work=Body("work", (box(),), mass=0.1, pose=(float("nan"), 0.0, 0.0))),
     "body 'work' pose: expected coordinates finite, got nan"),
])
def test_limits_are_named_with_value_and_limit(make, message):
    with pytest.raises(InputError) as exc:
        check_scene(make())
    assert message in str(exc.value)
    assert "expected" in str(exc.value) and "got" in str(exc.value)


def test_coordinates_beyond_coord_max_at_any_scale():
    with pytest.raises(InputError, match="at most 1e\\+10 m"):
        check_scene(scene(offset=2 * COORD_MAX, scale=1e5))


def test_inertias_are_what_the_backends_compute():
    """pymunk's moment_for_poly and MuJoCo's mass L^2 / 6 (the backends' formulas)."""
    import pymunk

    body = Body("w", (box(0.1, 0.05),), mass=0.3, com=(0.02, -0.01))
    got = effective_inertias(body, 0.1)
    local = [(x - 0.02, y + 0.01) for x, y in body.shapes[0].vertices]
    assert got["pymunk"] == pytest.approx(pymunk.moment_for_poly(0.3, local), rel=1e-12)
    assert got["mujoco"] == pytest.approx(0.3 * 0.01 / 6)
    verts = [(0.0, 0.0), (1e160, 0.0), (0.0, 1e160)]  # pymunk: NaN; the true value: beyond
    assert polygon_inertia(verts, 1.0, (0.0, 0.0)) == float("inf")
    assert pymunk.moment_for_poly(1.0, verts) != pymunk.moment_for_poly(1.0, verts)
    assert pymunk.moment_for_poly(1.0, [(0.0, 0.0), (1e3, 0.0), (0.0, 1e3)]) == \
        pytest.approx(polygon_inertia([(0.0, 0.0), (1e3, 0.0), (0.0, 1e3)], 1.0, (0, 0)))


SCENES = {
    "far vertex": "s = scene(work=Body('work', (box(far=1e160),), mass=0.1))",
    "tiny mass": "s = scene(work=Body('work', (box(),), mass=5e-324))",
    "repeated vertex": "s = scene(work=Body('work', (Polygon(((-0.1, -0.05), (0.1, -0.05), "
                       "(0.1, -0.05), (0.1, 0.05), (-0.1, 0.05))),), mass=0.1))",
    "zero capsule": "s = scene(finger=Body('finger', (Capsule((0.0, 0.0), (0.0, 0.0), 0.005),),"
                    " pose=(-0.105, 0.0, 0.0), kind=BodyKind.DRIVEN, twist=lambda t, s: (0,0,0)))",
}


def _scene_source(kind: str) -> str:
    return (f"import sys\nsys.path.insert(0, {str(ROOT / 'tests' / 'sim')!r})\n"
            "from test_sim_limits import scene, box, Body, Polygon, Capsule, BodyKind\n"
            + SCENES[kind] + "\n")


@pytest.mark.parametrize("engine,kind,outcome", [
    ("pymunk", "far vertex", "SIGABRT"),
    ("mujoco", "tiny mass", "mass and inertia of moving bodies must be larger than mjMINVAL"),
    ("pymunk", "tiny mass", "Dynamic bodies must have a mass > 0"),
    ("mujoco", "zero capsule", "fromto points too close in geom"),
])
def test_the_engines_fail_without_the_check(engine, kind, outcome, tmp_path):
    """Without check_scene the engine aborts the process (SIGABRT) or raises from its compiler
    (what reached users as an internal fault); with it, the same scene is an InputError."""
    code = "exec(src)\n" + (
        "from sim.backends import make_backend\n"
        "from sim.run import RunSettings, run_scene\n"
        f"run_scene(s, make_backend({engine!r}), RunSettings(duration=0.003, dt=1e-3, "
        "slip_speed=1e-6, penetration_tol=1e-2))\n")
    src = _scene_source(kind)
    res = subprocess.run([sys.executable, "-c", f"src = {src!r}\n" + code], cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True,
                         text=True, timeout=120)
    if outcome == "SIGABRT":
        assert res.returncode == -signal.SIGABRT, res.stderr[-500:]
        assert "Moment of Inertia must be positive" in res.stderr
    else:
        assert res.returncode == 1 and outcome in res.stderr, res.stderr[-500:]
    namespace: dict = {}
    exec(src, namespace)  # the same scene, checked first
    with pytest.raises(InputError):
        check_scene(namespace["s"])


def test_shipped_scene_kinds_pass(example_41):
    """A system scene, a hand scene and a chain scene as the builders make them."""
    from sim.scenes.system import system_scene

    check_scene(system_scene(example_41))
    check_scene(dataclasses.replace(scene(), length_scale=1.0))
