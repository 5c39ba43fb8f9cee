"""The DART backend (:mod:`sim.backends.dart_engine`) measured: stick/slip on an incline, the
ruler with static/kinetic friction, the paper's examples, system scenes, the validation
campaign's friction points, and speed -- DART next to pymunk and MuJoCo in the same run.

* ``incline``: a box on a static block tilted by ``a`` at mu = 0.3, loaded by its weight, each
  engine's backend with its defaults (``dart-defaults``: DART's own sleeping and solver put
  back): creep below ``atan(mu)`` (largest ``|v_t|`` over the last
  half of 0.5 s), the stick/slip threshold found by bisection (a box *slides* when its slip after
  0.5 s exceeds 1e-6 m/s), the sliding acceleration's error against ``g (sin a - mu cos a)``;
* ``ruler``: Sec. 5.1 through ``scenarios.paper_sims.run_ruler`` (pymunk's speed and step);
* ``examples``: every registered simulator scenario (Examples 4.1 / 4.3, the ruler, the hand,
  several workpieces, their negative controls) through its own ``run``;
* ``systems``: ``box_on_table_high`` / ``_low`` and the chain boxes of ``tests/data`` through
  ``sim.system_run.simulate_system`` (the several-workpiece files run as registered scenarios);
* ``campaign``: the first ``--points`` friction points of ``benchmarks/validation_campaign.py``
  (seed 1) per case through the same machinery, and agreement with the pymunk / MuJoCo rows
  recorded for those points in ``benchmarks/results/validation_campaign.jsonl``;
* ``speed``: bare ``backend.step`` calls per second on the ruler scene and on Example 4.1, the
  three engines in alternating blocks.

DART is not in the engine registry yet: :func:`enable_dart` adds it *for this process only*
(pymunk's run settings: DART's contacts are as stiff as pymunk's; creep floor 1e-7 m/s, above the
measured 3e-8, docs/engine-dart.md). Nothing is asserted here (tests/test_dart_backend.py).

    PYTHONPATH=. python benchmarks/dart_engine.py incline speed --out results.json
    PYTHONPATH=. python benchmarks/dart_engine.py ruler examples systems campaign --points 20
"""

from __future__ import annotations

import argparse
import json
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
#: DART's creep floor for the classifier [m/s] (docs/engine-dart.md: measured <= 3e-8)
DART_CREEP = 1e-7
#: DART backends made by the registered factory (their depth-floor growth and unconverged solves)
BUILT: list[Any] = []


def dart_counters() -> dict[str, Any]:
    """Depth-floor growth [m] and unconverged contact solves of the last DART backend built."""
    if not BUILT:
        return {}
    return {"inflation_m": BUILT[-1].inflation, "unconverged_solves": BUILT[-1].unconverged}


def enable_dart() -> None:
    """Register ``"dart"`` in this process: the engine tuple and factory of
    :mod:`sim.backends` and the per-engine tables of :mod:`sim.system_run` and
    :mod:`scenarios.paper_sims`, with pymunk's numbers and :data:`DART_CREEP`."""
    import scenarios.paper_sims as ps
    import sim.backends as sb
    import sim.hand_run as hr
    import sim.hand_settings as hs
    import sim.system_run as sr
    from sim.backends.dart_engine import DartBackend

    if "dart" in sb.ENGINES:
        return
    sb.ENGINES = (*sb.ENGINES, "dart")
    factory = sb.make_backend

    def make_backend(engine: str, settings: Any = None) -> Any:
        if engine != "dart":
            return factory(engine, settings)
        BUILT.append(DartBackend())
        return BUILT[-1]

    sb.make_backend = hr.make_backend = make_backend  # type: ignore[assignment]
    hs.ENGINE_SETTINGS["dart"] = sb.EngineSettings(dt=1e-3, creep=DART_CREEP)
    sr.RATE["dart"], sr.MAX_SPEED["dart"] = sr.RATE["pymunk"], sr.MAX_SPEED["pymunk"]
    sr.ENGINE["dart"] = dict(sr.ENGINE["pymunk"], creep=DART_CREEP)
    sr.SYSTEM_SETTINGS["dart"] = sb.EngineSettings()
    ps.ENGINE_SETTINGS["dart"] = dict(ps.ENGINE_SETTINGS["pymunk"], creep=DART_CREEP)
    ps.RULER_DT["dart"], ps.RULER_SPEED["dart"] = ps.RULER_DT["pymunk"], ps.RULER_SPEED["pymunk"]


