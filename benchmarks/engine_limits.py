"""What the simulators can represent: one scene, one quantity pushed to extremes, both engines.

The limits of :mod:`sim.limits` come from here.  A small scene -- a box resting on a table,
pushed sideways by a driven round fingertip, under a load -- is built with one quantity set to
an extreme value and run for 30 steps in pymunk (Chipmunk2D) and MuJoCo, each probe in its own
process (a Chipmunk assertion ends the process with SIGABRT).  Every probe is classified:

``ok``
    built and ran, no fault;
``fault:<kind>``
    built and ran, and :func:`sim.run.run_scene` reported a fault (a simulator result, not a
    crash -- but at a value a user gave, it is no physics either);
``error:<type>: <message>``
    the engine refused with a Python exception (MuJoCo's compiler: "size 1 must be positive in
    geom", "mass and inertia of moving bodies must be larger than mjMINVAL");
``abort:<signal>: <last line of stderr>``
    the process died (Chipmunk: "Moment of Inertia must be positive");
``hang``
    no answer within 60 s.

Axes: the scene's offset from the origin; one polygon vertex far from its body; its size
(every length scaled, ``length_scale`` too; with the box's mass fixed, and at a fixed areal
density); the box mass; its explicit moment of inertia (absolute, and relative to mass x
size^2); the load's acceleration; a short capsule and a short polygon edge; the box's aspect
ratio (a sliver); the finger radius relative to the scene; the friction coefficient; and
degenerate shapes (a repeated vertex, a collinear vertex, a non-convex outline, a zero-length
capsule, a zero prismatic axis, a triangle sliver).

    PYTHONPATH=. python benchmarks/engine_limits.py --out benchmarks/results/engine_limits.json

prints one Markdown table per axis (docs/robustness.md, "Engine limits").
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

AXES: dict[str, list[Any]] = {
    "offset [m]": [0.0, 1e3, 1e6, 1e9, 1e10, 3e10, 1e12, 1e15, 1e20, 1e50, 1e100, 1e150,
                   1e154, 1e155, 1e160, 1e200, 1e300],
    "far vertex [m]": [1.0, 1e10, 1e50, 1e100, 1e150, 1e152, 1e153, 1e154, 1e155, 1e160,
                       1e200, 1e300],
    "size [m]": [1e-300, 1e-160, 1e-150, 1e-100, 1e-50, 1e-20, 1e-16, 1e-15, 1e-12, 1e-9,
                 1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9, 1e10, 1e12, 1e20, 1e50, 1e100, 1e150,
                 1e155, 1e160],
    "mass [kg]": [5e-324, 1e-300, 1e-100, 1e-20, 1e-16, 1e-15, 1e-14, 1e-12, 1e-9, 1e-6, 1.0,
                  1e6, 1e12, 1e20, 1e50, 1e100, 1e200, 1e290, 1e296, 1e300, 1e305, 1e308],
    "inertia [kg m^2]": [5e-324, 1e-300, 1e-100, 1e-20, 1e-16, 1e-15, 1e-14, 1e-12, 1e-6, 1.0,
                         1e20, 1e100, 1e300],
    "size at 10 kg/m^2 [m]": [1e-2, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6],
    "inertia / (mass size^2)": [1e-12, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 3e-4, 1e-3, 3e-3,
                                1e-2, 1.0, 1e2,
                                1e4, 1e6, 1e9, 1e12],
    "load / mass [m/s^2]": [1e3, 1e6, 1e9, 1e10, 1e11, 1e12, 1e15, 1e20, 1e100],
    "capsule length / size": [0.0, 1e-20, 1e-16, 1e-15, 1e-14, 1e-12, 1e-9, 1e-6],
    "edge length / size": [0.0, 1e-20, 1e-16, 1e-15, 1e-14, 1e-12, 1e-9, 1e-6, 1e-4],
    "aspect (height / width)": [1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-9, 1e-12, 1e-15, 1e-16,
                                1e-17],
    "finger radius / size": [1e-300, 1e-100, 1e-20, 1e-16, 1e-15, 1e-12, 1e-9, 1e-6, 1e-4,
                             1e-3],
    "mu": [0.0, 1e-300, 1e-10, 1e6, 1e10, 1e20, 1e50, 1e100, 1e300],
    "polygon": ["repeated vertex", "collinear vertex", "non-convex", "zero-length capsule",
                "zero prismatic axis", "triangle sliver 1e-12"],
}


def scene(axis: str, value: Any):  # type: ignore[no-untyped-def]
    """The probe scene with ``axis`` set to ``value`` (every other quantity at its default:
    a 0.1 m box of 0.1 kg at the origin on a table, mu 0.5, a 5 mm finger at 1 mm/s)."""
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

    size = value if axis in ("size [m]", "size at 10 kg/m^2 [m]") else 0.1
    off = value if axis == "offset [m]" else 0.0
    mass = (value if axis == "mass [kg]" else 10 * size ** 2 if axis.startswith("size at")
            else 0.1)
    inertia = (value if axis == "inertia [kg m^2]" else value * mass * size ** 2
               if axis == "inertia / (mass size^2)" else None)
    gravity = value if axis == "load / mass [m/s^2]" else 9.81
    aspect = value if axis == "aspect (height / width)" else 0.5
    radius = (value if axis == "finger radius / size" else 0.05) * size
    mu = value if axis == "mu" else 0.5
    w, h = size, size * aspect
    box = [(-w, 0.0), (w, 0.0), (w, 2 * h), (-w, 2 * h)]
    if axis == "far vertex [m]":
        box = [(-w, 0.0), (value, 0.0), (w, 2 * h), (-w, 2 * h)]
    elif value == "repeated vertex":
        box = [box[0], box[1], box[1], box[2], box[3]]
    elif value == "collinear vertex":
        box = [box[0], (0.0, 0.0), box[1], box[2], box[3]]
    elif value == "non-convex":
        box = [box[0], box[1], box[2], (0.0, 0.2 * h), box[3]]
    elif axis == "edge length / size":
        box = [box[0], box[1], (w, value * w), box[2], box[3]]
    elif value == "triangle sliver 1e-12":
        box = [(-w, 0.0), (w, 0.0), (0.0, 1e-12 * w)]
    pre = 5e-5 * size
    table = Body("table", (Polygon(((-10 * w, -size), (10 * w, -size), (10 * w, pre),
                                    (-10 * w, pre))),), pose=(off, 0.0, 0.0),
                 kind=BodyKind.STATIC)
    work = Body("box", (Polygon(tuple(box)),), mass=mass, inertia=inertia, com=(0.0, h),
                pose=(off, 0.0, 0.0))
    speed = 1e-3 * size
    finger = Body("finger", (Circle((0.0, 0.0), radius),),
                  pose=(off - w - radius + pre, h, 0.0), kind=BodyKind.DRIVEN,
                  twist=lambda t, s: (speed, 0.0, 0.0))
    bodies = [table, work, finger]
    joints: list[Any] = []
    pairs = [ContactPair("support", "table", "box", mu), ContactPair("push", "finger", "box", mu)]
    if value == "zero-length capsule" or axis == "capsule length / size":
        length = 0.0 if value == "zero-length capsule" else value * size
        bodies[2] = Body("finger", (Capsule((0.0, -0.5 * length), (0.0, 0.5 * length),
                                            radius),),
                         pose=finger.pose, kind=BodyKind.DRIVEN, twist=finger.twist)
    if value == "zero prismatic axis":
        bodies[2] = Body("finger", (Circle((0.0, 0.0), radius),), pose=finger.pose, mass=0.01)
        joints = [Joint("slide", "finger", JointKind.PRISMATIC, anchor=finger.pose[:2],
                        control=Control.VELOCITY, command=lambda t, s: speed, axis=(0.0, 0.0))]
    span = 20 * size
    return Scene(bodies=tuple(bodies), pairs=tuple(pairs), joints=tuple(joints),
                 loads=(Load("box", (0.0, -mass * gravity)),),
                 bounds=(off - span, -span, off + span, span), length_scale=size)


def child(engine: str, axis: str, value: Any) -> dict[str, Any]:
    """Run one probe in this process (called in a subprocess)."""
    from sim.backends import make_backend
    from sim.run import RunSettings, run_scene

    try:
        sc = scene(axis, value)
    except Exception as exc:  # noqa: BLE001 - the classification is the point
        return {"result": f"scene refused: {type(exc).__name__}: {exc}"}
    size = sc.length_scale
    settings = RunSettings(duration=0.6, dt=1e-3, slip_speed=1e-5 * size,
                           penetration_tol=0.1 * size)
    try:
        rec = run_scene(sc, make_backend(engine), settings)
    except Exception as exc:  # noqa: BLE001
        return {"result": f"error:{type(exc).__name__}: {' '.join(str(exc).split())[:160]}"}
    if rec.fault is not None:
        return {"result": f"fault:{rec.fault.kind.value}", "detail": rec.fault.detail[:160]}
    return {"result": physics(sc, rec)}


def physics(sc, rec) -> str:  # type: ignore[no-untyped-def]
    """``ok`` when the run shows the physics of the scene -- the table carries the box's
    weight and the box moves with the finger over the last third of the run (each within
    25 %) -- else ``wrong: ...``."""
    import numpy as np

    weight = -sc.loads[0].force[1]
    half = 2 * len(rec.times) // 3
    support = float(np.mean(rec.normal_force[half:, 0]))
    dt = rec.times[-1] - rec.times[half]
    moved = (rec.poses[-1, 1, 0] - rec.poses[half, 1, 0]) / dt
    speed = 1e-3 * sc.length_scale
    wrong = []
    if not abs(support - weight) <= 0.25 * weight:
        wrong.append(f"support force {support:.3g} N vs weight {weight:.3g} N")
    if not abs(moved - speed) <= 0.25 * speed:
        wrong.append(f"box speed {moved:.3g} m/s vs finger {speed:.3g} m/s")
    return "ok" if not wrong else "wrong: " + "; ".join(wrong)


def probe(engine: str, axis: str, value: Any) -> dict[str, Any]:
    """One probe in its own process."""
    arg = json.dumps([engine, axis, value])
    try:  # MuJoCo writes MUJOCO_LOG.TXT into the working folder
        res = subprocess.run([sys.executable, __file__, "--child", arg], capture_output=True,
                             text=True, timeout=60, cwd=tempfile.gettempdir(),
                             env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    except subprocess.TimeoutExpired:
        return {"result": "hang"}
    if res.returncode < 0:
        last = (res.stderr.strip().splitlines() or [""])[-1]
        for line in res.stderr.splitlines():
            if "Aborting" in line or "Assertion" in line or "Failed" in line:
                last = line.strip()
                break
        return {"result": f"abort:{signal.Signals(-res.returncode).name}: {last[:160]}"}
    try:
        return json.loads(res.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        return {"result": f"exit {res.returncode}: {res.stderr.strip()[-160:]}"}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--axis", action="append", help="only these axes")
    ap.add_argument("--out", help="JSON file of every probe")
    args = ap.parse_args()
    if args.child:
        engine, axis, value = json.loads(args.child)
        print(json.dumps(child(engine, axis, value)))
        return 0
    t0 = time.perf_counter()
    rows = []
    for axis, values in AXES.items():
        if args.axis and axis not in args.axis:
            continue
        print(f"\n### {axis}\n\n| value | pymunk | MuJoCo |\n|---|---|---|")
        for value in values:
            got = {e: probe(e, axis, value) for e in ("pymunk", "mujoco")}
            rows.append({"axis": axis, "value": value, **got})
            print(f"| {value} | {got['pymunk']['result']} | {got['mujoco']['result']} |",
                  flush=True)
    print(f"\n{len(rows)} probes x 2 engines in {time.perf_counter() - t0:.0f} s")
    if args.out:
        from planner.files.atomic import atomic_write_json

        atomic_write_json(args.out, {"probes": rows, "command": " ".join(sys.argv)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
