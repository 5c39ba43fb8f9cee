"""Validation campaign: seeded random friction points and random systems, both engines.

Cases (each simulated with :func:`scenarios.runs.simulate_system`, the path of ``qsplan
simulate``):

* ``ex41`` / ``ex43``: Examples 4.1 / 4.3 (eqs. 37, 42), the shipped files (simulated at the
  pipeline's scale, :data:`sim.settings.SIZE_RANGE`) at friction drawn uniformly from
  [0.05, 1] per contact;
* ``system``: random boxes and trapezoids on a table pushed by one frictionless finger from the
  left or (mirrored) the right, at a random height and direction (:func:`random_system`) --
  systems with ``workpiece`` geometry and ``environment`` contacts.

Every run is also judged against the prediction at a second random friction point whose
predicted mode set shares no mode with the first's (a negative control: agreement there while
the run agreed with its own prediction is a false agreement). A point is *near a boundary*
when the predicted mode set changes with any one coefficient moved by ``+-NEAR`` (0.03) or a
predicted sliding contact is too slow for the classifier (:func:`near_velocity`), and *wedge
possible* when two contacts can wedge the workpiece (:func:`wedge_pairs`); both are counted
apart from the points *away* (docs/simulation.md, "Validation campaign").

    python benchmarks/validation_campaign.py --points 8 --seed 1
    python benchmarks/validation_campaign.py --points ex41=200,ex43=200,system=50 \\
        --jsonl out.jsonl --workers 2          # the full campaign (resumable)
    python benchmarks/validation_campaign.py --jsonl out.jsonl --table-only

Rates are printed per case, engine and near/away; the full campaign (>= 200 points per example,
>= 50 systems, ~3-5 s per run) takes hours on two cores.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from typing import Any

import numpy as np

from planner.files.system_file import load_system
from planner.model.modes import SLIDE
from planner.model.system import System
from planner.model.wedge import wedge_pairs as planner_wedge_pairs
from planner.model.workpiece import WorkpieceGeometry
from planner.predict.feasibility import feasible_modes
from scenarios.registry import DATA_DIR
from scenarios.runs import simulate_system
from sim.judge import judge

NEAR = 0.03
#: MuJoCo backend settings of every run (``--mujoco-backend-defaults``; ``None``: the system
#: scenes' own, ``sim.system_run.SYSTEM_SETTINGS``)
MUJOCO_SETTINGS: Any = None
#: The classifier's slip threshold as a fraction of the drive speed (``sim.classify``).
SLIP = 0.05
EXAMPLES = {"ex41": "example_4_1", "ex43": "example_4_3"}


def labels(system: System, mu: np.ndarray) -> frozenset[str]:
    return frozenset(feasible_modes(system.with_mu(mu)).labels)


def near_boundary(system: System, mu: np.ndarray) -> bool:
    """The predicted mode set changes when one coefficient moves by ``+-NEAR``."""
    base = labels(system, mu)
    for i in range(len(mu)):
        for d in (-NEAR, NEAR):
            m = mu.copy()
            m[i] = max(0.0, m[i] + d)
            if labels(system, m) != base:
                return True
    return False


def near_velocity(system: System, mu: np.ndarray) -> bool:
    """A contact predicted to slide does so slower than ``2 x SLIP`` of the fastest commanded
    contact speed: twice the classifier's slip threshold (``sim.classify.Thresholds``: 0.05 of
    the drive speed, left again below half of it), where the engine cannot tell S from R."""
    fastest = float(np.max(np.linalg.norm(
        np.asarray(system.joint_inputs, dtype=float).reshape(-1, 2), axis=1)))
    for m in feasible_modes(system.with_mu(mu)).all_modes:
        vt = np.abs(np.asarray(m.contact_velocities, dtype=float)[:, 1])
        sliding = np.array([c == SLIDE for c in m.mode.codes])
        if np.any(sliding & (vt < 2 * SLIP * fastest)):
            return True
    return False


def wedge_pairs(system: System, mu: np.ndarray, turn: float = 0.0,
                slide: np.ndarray | None = None) -> list[tuple[int, int]]:
    """Contact pairs (1-based) that can wedge the workpiece over the run
    (:func:`planner.model.wedge.wedge_pairs`, with the cones widened by how far the line between
    the contacts can turn: ``turn`` of the workpiece, ``slide`` of the contacts). Measured:
    Example 4.1 at mu = .98 .82 .54, 1.55 deg short of a wedge at contact 2 at the start (the
    workpiece turns 1.45 deg, contact 2 slides 6.4 mm at 0.31 m), forces grow from 34 N to
    130 N in pymunk."""
    return planner_wedge_pairs(system, mu, turn, slide)


def random_system(rng: np.random.Generator) -> tuple[System, np.ndarray]:
    """A random workpiece on a table pushed by one frictionless finger: a box or a trapezoid
    (top corners moved in by up to 0.3 of the width on each side) of width and height in
    [0.05, 0.15] m, standing on its bottom edge (two ``environment`` contacts at its bottom
    corners, table friction in [0.1, 1]), pushed on its left or, mirrored, right side edge at
    [0.1, 0.9] of the height along the edge's inward normal with a tangential component in
    [-0.5, 0.5] of the normal one; weight 0.981 N through the polygon's centroid."""
    w, h = rng.uniform(0.05, 0.15, size=2)
    trapezoid = bool(rng.integers(2))
    sl, sr = (rng.uniform(0.0, 0.3, size=2) * w) if trapezoid else (0.0, 0.0)
    poly = np.array([[0.0, 0.0], [w, 0.0], [w - sr, h], [sl, h]])
    frac = rng.uniform(0.1, 0.9)
    if rng.integers(2):  # mirrored: push the right edge towards -x
        a, b = poly[1], poly[2]
        n = np.array([-(b - a)[1], (b - a)[0]])
    else:
        a, b = poly[0], poly[3]
        n = np.array([(b - a)[1], -(b - a)[0]])
    n /= np.linalg.norm(n)
    r = a + frac * (b - a)
    v_t = rng.uniform(-0.5, 0.5)
    mu_t = rng.uniform(0.1, 1.0)
    mass = 0.1
    weight = 9.81 * mass
    geom = WorkpieceGeometry(poly, mass)
    cx = float(np.asarray(geom.com)[0])
    system = System.from_contacts(
        points=[[0.0, 0.0], [w, 0.0], r.tolist()],
        normals=[[0.0, 1.0], [0.0, 1.0], n.tolist()],
        mu=[mu_t, mu_t, 0.0],
        external_wrench=(0.0, -weight, -weight * cx),
        contact_velocities=[[0.0, 0.0], [0.0, 0.0], [0.001, 0.001 * v_t]],
        workpiece=geom,
        environment=[True, True, False],
    )
    return system, np.array([mu_t, mu_t, 0.0])


