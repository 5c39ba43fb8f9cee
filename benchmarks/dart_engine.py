"""DART (:mod:`sim.backends.dart_engine`) measured next to pymunk and MuJoCo, every run through
the one pipeline (``scenarios.runs`` / ``sim.jobs``, what ``qsplan simulate``, ``validate`` and
``scenarios run`` execute) with the settings table's rows (:data:`sim.settings.SETTINGS`), the
engines' verdicts taken in the same run.

* ``incline``: a box on a static block tilted by ``a`` at mu = 0.3 (the backends alone, no
  pipeline): creep below ``atan(mu)``, the stick/slip threshold by bisection, the sliding
  acceleration against ``g (sin a - mu cos a)``; ``dart-defaults`` puts DART's own sleeping and
  Dantzig solver back;
* ``ladder``: the static question of ``tests/data/ladder_30deg_stands.json`` (stands iff the
  floor's mu >= 0.82001) at floor friction just below and above the threshold, through
  :func:`scenarios.runs.simulate_system`;
* ``ruler``: Sec. 5.1 from :func:`sim.jobs.job_for_ruler` (the table's ruler row: its speed and
  step), judged against the planner's switch positions, run to just past the ``--switches``-th
  predicted switch (the rest of a run only adds switches);
* ``scenarios``: registered simulator scenarios by :func:`scenarios.runs.run_scenario`;
* ``users``: ``--points`` user-geometry system files of each kind of
  :mod:`planner.sweeps.user_systems` (acute corners, force-indeterminate supports, stacked
  blocks on corners, static ladders and inclines) by the validation campaign's
  ``task_row`` (its seeds, negative controls and "where" classes), every engine on the same
  files, with the pairwise engine-engine agreement.

Wall times are per run on whatever load the machine has; ratios between engines are taken from
the same run. Nothing is asserted here (tests/sim/test_dart_backend.py).

    PYTHONPATH=. python benchmarks/dart_engine.py ladder users --points 3
    PYTHONPATH=. python benchmarks/dart_engine.py ruler --engines pymunk,dart --switches 5
    PYTHONPATH=. python benchmarks/dart_engine.py scenarios --engines dart
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import atomic_write_json
from sim.run import RunSettings, run_scene
from sim.scene import Body, BodyKind, ContactPair, Load, Polygon, Scene, preload_depth

ROOT = Path(__file__).resolve().parents[1]
G, L, MU = 9.81, 0.1, 0.3


def backend(engine: str) -> Any:
    """``engine``'s backend (:func:`sim.backends.make_backend`); ``dart-defaults``: the DART
    backend with DART's own defaults put back (sleeping on, Dantzig pivoting with the PGS
    fallback) -- what a plain DART script gets."""
    from sim.backends import make_backend

    if engine != "dart-defaults":
        return make_backend(engine)
    import dartpy

    from sim.backends.dart_engine import DartBackend

    class DartDefaults(DartBackend):
        name = "dart-defaults"

        def build(self, scene: Scene) -> None:
            super().build(scene)
            sleep = self.world.getDeactivationOptions()
            sleep.mEnabled = True
            self.world.setDeactivationOptions(sleep)
            self._default_world = dartpy.simulation.World()  # owns DART's default solver
            self.world.getConstraintSolver().setBoxedLcpSolver(
                self._default_world.getConstraintSolver().getBoxedLcpSolver())

    return DartDefaults()


# -- incline ---------------------------------------------------------------------------------
def incline(angle_deg: float, mu: float = MU) -> Scene:
    a = np.radians(angle_deg)
    half = (L / 2, L / 4)
    box = Polygon(((-half[0], -half[1]), (half[0], -half[1]), half, (-half[0], half[1])))
    c = (L / 4 - preload_depth(L)) * np.array([-np.sin(a), np.cos(a)])
    ground = Polygon(((-5 * L, -L / 2), (5 * L, -L / 2), (5 * L, 0.0), (-5 * L, 0.0)))
    return Scene(bodies=(Body("ground", (ground,), kind=BodyKind.STATIC, pose=(0.0, 0.0, a)),
                         Body("box", (box,), mass=1.0, pose=(c[0], c[1], a))),
                 pairs=(ContactPair("c", "ground", "box", mu_static=mu),),
                 loads=(Load("box", (0.0, -G)),), length_scale=L, only_pairs=True)


def slip(engine: str, angle_deg: float, duration: float = 0.5) -> np.ndarray:
    rec = run_scene(incline(angle_deg), backend(engine),
                    RunSettings(duration=duration, dt=1e-3, slip_speed=1e-6,
                                penetration_tol=0.01 * L))
    return np.where(rec.present[:, 0], rec.slip_velocity[:, 0], np.nan)  # + down the slope


def sleeping_row() -> dict[str, Any]:
    """The incline at +0.01 deg with the weight given as DART's gravity (as a plain DART script
    has it) and DART's default sleeping on: slip after 0.5 s and 1 s over the closed form."""
    import dartpy

    from sim.backends.dart_engine import DartBackend

    class Sleepy(DartBackend):
        def build(self, scene: Scene) -> None:
            super().build(scene)
            self.world.setGravity([0.0, -G, 0.0])
            sleep = self.world.getDeactivationOptions()
            sleep.mEnabled = True
            self.world.setDeactivationOptions(sleep)

    th = float(np.degrees(np.arctan(MU))) + 0.01
    scene = incline(th)
    scene = Scene(bodies=scene.bodies, pairs=scene.pairs, length_scale=L, only_pairs=True)
    rec = run_scene(scene, Sleepy(), RunSettings(duration=1.0, dt=1e-3, slip_speed=1e-6,
                                                 penetration_tol=0.01 * L))
    a = G * (np.sin(np.radians(th)) - MU * np.cos(np.radians(th)))
    k = int(np.searchsorted(rec.times, 0.5))
    return {"dartpy": dartpy.__version__, "delta_deg": 0.01,
            "slip_of_closed_form_at_0.5s": float(rec.slip_velocity[k, 0] / (a * rec.times[k])),
            "slip_of_closed_form_at_1s": float(rec.slip_velocity[-1, 0] / (a * rec.times[-1])),
            "present_fraction": float(rec.present.mean())}