def backend(engine: str) -> Any:
    """``engine``'s backend; ``dart-defaults``: the DART backend with DART's own defaults put
    back (sleeping on, Dantzig pivoting with the PGS fallback) -- what the issue measured."""
    enable_dart()
    import sim.backends as sb

    if engine != "dart-defaults":
        return sb.make_backend(engine)
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


# -- the project's own scenario paths ----------------------------------------------------------
def ruler_rows(pairs: list[tuple[float, float]], out: Path) -> list[dict[str, Any]]:
    enable_dart()
    from scenarios.paper_sims import run_ruler
    from sim.compare import Expect

    rows = []
    for mu_s, mu_k in pairs:
        t0 = time.perf_counter()
        s = run_ruler(out / f"ruler_{mu_s}_{mu_k}", name="ruler", expect=Expect.AGREE,
                      mu_s=mu_s, mu_k=mu_k, engine="dart", tolerance=0.01,
                      required=1 if mu_s == mu_k else 5, render=False)
        rows.append({"mu_s": mu_s, "mu_k": mu_k, "status": s["status"],
                     "relative_errors": s["observed"]["relative_errors"],
                     "predicted": s["switch_positions"]["predicted"],
                     "observed": s["switch_positions"]["observed"],
                     "creep_m_per_s": s["observed"]["creep_m_per_s"],
                     "fault": s["observed"]["fault"], "wall_s": round(time.perf_counter() - t0),
                     **dart_counters()})
        print(rows[-1], flush=True)
    return rows


def example_rows(out: Path) -> list[dict[str, Any]]:
    enable_dart()
    from scenarios.registry import all_scenarios

    rows = []
    for name, sc in all_scenarios().items():
        if "sim" not in sc.tags:
            continue
        s = sc.run(out / name, engine="dart", render=False)
        rows.append({"scenario": name, "expect": s.get("expect"), "status": s.get("status"),
                     "passed": s.get("passed"), "reason": s.get("reason"), **dart_counters()})
        print(rows[-1], flush=True)
    return rows


SYSTEM_FILES = ("scenarios/data/box_on_table_high.json", "scenarios/data/box_on_table_low.json",
                "tests/data/two_link_finger_box.json", "tests/data/prismatic_finger_box.json",
                "tests/data/two_link_effort_finger_box.json")


def system_rows(engines: list[str]) -> list[dict[str, Any]]:
    enable_dart()
    from planner.files.system_file import load_system
    from sim.system_run import simulate_system

    rows = []
    for path in SYSTEM_FILES:
        for engine in engines:
            t0 = time.perf_counter()
            res = simulate_system(load_system(ROOT / path), engine)
            rows.append({"system": path, "engine": engine, "status": res.verdict.outcome.value,
                         "predicted": res.summary["predicted"]["labels"],
                         "observed": res.summary["observed"]["counts"],
                         "reason": res.verdict.reason,
                         "wall_s": round(time.perf_counter() - t0, 1),
                         **(dart_counters() if engine == "dart" else {})})
            print({k: rows[-1][k] for k in ("system", "engine", "status", "predicted")},
                  flush=True)
    return rows