def draw(case: str, rng: np.random.Generator) -> tuple[System, np.ndarray, np.ndarray]:
    """``(system, mu, control mu)``; the control's predicted mode set shares no mode with
    ``mu``'s (``mu`` itself when none is found in 50 draws: no control for that point)."""
    if case == "system":
        system, mu = random_system(rng)
        for _ in range(50):
            c = rng.uniform(0.1, 1.0)
            ctrl = np.array([c, c, 0.0])
            if not labels(system, ctrl) & labels(system, mu):
                return system, mu, ctrl
        return system, mu, mu
    system = load_system(DATA_DIR / f"{EXAMPLES[case]}.json")
    mu = rng.uniform(0.05, 1.0, size=system.n_contacts)
    for _ in range(50):
        ctrl = rng.uniform(0.05, 1.0, size=system.n_contacts)
        if not labels(system, ctrl) & labels(system, mu):
            return system, mu, ctrl
    return system, mu, mu


def reach(system: System, mu: np.ndarray, p: dict[str, Any]) -> tuple[float, np.ndarray]:
    """How far the predicted modes move things over the run of ``qsplan simulate``'s
    ``parameters`` ``p``: the largest turn of the workpiece [rad] and each contact's largest
    slide along the workpiece [m] (predicted ``|omega|`` and ``|v_t|`` x speed scale x
    duration)."""
    modes = feasible_modes(system.with_mu(mu)).all_modes
    k = float(p["speed_scale"]) * float(p["duration_s"])
    omega = max((abs(float(np.asarray(m.qdot)[2])) for m in modes), default=0.0)
    slide = np.zeros(system.n_contacts)
    for m in modes:
        slide = np.maximum(slide, np.abs(np.asarray(m.contact_velocities, dtype=float)[:, 1]))
    return omega * k, slide * k