def incline_rows(engines: list[str]) -> list[dict[str, Any]]:
    th = float(np.degrees(np.arctan(MU)))
    rows = []
    for engine in engines:
        t0 = time.perf_counter()
        creep = {f"{d:g}": float(np.nanmax(np.abs(slip(engine, th + d)[250:])))
                 for d in (-1.0, -0.01, -0.001)}
        frozen = slip(engine, th + 0.01, 1.0)  # 1.8e-3 m/s^2: below 1 cm/s for the whole run
        a01 = G * (np.sin(np.radians(th + 0.01)) - MU * np.cos(np.radians(th + 0.01)))
        lo, hi = th - 0.2, th + 0.2
        for _ in range(18):  # 0.4 deg / 2^18 = 1.5e-6 deg
            mid = 0.5 * (lo + hi)
            if slip(engine, mid)[-1] > 1e-6:
                hi = mid
            else:
                lo = mid
        accel = {}
        for d in (0.01, 1.0, 5.0):
            a = np.radians(th + d)
            v = slip(engine, th + d)
            t = 1e-3 * np.arange(1, len(v) + 1)
            k = slice(len(v) // 2, None)
            measured = float(np.polyfit(t[k], v[k], 1)[0])
            accel[f"{d:g}"] = measured / (G * (np.sin(a) - MU * np.cos(a))) - 1.0
        rows.append({"engine": engine, "mu": MU, "atan_mu_deg": th,
                     "creep_m_per_s_at_delta_deg": creep,
                     "threshold_minus_atan_mu_deg": 0.5 * (lo + hi) - th,
                     "threshold_bracket_deg": hi - lo,
                     "sliding_accel_rel_error_at_delta_deg": accel,
                     "slip_after_1s_at_0.01_deg_of_closed_form": float(frozen[-1] / a01),
                     "wall_s": round(time.perf_counter() - t0, 1)})
        print(rows[-1], flush=True)
    return rows


# -- through the pipeline -----------------------------------------------------------------------
def ladder_rows(engines: list[str], mus: list[float]) -> list[dict[str, Any]]:
    """The ladder at floor friction ``mus`` (threshold 0.82001) in each engine."""
    from planner.files.system_file import load_system
    from scenarios.runs import simulate_system

    base = load_system(ROOT / "tests" / "data" / "ladder_30deg_stands.json")
    rows = []
    for mu in mus:
        for engine in engines:
            res = simulate_system(base.with_mu([mu, 0.0]), engine, name=f"ladder mu={mu}")
            s, rec = res.summary, res.recording
            late = rec.times > res.job.thresholds.settle
            rows.append({"mu_floor": mu, "engine": engine, "status": s.verdict.outcome.value,
                         "predicted": s.predicted["labels"], "final": s.observed["final"],
                         "floor_slip_max_m_per_s": float(np.nanmax(np.abs(
                             rec.slip_velocity[late, 0]))) if late.any() else None,
                         "steps": len(rec.times), "wall_s": round(s.wall_time_s, 2)})
            print(rows[-1], flush=True)
    return rows


def ruler_rows(engines: list[str], pairs: list[tuple[float, float]], switches: int
               ) -> list[dict[str, Any]]:
    """The ruler at each ``(mu_s, mu_k)`` in each engine, to just past the ``switches``-th
    switch the planner predicts; relative errors of the observed switch positions."""
    from dataclasses import replace

    from planner.predict.ruler import THICKNESS_RATIO, predicted_switches
    from sim.jobs import execute, job_for_ruler

    length = 0.1
    rows = []
    for mu_s, mu_k in pairs:
        pos, who = predicted_switches(0.4 * length, 0.25 * length, 1.0,
                                      THICKNESS_RATIO * length, mu_s, mu_k,
                                      min_distance=0.015 * length)
        need = min(switches, len(pos))
        for engine in engines:
            job = job_for_ruler(engine, mu_s=mu_s, mu_k=mu_k, positions=pos, sliders=who,
                                required=need, tolerance=0.01)
            v = job.parameters["speed_m_per_s"]
            other = (0.25 if who[0] == 0 else 0.4) * length  # the first sticking finger
            gap = pos[need - 1] + (pos[need - 2] if need > 1 else other)
            travel = 0.65 * length - gap + 0.05 * pos[need - 1]
            job = replace(job, run=replace(job.run, duration=min(job.run.duration,
                                                                 travel / (2 * v))))
            res = execute(job)
            s = res.summary
            errors = s.observed.get("relative_errors", [])
            rows.append({"mu_s": mu_s, "mu_k": mu_k, "engine": engine,
                         "status": s.verdict.outcome.value, "speed_m_per_s": v,
                         "dt_s": job.run.dt, "predicted_m": list(pos[:need]),
                         "observed_m": s.observed.get("switch_positions_m", [])[:need],
                         "relative_errors": errors[:need],
                         "creep_m_per_s": s.observed.get("creep_m_per_s"),
                         "steps": s.parameters["steps"], "wall_s": round(s.wall_time_s, 1)})
            print(rows[-1], flush=True)
    return rows


def scenario_rows(engines: list[str], names: list[str] | None) -> list[dict[str, Any]]:
    """Registered simulator scenarios (``names``, default all) in each engine."""
    import tempfile

    from scenarios.registry import all_scenarios
    from scenarios.runs import run_scenario

    rows = []
    for name, sc in all_scenarios().items():
        if sc.spec is None or (names and name not in names):
            continue
        for engine in engines:
            with tempfile.TemporaryDirectory() as tmp:
                s = run_scenario(sc, tmp, engine=engine, render=False)
            rows.append({"scenario": name, "engine": engine, "expect": s["expect"],
                         "status": s["status"], "passed": s["passed"],
                         "agreement": s.get("agreement"), "reason": s.get("reason"),
                         "steps": s["parameters"].get("steps"),
                         "wall_s": round(s.get("wall_time_s", 0.0), 1)})
            print({k: rows[-1][k] for k in ("scenario", "engine", "status", "passed",
                                            "wall_s")}, flush=True)
    return rows


def user_rows(engines: list[str], kinds: list[str], points: int, seed: int
              ) -> dict[str, Any]:
    """``points`` files of each user-geometry kind through the validation campaign's
    ``task_row`` in every engine; its table and the pairwise engine-engine agreement."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from validation_campaign import table, task_row, where

    rows = []
    for i in range(points):
        for kind in kinds:
            for engine in engines:
                row = task_row((kind, i, engine, seed))
                row.pop("file", None)
                rows.append(row)
                print({k: row.get(k) for k in ("case", "index", "engine", "status",
                                               "control_status", "wall_s")}, flush=True)
    pairs: dict[str, Counter[str]] = {}
    by_point: dict[tuple[str, int], dict[str, dict[str, Any]]] = {}
    for r in rows:
        by_point.setdefault((r["case"], r["index"]), {})[r["engine"]] = r
    for per in by_point.values():
        for a in engines:
            for b in engines[engines.index(a) + 1:]:
                if a in per and b in per:
                    at = where(per[a]) if "near_boundary" in per[a] else "refused"
                    c = pairs.setdefault(f"{a}-{b} {at}", Counter())
                    c["n"] += 1
                    c["same"] += per[a]["status"] == per[b]["status"]
    return {"rows": rows, "table": table([r for r in rows if r["status"] != "refused"]),
            "engine_pairs": {k: dict(v) for k, v in pairs.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("parts", nargs="+",
                    choices=("incline", "ladder", "ruler", "scenarios", "users"))
    ap.add_argument("--engines", default="pymunk,mujoco,dart",
                    help="comma-separated; 'dart-defaults' (incline only): DART's own defaults")
    ap.add_argument("--points", type=int, default=3, help="users: files per kind")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--kinds", default="acute,supports,stacked,static")
    ap.add_argument("--ladder-mu", default="0.80,0.84")
    ap.add_argument("--ruler-pairs", default="0.5/0.3,0.8/0.5")
    ap.add_argument("--switches", type=int, default=5)
    ap.add_argument("--scenarios", default="", help="comma-separated names (default all)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/dart_engine.json"))
    args = ap.parse_args()
    engines = args.engines.split(",")
    out = Path(args.out)
    result: dict[str, Any] = json.loads(out.read_text()) if out.exists() else {}
    import dartpy

    result["versions"] = {"dartpy": dartpy.__version__}
    for part in args.parts:
        t0 = time.perf_counter()
        if part == "incline":
            result["incline"] = incline_rows(engines)
            result["incline_dart_sleeping"] = sleeping_row()
        elif part == "ladder":
            result["ladder"] = ladder_rows(engines, [float(m) for m in
                                                     args.ladder_mu.split(",")])
        elif part == "ruler":
            pairs = [(float(p.split("/")[0]), float(p.split("/")[1]))
                     for p in args.ruler_pairs.split(",")]
            result["ruler"] = ruler_rows(engines, pairs, args.switches)
        elif part == "scenarios":
            result["scenarios"] = scenario_rows(engines, [n for n in
                                                          args.scenarios.split(",") if n])
        else:
            result["users"] = user_rows(engines, args.kinds.split(","), args.points,
                                        args.seed)
            print(result["users"]["table"])
            print(result["users"]["engine_pairs"])
        result.setdefault("commands", {})[part] = " ".join(sys.argv[1:])
        print(f"{part}: {time.perf_counter() - t0:.0f} s", flush=True)
        atomic_write_json(out, result)


if __name__ == "__main__":
    main()
