"""MuJoCo polygon representations at acute corners: the kick, the contact point, penetration and
the stick/slip threshold, through the user's path (``qsplan simulate``'s
:func:`scenarios.runs.simulate_system`), each representation patched into the backend in turn.

Representations (:func:`sim.backends.mujoco_engine.polygon_geoms` replaced):

``edge boxes``
    one box per edge, full length, ``h = 0.02 x size`` thick inward (the simplest representation:
    its inner corner sticks out ``h cos theta`` at a vertex of angle ``theta < 90``);
``edge slabs``
    one convex prism per edge, its ends cut along the vertex bisectors (all convex meshes);
``one mesh``
    the whole polygon as one convex mesh;
``boxes + tips``
    the adopted :mod:`sim.backends.mujoco_polygon`: boxes cut back by ``h cot theta`` at acute
    vertices, a triangular prism at each acute tip.

``--features`` also runs the given representations with the environment contacts near an acute
vertex paired with a small feature of their own (a circle of radius ``0.005 x size`` touching
the vertex, or a capsule on the edge) instead of the polygon: a special case for the environment
contacts in place of one polygon for every contact.

Cases: the ladder of ``tests/data`` held by fixed contacts (fingertips at its two 30-deg
corners) and on environment surfaces, the box of ``scenarios/data`` pushed low and high, the
triangle of ``tests/sim/test_contact_features.py``, Examples 4.1 and 4.3, the stacked blocks on
their corners. Per run: the verdict, how far the workpiece moved in the first 40 ms and over
the run, the deepest penetration, the contact point's offset from the file's contact point at
the first judged step and its step-to-step noise (detrended standard deviation), the twist and
force errors, all lengths over the scene size. The threshold sweep: the held ladder at floor
friction around its rigid-body threshold ``c_x / Q_y = 0.82001``, moved or not.

    PYTHONPATH=. python benchmarks/polygon_geoms.py --out benchmarks/results/polygon_geoms.json
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from planner.files.atomic import atomic_write_json  # noqa: E402
from planner.files.system_file import load_system, system_from_dict  # noqa: E402
from sim.backends import mujoco_engine  # noqa: E402
from sim.backends.mujoco_polygon import EDGE_BOX_OF_SIZE, polygon_geoms  # noqa: E402
from sim.scene import Capsule, Circle  # noqa: E402

TESTS = ROOT / "tests" / "data"
DATA = ROOT / "scenarios" / "data"


# ---- the representations ------------------------------------------------------------------------
def _quiet(g: Any) -> Any:
    g.contype = 0
    g.conaffinity = 0
    g.mass = 0.0
    return g


def _box(body: Any, name: str, a: np.ndarray, b: np.ndarray, h: float, depth: float) -> Any:
    d = b - a
    ln = float(np.linalg.norm(d))
    m = np.array([-d[1], d[0]]) / ln
    c = 0.5 * (a + b) + 0.5 * h * m
    ang = float(np.arctan2(d[1], d[0]))
    return _quiet(body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX,
                                size=[0.5 * ln, 0.5 * h, depth], pos=[c[0], c[1], 0.0],
                                quat=[np.cos(ang / 2), 0.0, 0.0, np.sin(ang / 2)]))


def _mesh(spec: Any, body: Any, name: str, pts: list[np.ndarray], depth: float) -> Any:
    spec.add_mesh(name=name + ":mesh", uservert=[float(c) for z in (-depth, depth)
                                                 for p in pts for c in (p[0], p[1], z)])
    return _quiet(body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH,
                                meshname=name + ":mesh"))


def edge_boxes(spec: Any, body: Any, name: str, v: np.ndarray, depth: float,
               length: float) -> list[Any]:
    h = EDGE_BOX_OF_SIZE * length
    return [_box(body, f"{name}:e{e}", v[e], v[(e + 1) % len(v)], h, depth)
            for e in range(len(v))]


def _bisector_point(v: np.ndarray, k: int, h: float) -> np.ndarray:
    """The point ``h`` inside both edges at vertex ``k``."""
    p, c, q = v[k - 1], v[k], v[(k + 1) % len(v)]
    u1, u2 = (c - p) / np.linalg.norm(c - p), (q - c) / np.linalg.norm(q - c)
    m = np.array([[-u1[1], u1[0]], [-u2[1], u2[0]]])
    return c + np.linalg.solve(m, [h, h])


def edge_slabs(spec: Any, body: Any, name: str, v: np.ndarray, depth: float,
               length: float) -> list[Any]:
    h = EDGE_BOX_OF_SIZE * length
    inner = [_bisector_point(v, k, h) for k in range(len(v))]
    n = len(v)
    return [_mesh(spec, body, f"{name}:e{e}",
                  [v[e], v[(e + 1) % n], inner[(e + 1) % n], inner[e]], depth)
            for e in range(n)]


def one_mesh(spec: Any, body: Any, name: str, v: np.ndarray, depth: float,
             length: float) -> list[Any]:
    return [_mesh(spec, body, f"{name}:e0", list(v), depth)]


REPRESENTATIONS = {"edge boxes": edge_boxes, "edge slabs": edge_slabs, "one mesh": one_mesh,
                   "boxes + tips": polygon_geoms}


# ---- environment contacts on their own feature (the special case replaced) -------------------
def _acute_near(r: np.ndarray, poly: np.ndarray, size: float) -> bool:
    """``r`` at, or on an edge ending at, a vertex of interior angle below 90 deg."""
    tol = 1e-6 * size
    prv, nxt = np.roll(poly, 1, axis=0), np.roll(poly, -1, axis=0)
    acute = np.einsum("ij,ij->i", prv - poly, nxt - poly) > 0.0
    e = nxt - poly
    ln = np.linalg.norm(e, axis=1)
    d = r - poly
    along = np.einsum("ij,ij->i", d, e) / ln
    off = np.abs(e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]) / ln
    on = (off <= tol) & (along >= -tol) & (along <= ln + tol)
    return bool(np.any(on & (acute | np.roll(acute, -1))))


def _feature(r: np.ndarray, n: np.ndarray, poly: np.ndarray, size: float) -> Any:
    """A circle of radius ``0.005 size`` touching the vertex at ``r``, else a capsule of that
    radius on the edge through ``r`` (surface on the edge line)."""
    rho = 0.005 * size
    d = np.linalg.norm(poly - r, axis=1)
    k = int(np.argmin(d))
    if d[k] <= 1e-6 * size:
        return Circle(tuple((poly[k] + rho * n).tolist()), rho)
    nxt = np.roll(poly, -1, axis=0)
    for a, b in zip(poly, nxt):
        t = (b - a) / np.linalg.norm(b - a)
        if abs(t[0] * (r - a)[1] - t[1] * (r - a)[0]) <= 1e-6 * size:
            return Capsule(tuple((a + rho * n).tolist()), tuple((b + rho * n).tolist()), rho)
    raise ValueError(f"contact at {r}: not on the polygon")


def with_features(system: Any, scene: Any) -> Any:
    """``scene`` of a one-workpiece ``system`` with every environment contact near an acute
    vertex paired with its own feature (:func:`_feature`) instead of the polygon."""
    if system.n_bodies != 1 or not system.environment:
        return scene
    size = scene.length_scale
    work = scene.body("workpiece")
    poly = np.asarray(work.shapes[0].vertices, dtype=float)
    shapes = list(work.shapes)
    pairs = []
    for i, p in enumerate(scene.pairs):
        r = np.asarray(system.points[i], dtype=float)
        n = np.asarray(system.normals[i], dtype=float)
        if system.environment[i] and _acute_near(r, poly, size):
            shapes.append(_feature(r, n, poly, size))
            p = replace(p, shape_b=len(shapes) - 1)
        pairs.append(p)
    work = replace(work, shapes=tuple(shapes))
    return replace(scene, pairs=tuple(pairs), bodies=tuple(
        work if b.name == "workpiece" else b for b in scene.bodies))


# ---- runs ---------------------------------------------------------------------------------------
def run_case(system: Any, features: bool = False, duration: float | None = None
             ) -> dict[str, Any]:
    from planner.predict.feasibility import feasible_modes
    from sim.jobs import execute, job_for_system

    job = job_for_system(system, "mujoco", feasible_modes(system), duration=duration)
    if features:
        job = replace(job, scene=with_features(system, job.scene))
    cpu = time.process_time()
    res = execute(job)
    cpu = time.process_time() - cpu
    rec = res.recording
    size = job.expectation.length
    pose = rec.poses[:, 0]
    k40 = min(int(np.searchsorted(rec.times, 0.04)), len(rec.times) - 1)
    judged = rec.times > job.thresholds.settle
    pts, present = rec.points[judged], rec.present[judged]
    times = rec.times[judged]
    r0 = np.asarray(system.points, dtype=float)
    offset, noise = [], []
    for p in range(len(rec.pair_names)):
        q, ts = pts[present[:, p], p], times[present[:, p]]
        if len(q) > 2:
            basis = np.stack([np.ones_like(ts), ts], axis=1)
            resid = q - basis @ np.linalg.lstsq(basis, q, rcond=None)[0]
            noise.append(float(np.max(np.std(resid, axis=0))))
            offset.append(float(np.linalg.norm(q[0] - r0[p])))
    v = res.verdict
    m = v.motion
    return {"verdict": v.outcome.value, "agreement": v.agreement,
            "moved_40ms_of_size": float(np.linalg.norm(pose[k40, :2] - pose[0, :2])) / size,
            "moved_of_size": float(np.max(np.linalg.norm(pose[:, :2] - pose[0, :2], axis=1)))
            / size,
            "turned_rad": float(np.max(np.abs(pose[:, 2] - pose[0, 2]))),
            "depth_of_size": float(np.max(rec.depth)) / size,
            "point_offset_of_size": max(offset) / size if offset else None,
            "point_noise_of_size": max(noise) / size if noise else None,
            "twist_error": None if m is None else m.twist_error,
            "force_error": None if m is None else m.force_error,
            "cpu_s": cpu, "reason": v.reason}


#: The triangle of tests/sim/test_contact_features.py (63, 41, 76 deg) on a table, pushed on its
#: sloped side by a frictionless finger.
TRIANGLE = {
    "contacts": [
        {"point": [0.0, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
        {"point": [0.1, 0.0], "normal": [0.0, 1.0], "mu": 0.3, "environment": True},
        {"point": [0.015, 0.03], "normal": [0.894427191, -0.4472135955], "mu": 0.0}],
    "external_wrench": [0.0, -0.981, -0.981 * 0.13 / 3],
    "manipulator": {"contact_velocities": [[0.0, 0.0], [0.0, 0.0], [0.001, 0.0]]},
    "workpiece": {"polygon": [[0.0, 0.0], [0.1, 0.0], [0.03, 0.06]], "mass": 0.1}}


def cases() -> dict[str, Any]:
    return {"ladder held (fingertips at 30-deg corners)":
            load_system(TESTS / "ladder_30deg_held.json"),
            "ladder on floor and wall (environment)":
            load_system(TESTS / "ladder_30deg_stands.json"),
            "triangle on a table": system_from_dict(TRIANGLE),
            "box pushed low": load_system(DATA / "box_on_table_low.json"),
            "box pushed high": load_system(DATA / "box_on_table_high.json"),
            "Example 4.1": load_system(DATA / "example_4_1.json"),
            "Example 4.3": load_system(DATA / "example_4_3.json"),
            "stacked blocks on their corners":
            load_system(TESTS / "stacked_corners_slide_over.json")}


def threshold_sweep(mus: list[float], features: bool) -> list[dict[str, Any]]:
    """The held ladder (and, with ``features``, the ladder on environment surfaces) at floor
    friction ``mu``: moved after the settling time (mean speed over 0.5-1.5 s, over size)."""
    rows = []
    for name in ("ladder_30deg_held.json", "ladder_30deg_stands.json"):
        base = load_system(TESTS / name)
        for mu in mus:
            from planner.predict.feasibility import feasible_modes
            from sim.jobs import execute, job_for_system

            system = base.with_mu([mu, 0.0])
            job = job_for_system(system, "mujoco", feasible_modes(system), duration=1.5)
            if features:
                job = replace(job, scene=with_features(system, job.scene))
            rec = execute(job).recording
            k0 = int(np.searchsorted(rec.times, 0.5))
            k1 = len(rec.times) - 1
            speed = float(np.linalg.norm(rec.poses[k1, 0, :2] - rec.poses[k0, 0, :2])) / max(
                rec.times[k1] - rec.times[k0], 1e-9) / job.expectation.length
            rows.append({"case": name, "mu_floor": mu, "speed_of_size_per_s": speed,
                         "moved": speed > 1e-3 or rec.fault is not None})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/polygon_geoms.json")
    ap.add_argument("--representations", default=",".join(REPRESENTATIONS))
    ap.add_argument("--features", default="edge boxes,boxes + tips",
                    help="representations also run with the environment-feature special case "
                         "('' for none)")
    ap.add_argument("--sweep", default="0.78,0.80,0.81,0.815,0.825,0.83,0.84,0.86",
                    help="floor friction values of the threshold sweep ('' for none)")
    args = ap.parse_args()
    reps = [r for r in args.representations.split(",") if r]
    mus = [float(x) for x in args.sweep.split(",") if x]
    load = list(__import__("os").getloadavg())
    results: dict[str, Any] = {"load_average_1_5_15": load, "cases": [], "sweep": []}
    variants = [(r, False) for r in reps] + [(r, True) for r in args.features.split(",") if r]
    for rep, feat in variants:
        mujoco_engine.polygon_geoms = REPRESENTATIONS[rep]  # type: ignore[attr-defined]
        label = rep + (" + environment features" if feat else "")
        for name, system in cases().items():
            row = {"representation": label, "case": name, **run_case(system, feat)}
            results["cases"].append(row)
            print(f"{label:40s} {name:45s} {row['verdict']:12s} moved40ms "
                  f"{row['moved_40ms_of_size']:.1e} depth {row['depth_of_size']:.1e} offset "
                  f"{row['point_offset_of_size'] or 0:.1e} noise "
                  f"{row['point_noise_of_size'] or 0:.1e} twist {row['twist_error']} force "
                  f"{row['force_error']}", flush=True)
        for row in threshold_sweep(mus, feat):
            results["sweep"].append({"representation": label, **row})
            print(f"{label:40s} {row['case']:30s} mu {row['mu_floor']:.3f} "
                  f"{'moved' if row['moved'] else 'stayed'}", flush=True)
    mujoco_engine.polygon_geoms = polygon_geoms  # type: ignore[attr-defined]
    results["load_average_end"] = list(__import__("os").getloadavg())
    atomic_write_json(args.out, results)


if __name__ == "__main__":
    main()