def run_point(case: str, engine: str, system: System, mu: np.ndarray, ctrl: np.ndarray
              ) -> dict[str, Any]:
    """One point through the user's path (:func:`scenarios.runs.simulate_system`, as ``qsplan
    simulate``), and the same recording judged against the control friction's prediction."""
    from dataclasses import replace

    t0 = time.perf_counter()
    res = simulate_system(system, engine, mu=mu,
                          settings=MUJOCO_SETTINGS if engine == "mujoco" else None)
    s = res.summary
    p = s.parameters
    row: dict[str, Any] = {
        "case": case, "engine": engine, "mu": mu.tolist(), "status": res.verdict.outcome.value,
        "predicted": s.predicted["labels"], "observed": s.observed["counts"],
        "reason": res.verdict.reason, "near_boundary": near_boundary(system, mu),
        "near_velocity": near_velocity(system, mu),
        "wedge": wedge_pairs(system, mu, *reach(system, mu, p)), "control_mu": ctrl.tolist(),
    }
    if engine == "mujoco" and MUJOCO_SETTINGS is not None:
        row["settings"] = "backend defaults"
    if not np.array_equal(ctrl, mu) and res.verdict.outcome.value != "fault":
        control = system.with_mu(ctrl)
        judged = feasible_modes(control)
        row["control_predicted"] = list(judged.labels)
        if not set(judged.labels or ["JAM"]) & set(row["predicted"]):  # a jam is "JAM"
            exp = replace(res.job.expectation, modes=tuple(judged.all_modes), system=control)
            row["control_status"] = judge(res.recording, exp,
                                          res.job.thresholds).verdict.outcome.value
    row["wall_s"] = time.perf_counter() - t0
    return row


def where(row: dict[str, Any]) -> str:
    """``near boundary`` (friction or slip speed), ``wedge possible`` or ``away``."""
    if row["near_boundary"] or row.get("near_velocity"):
        return "near boundary"
    return "wedge possible" if row.get("wedge") else "away"


def false_agreement(row: dict[str, Any]) -> bool:
    """The control agreed although the run agreed with its own prediction, whose modes the
    control's share none of. (A control that agrees with a run that missed its own prediction
    -- e.g. a run that jammed, judged at a friction where a jam is predicted -- is the judge
    being right.)"""
    return row.get("control_status") == "agreed" and row["status"] == "agreed"