def campaign_rows(points: int) -> dict[str, Any]:
    """DART on the first ``points`` friction points per case of the recorded campaign."""
    enable_dart()
    import importlib.util

    spec = importlib.util.spec_from_file_location("vc", ROOT / "benchmarks/validation_campaign.py")
    vc = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(vc)  # type: ignore[union-attr]
    recorded = {(r["case"], r["index"], r["engine"]): r for r in
                vc.read_rows(str(ROOT / "benchmarks/results/validation_campaign.jsonl"))}
    rows = []
    for case, n in (("ex41", points), ("ex43", points), ("system", max(1, points // 4))):
        for index in range(n):
            rows.append(vc.run_task((case, index, "dart", 1)))
            print({k: rows[-1][k] for k in ("case", "index", "status", "predicted")},
                  flush=True)
    pairwise: dict[str, Any] = {}
    for other in ("pymunk", "mujoco"):
        both = [(r, recorded[(r["case"], r["index"], other)]) for r in rows
                if (r["case"], r["index"], other) in recorded
                and vc.where(r) == "away"]
        pairwise[other] = {"away_points": len(both),
                           "same_status": sum(a["status"] == b["status"] for a, b in both),
                           "both_agreed": sum(a["status"] == b["status"] == "agreed"
                                              for a, b in both),
                           "differ": [{"case": a["case"], "index": a["index"], "dart": a["status"],
                                       other: b["status"], "mu": a["mu"]}
                                      for a, b in both if a["status"] != b["status"]]}
    away = [r for r in rows if vc.where(r) == "away"]
    return {"rows": rows, "table": vc.table(rows), "pairwise_away": pairwise,
            "away_status": dict(Counter(r["status"] for r in away)),
            "false_agreements": sum(vc.false_agreement(r) for r in rows
                                    if "control_status" in r)}


# -- speed -----------------------------------------------------------------------------------
def speed_rows(engines: list[str], steps: int = 2000, blocks: int = 3) -> list[dict[str, Any]]:
    from planner.files.system_file import load_system
    from sim.scenes.paper import example_scene, scaled_system
    from sim.scenes.ruler import ruler_scene

    scenes = {
        "ruler": (ruler_scene(length=L, weight=1.0, mass=0.1, x_left=-0.4 * L, x_right=0.25 * L,
                              speed=3e-4, mu_s=0.5, mu_k=None, finger_radius=0.03 * L), 2e-3),
        "example_4_1": (example_scene(scaled_system(load_system(
            ROOT / "scenarios/data/example_4_1.json"), 0.01, 2e-3).with_mu((0.2, 0.3, 0.1)),
            speed=2e-3), 1e-3)}
    rows = []
    for name, (scene, dt) in scenes.items():
        times: dict[str, list[float]] = {e: [] for e in engines}
        for _ in range(blocks):  # alternating blocks: a burst of other work slows all alike
            for engine in engines:
                b = backend(engine)
                b.build(scene)
                t0 = time.perf_counter()
                for _ in range(steps):
                    b.step(dt)
                    b.contacts()
                times[engine].append(time.perf_counter() - t0)
        best = {e: steps / min(ts) for e, ts in times.items()}
        rows.append({"scene": name, "steps": steps, "blocks": blocks,
                     "steps_per_s": {e: round(v) for e, v in best.items()},
                     "dart_over": {e: round(best["dart"] / v, 3) for e, v in best.items()
                                   if e != "dart"}})
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("parts", nargs="+",
                    choices=("incline", "ruler", "examples", "systems", "campaign", "speed"))
    ap.add_argument("--engines", default="pymunk,mujoco,dart",
                    help="comma-separated; 'dart-defaults' (incline only): DART's own defaults")
    ap.add_argument("--points", type=int, default=20)
    ap.add_argument("--ruler-pairs", default="0.5/0.5,0.3/0.2,0.5/0.3,0.6/0.4,0.8/0.6,0.8/0.5,"
                                             "0.8/0.3")
    ap.add_argument("--work", default="/tmp/dart_engine_runs")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/results/dart_engine.json"))
    args = ap.parse_args()
    engines = args.engines.split(",")
    out = Path(args.out)
    result: dict[str, Any] = json.loads(out.read_text()) if out.exists() else {}
    import dartpy

    result["versions"] = {"dartpy": dartpy.__version__}
    for part in args.parts:
        if part == "incline":
            result["incline"] = incline_rows(engines)
            result["incline_dart_sleeping"] = sleeping_row()
            print(result["incline_dart_sleeping"])
        elif part == "ruler":
            pairs = [tuple(float(x) for x in p.split("/")) for p in args.ruler_pairs.split(",")]
            result["ruler"] = ruler_rows(pairs, Path(args.work))  # type: ignore[arg-type]
        elif part == "examples":
            result["examples"] = example_rows(Path(args.work))
        elif part == "systems":
            result["systems"] = system_rows(engines)
        elif part == "campaign":
            result["campaign"] = campaign_rows(args.points)
            print(result["campaign"]["table"])
        else:
            result["speed"] = speed_rows(engines)
        atomic_write_json(out, result)


if __name__ == "__main__":
    main()