def table(rows: list[dict[str, Any]]) -> str:
    out = ["| case | engine | where | n | agreed | disagreed | inconclusive | fault | "
           "false agreement on control |", "|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["case"], r["engine"], where(r)) for r in rows})
    for case, engine, at in keys:
        sel = [r for r in rows if (r["case"], r["engine"], where(r)) == (case, engine, at)]
        c = Counter(r["status"] for r in sel)
        ctrl = [r for r in sel if "control_status" in r]
        false = sum(false_agreement(r) for r in ctrl)
        n = len(sel)
        out.append(f"| {case} | {engine} | {at} | {n} | "
                   + " | ".join(f"{c[s]} ({c[s] / n:.0%})" for s in
                                ("agreed", "disagreed", "inconclusive", "fault"))
                   + f" | {false} of {len(ctrl)} |")
    return "\n".join(out)


def tasks(cases: list[str], engines: list[str], points: dict[str, int]
          ) -> list[tuple[str, int, str]]:
    """Every ``(case, index, engine)`` of the campaign, interleaved by index (a partial run
    covers every case)."""
    return [(c, i, e) for i in range(max(points.values(), default=0)) for c in cases
            for e in engines if i < points[c]]


def point(case: str, index: int, seed: int) -> tuple[System, np.ndarray, np.ndarray]:
    """The ``index``-th draw of ``case`` (the same draw whatever else runs: the generator is
    seeded by ``(seed, case)`` and the draws before ``index`` are replayed, no simulation)."""
    rng = np.random.default_rng([seed, sum(map(ord, case))])
    for _ in range(index):
        draw(case, rng)
    return draw(case, rng)


def run_task(task: tuple[str, int, str, int]) -> dict[str, Any]:
    case, index, engine, seed = task
    system, mu, ctrl = point(case, index, seed)
    row = run_point(case, engine, system, mu, ctrl)
    row.update(index=index, seed=seed)
    return row


def read_rows(path: str) -> list[dict[str, Any]]:
    """Rows of a JSONL file (a torn last line from an interrupted run is skipped)."""
    rows = []
    try:
        with open(path) as fh:
            for line in fh:
                try:
                    rows.append(json.loads(line))
                except json.JSONDecodeError:
                    pass
    except FileNotFoundError:
        pass
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="8",
                    help="points per case: N, or CASE=N,... (e.g. ex41=200,ex43=200,system=50)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--engines", default="pymunk,mujoco")
    ap.add_argument("--cases", default="ex41,ex43,system")
    ap.add_argument("--jsonl", help="append every row to this file and skip the (case, index, "
                    "engine, seed) rows it already holds (resumable)")
    ap.add_argument("--workers", type=int, default=1, help="processes")
    ap.add_argument("--chunk", default="0/1", help="K/N: run only tasks with number %% N == K")
    ap.add_argument("--table-only", action="store_true", help="print the table of --jsonl")
    ap.add_argument("--mujoco-backend-defaults", action="store_true",
                    help="MuJoCo: the backend's defaults (stiff squeeze pairs, driven bodies 1e6 "
                    "x the workpiece) instead of the system scenes' settings "
                    "(sim.settings.SETTINGS); for comparison")
    args = ap.parse_args()
    if args.mujoco_backend_defaults:
        from sim.backends import EngineSettings

        global MUJOCO_SETTINGS
        MUJOCO_SETTINGS = EngineSettings()
    done = read_rows(args.jsonl) if args.jsonl else []
    if args.table_only:
        print(table(done))
        return
    have = {(r["case"], r["index"], r["engine"], r["seed"]) for r in done if "index" in r}
    k, n = (int(v) for v in args.chunk.split("/"))
    cases = args.cases.split(",")
    if "=" in args.points:
        points = {c: int(v) for c, v in (kv.split("=") for kv in args.points.split(","))}
        cases = [c for c in cases if c in points]
    else:
        points = dict.fromkeys(cases, int(args.points))
    todo = [(c, i, e, args.seed) for j, (c, i, e) in enumerate(
        tasks(cases, args.engines.split(","), points))
        if j % n == k and (c, i, e, args.seed) not in have]
    rows = [r for r in done if r.get("seed") == args.seed]
    print(f"{len(todo)} runs to do, {len(rows)} rows already in {args.jsonl}", flush=True)

    def record(r: dict[str, Any]) -> None:
        rows.append(r)
        if args.jsonl:
            with open(args.jsonl, "a") as fh:
                fh.write(json.dumps(r) + "\n")
        print(f"{r['case']} #{r['index']} {r['engine']} mu={np.round(r['mu'], 3).tolist()} "
              f"{r['status']:12s} control {r.get('control_status', '-'):10s} "
              f"{where(r)} pred {r['predicted']} "
              f"obs {r['observed']} [{r['wall_s']:.1f} s]", flush=True)

    if args.workers > 1:
        import multiprocessing

        with multiprocessing.Pool(args.workers) as pool:
            for r in pool.imap_unordered(run_task, todo):
                record(r)
    else:
        for t in todo:
            record(run_task(t))
    print(table(rows))


if __name__ == "__main__":
    main()
