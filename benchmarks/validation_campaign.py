"""Validation campaign: seeded random points through the user's path, in any engines
(docs/validation-campaign.md).

Cases:

* ``ex41`` / ``ex43``: Examples 4.1 / 4.3 (eqs. 37, 42), the shipped files at friction drawn
  uniformly from [0.05, 1] per contact;
* ``system``: boxes and trapezoids on a table pushed by one frictionless finger
  (:func:`random_system`, built in code);
* ``acute``, ``supports``, ``stacked``, ``static``: system files of the kinds a user writes
  (:mod:`planner.sweeps.user_systems`), read by the system-file loader (:func:`user_point`);
* ``hand``: random hands planned by ``qsplan plan`` and validated by ``qsplan validate``
  (``campaign_hands.py``).

A system point is simulated by :func:`scenarios.runs.simulate_system` (``qsplan simulate``) and
the same recording is judged against the prediction of a negative control whose predicted mode
set shares no mode with the point's (another friction, or for a drawn file its mirror image);
agreement there while the run agreed with its own prediction is a false agreement. A point is
*near a boundary* when the predicted mode set changes with one coefficient a user sets moved by
``+-NEAR`` (0.03) or a predicted sliding contact is too slow for the classifier
(:func:`near_velocity`), and *wedge possible* when two contacts can wedge the workpiece
(:func:`wedge_pairs`); both are counted apart from the points *away*.

    python benchmarks/validation_campaign.py --points 8 --seed 1
    python benchmarks/validation_campaign.py --cases ex41,ex43,acute,supports,stacked,static,hand \\
        --points ex41=200,ex43=200,acute=16,supports=16,stacked=16,static=16,hand=24 --seed 4 \\
        --jsonl out.jsonl --workers 2          # the full campaign (resumable)
    python benchmarks/validation_campaign.py --jsonl out.jsonl --table-only
    python benchmarks/validation_campaign.py --engines dart ... --jsonl dart.jsonl
    python benchmarks/validation_campaign.py --jsonl dart.jsonl --also out.jsonl --table-only

Rates are printed per case, engine and near/away; the full campaign takes hours on two cores.
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

from planner.files.system_file import load_system, system_from_dict
from planner.model.layout import group_mu
from planner.model.modes import SLIDE
from planner.model.system import System
from planner.model.wedge import wedge_pairs as planner_wedge_pairs
from planner.model.workpiece import WorkpieceGeometry
from planner.predict.feasibility import feasible_modes
from planner.sweeps.user_files import UserDraw, mirror_system
from planner.sweeps.user_systems import KINDS, draw_user_system
from scenarios.registry import DATA_DIR
from scenarios.runs import simulate_system
from sim.judge import judge
from sim.scenes.system import commanded_contact_speed

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the sibling benchmarks module
from campaign_engines import consensus_table, odd_unrecorded, pairwise_table  # noqa: E402
from campaign_hands import hand_entries, refresh_where, run_hand  # noqa: E402

NEAR = 0.03
#: MuJoCo backend settings of every run (``--mujoco-backend-defaults``; ``None``: the system
#: scenes' own, ``sim.settings.SETTINGS``)
MUJOCO_SETTINGS: Any = None
#: The classifier's slip threshold as a fraction of the drive speed (``sim.classify``).
SLIP = 0.05
EXAMPLES = {"ex41": "example_4_1", "ex43": "example_4_3"}
#: Where the random hands' files, plans and runs go (``--hands-dir``).
HANDS_DIR = Path(__file__).resolve().parent / "results" / "campaign_hands"


def labels(system: System, mu: np.ndarray) -> frozenset[str]:
    return frozenset(feasible_modes(system.with_mu(mu)).labels)


def parameters(system: System) -> list[list[int]]:
    """The friction coefficients a user sets: each friction group (its contacts share one
    value) and each contact outside a group; 0-based contact indices."""
    grouped = [list(ix) for _, ix in system.friction_groups]
    taken = {i for ix in grouped for i in ix}
    return grouped + [[i] for i in range(system.n_contacts) if i not in taken]


def near_boundary(system: System, mu: np.ndarray) -> bool:
    """The predicted mode set changes when one coefficient a user sets (:func:`parameters`:
    a contact's, or a friction group's) moves by ``+-NEAR``."""
    base = labels(system, mu)
    for ix in parameters(system):
        for d in (-NEAR, NEAR):
            m = mu.copy()
            m[ix] = np.maximum(0.0, m[ix] + d)
            if labels(system, m) != base:
                return True
    return False


def near_velocity(system: System, mu: np.ndarray) -> bool:
    """A contact predicted to slide does so slower than ``2 x SLIP`` of the fastest commanded
    contact speed: twice the classifier's slip threshold (``sim.classify.Thresholds``: 0.05 of
    the drive speed, left again below half of it), where the engine cannot tell S from R. (A
    static system has no drive: never.)"""
    fastest = commanded_contact_speed(system)
    if not fastest > 0:
        return False
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


def run_point(case: str, engine: str, system: System, mu: np.ndarray, ctrl: np.ndarray,
              control_system: System | None = None) -> dict[str, Any]:
    """One point through the user's path (:func:`scenarios.runs.simulate_system`, as ``qsplan
    simulate``), and the same recording judged against the prediction of the control: the
    friction ``ctrl``, of ``control_system`` when given (else of ``system``)."""
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
        "artefacts": [a["text"] for a in s.observed["engine_measures"]["artefacts"]],
    }
    if engine == "mujoco" and MUJOCO_SETTINGS is not None:
        row["settings"] = "backend defaults"
    if control_system is not None:
        row["control_system"] = "mirror image"
    if ((control_system is not None or not np.array_equal(ctrl, mu))
            and res.verdict.outcome.value != "fault"):
        control = (control_system or system).with_mu(ctrl)
        judged = feasible_modes(control)
        row["control_predicted"] = list(judged.labels)
        exp = replace(res.job.expectation, modes=tuple(judged.all_modes), system=control)
        if not set(exp.labels) & set(row["predicted"]):  # "JAM" / "MOVES" for an empty set
            row["control_status"] = judge(res.recording, exp,
                                          res.job.thresholds).verdict.outcome.value
    row["wall_s"] = time.perf_counter() - t0
    return row


def where(row: dict[str, Any]) -> str:
    """``near boundary`` (friction or slip speed), ``wedge possible`` or ``away``."""
    if row.get("near_boundary") or row.get("near_velocity"):
        return "near boundary"
    return "wedge possible" if row.get("wedge") else "away"


def false_agreement(row: dict[str, Any]) -> bool:
    """The control agreed although the run agreed with its own prediction, whose modes the
    control's share none of. (A control that agrees with a run that missed its own prediction
    -- e.g. a run that jammed, judged at a friction where a jam is predicted -- is the judge
    being right.) A hand's control is set against the whole plan's status (``control_of``)."""
    return (row.get("control_status") == "agreed"
            and row.get("control_of", row["status"]) == "agreed")


STATUSES = ("agreed", "disagreed", "inconclusive", "fault")


def table(rows: list[dict[str, Any]]) -> str:
    """Per case, engine and where (:func:`where`): runs per verdict, runs not made (a hand
    without a plan, a plan whose run would be too long), false agreements of the controls."""
    rows = [e for r in rows for e in hand_entries(r)]
    out = ["| case | engine | where | n | agreed | disagreed | inconclusive | fault | not run | "
           "false agreement on control |", "|---|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["case"], r["engine"], where(r)) for r in rows})
    for case, engine, at in keys:
        sel = [r for r in rows if (r["case"], r["engine"], where(r)) == (case, engine, at)]
        c = Counter(r["status"] for r in sel)
        ctrl = [r for r in sel if "control_status" in r]
        false = sum(false_agreement(r) for r in ctrl)
        ran = [r for r in sel if r["status"] in STATUSES]
        n = len(ran) or 1
        out.append(f"| {case} | {engine} | {at} | {len(ran)} | "
                   + " | ".join(f"{c[s]} ({c[s] / n:.0%})" for s in STATUSES)
                   + f" | {len(sel) - len(ran)} | {false} of {len(ctrl)} |")
    return "\n".join(out)


def tasks(cases: list[str], engines: list[str], points: dict[str, int]
          ) -> list[tuple[str, int, str]]:
    """Every ``(case, index, engine)`` of the campaign, interleaved by index (a partial run
    covers every case)."""
    return [(c, i, e) for i in range(max(points.values(), default=0)) for c in cases
            for e in engines if i < points[c]]


def user_point(kind: str, index: int, seed: int
               ) -> tuple[UserDraw, System, np.ndarray, np.ndarray, System | None]:
    """The ``index``-th system file of ``kind`` (:mod:`planner.sweeps.user_systems`, seeded
    by ``(seed, kind, index)``: no replay), read with the loader of ``qsplan simulate``
    (:func:`planner.files.system_file.system_from_dict` of its JSON text), its friction, and a
    negative control: the friction groups redrawn from their ranges until the predicted mode
    set (``JAM`` / ``MOVES`` when empty) shares none with the point's; when 50 redraws find
    none, the mirror image of the file (:func:`planner.sweeps.user_files.mirror_system`) as
    the judged system if its modes share none (returned last, else ``None``); else ``mu``
    itself (no control)."""
    code = sum(map(ord, kind))
    d = draw_user_system(kind, np.random.default_rng([seed, code, index]))
    system = system_from_dict(json.loads(json.dumps(d.data)), f"{kind} #{index}")
    mu = np.asarray(system.mu, dtype=float)
    empty = "JAM" if commanded_contact_speed(system) > 0 else "MOVES"
    own = labels(system, mu) or {empty}
    rng = np.random.default_rng([seed, code, index, 1])
    for _ in range(50):
        values = {g: float(rng.uniform(*r)) for g, r in d.groups.items()}
        ctrl = group_mu(mu, system.friction_groups, values)
        if not (labels(system, ctrl) or {empty}) & own:
            return d, system, mu, ctrl, None
    mirror = system_from_dict(mirror_system(d.data), f"{kind} #{index} mirrored")
    if not (labels(mirror, mu) or {empty}) & own:
        return d, system, mu, mu, mirror
    return d, system, mu, mu, None


def point(case: str, index: int, seed: int) -> tuple[System, np.ndarray, np.ndarray]:
    """The ``index``-th draw of ``case`` (the same draw whatever else runs: the generator is
    seeded by ``(seed, case)`` and the draws before ``index`` are replayed, no simulation; a
    user-written kind is seeded by ``(seed, kind, index)``, :func:`user_point`)."""
    if case in KINDS:
        return user_point(case, index, seed)[1:4]
    rng = np.random.default_rng([seed, sum(map(ord, case))])
    for _ in range(index):
        draw(case, rng)
    return draw(case, rng)


def run_task(task: tuple[str, int, str, int]) -> dict[str, Any]:
    """The row of one ``(case, index, engine, seed)``; an unexpected exception becomes a row
    with status ``error`` (the campaign goes on; the row says what broke)."""
    try:
        return task_row(task)
    except Exception as exc:  # noqa: BLE001 -- recorded, reported as a finding
        import traceback

        case, index, engine, seed = task
        return {"case": case, "index": index, "engine": engine, "seed": seed,
                "status": "error", "reason": f"{type(exc).__name__}: {exc}",
                "traceback": traceback.format_exc()[-2000:], "near_boundary": False,
                "wall_s": 0.0}


def task_row(task: tuple[str, int, str, int]) -> dict[str, Any]:
    case, index, engine, seed = task
    if case == "hand":
        return run_hand(index, engine, seed, HANDS_DIR, NEAR, SLIP)
    if case in KINDS:
        from planner.errors import QsplanError

        d = draw_user_system(case, np.random.default_rng([seed, sum(map(ord, case)), index]))
        try:
            _, system, mu, ctrl, mirror = user_point(case, index, seed)
            row = run_point(case, engine, system, mu, ctrl, mirror)
        except QsplanError as exc:  # what `qsplan simulate` refuses with exit 2
            row = {"case": case, "engine": engine, "status": "refused", "reason": str(exc),
                   "near_boundary": False, "wall_s": 0.0}
        row.update(params=d.params, claim=d.claim.why, file=d.data)
    else:
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


def latest(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per ``(case, index, engine, seed)``: the last one given (a file's re-run of a
    point replaces an earlier file's row; rows without an index are kept)."""
    keyed: dict[Any, dict[str, Any]] = {}
    for i, r in enumerate(rows):
        keyed[(r["case"], r["index"], r["engine"], r.get("seed"))
              if "index" in r else ("row", i)] = r
    return list(keyed.values())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", default="8",
                    help="points per case: N, or CASE=N,... (e.g. ex41=200,ex43=200,system=50)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--engines", default="pymunk,mujoco")
    ap.add_argument("--cases", default="ex41,ex43,system",
                    help=f"comma-separated: ex41, ex43, system, {', '.join(KINDS)}, hand")
    ap.add_argument("--hands-dir", default=str(HANDS_DIR),
                    help="folder for the random hands' files, plans and validation runs")
    ap.add_argument("--jsonl", help="append every row to this file and skip the (case, index, "
                    "engine, seed) rows it already holds (resumable)")
    ap.add_argument("--workers", type=int, default=1, help="processes")
    ap.add_argument("--chunk", default="0/1", help="K/N: run only tasks with number %% N == K")
    ap.add_argument("--start", type=int, default=0,
                    help="run only the points of index >= this (the others stay to be run)")
    ap.add_argument("--table-only", action="store_true",
                    help="print the tables of --jsonl (and --also): per case, engine and where; "
                    "engine pairs with the same verdict and the engines' consensus, away from "
                    "region boundaries")
    ap.add_argument("--also", default="",
                    help="comma-separated JSONL files whose rows join --jsonl's in the tables "
                    "(the same points run in other engines; a row of --jsonl replaces theirs)")
    ap.add_argument("--redo-odd", action="store_true",
                    help="run again, into --jsonl, each row of --also away from region "
                    "boundaries whose engine is the odd one of its point and that recorded no "
                    "engine artefacts (rows of files written before they were recorded)")
    ap.add_argument("--refresh-where", action="store_true",
                    help="re-derive the hand rows' near flags of --jsonl from their plans (the "
                    "planner only, no simulation) and rewrite the file")
    ap.add_argument("--mujoco-backend-defaults", action="store_true",
                    help="MuJoCo: the backend's defaults (stiff squeeze pairs, driven bodies 1e6 "
                    "x the workpiece) instead of the system scenes' settings "
                    "(sim.settings.SETTINGS); for comparison")
    args = ap.parse_args()
    if args.mujoco_backend_defaults:
        from sim.backends import EngineSettings

        global MUJOCO_SETTINGS
        MUJOCO_SETTINGS = EngineSettings()
    globals()["HANDS_DIR"] = Path(args.hands_dir)
    done = read_rows(args.jsonl) if args.jsonl else []
    if args.refresh_where:
        refresh_where(args.jsonl, done, NEAR, SLIP)
        return
    also = [r for f in args.also.split(",") if f for r in read_rows(f)]
    if args.table_only:
        rows = latest(also + done)
        print(table(rows))
        print("\nEngine pairs with the same verdict, away from region boundaries:\n")
        print(pairwise_table(rows, where))
        print("\nThe same on the points every engine ran:\n")
        print(pairwise_table(rows, where, common=True))
        print("\nThe engines' consensus, away from region boundaries:\n")
        print(consensus_table(rows, where))
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
        if j % n == k and i >= args.start and (c, i, e, args.seed) not in have]
    if args.redo_odd:
        todo = [t for t in odd_unrecorded(also, where, args.seed) if t not in have]
    rows = [r for r in done if r.get("seed") == args.seed]
    print(f"{len(todo)} runs to do, {len(rows)} rows already in {args.jsonl}", flush=True)

    def record(r: dict[str, Any]) -> None:
        rows.append(r)
        if args.jsonl:
            with open(args.jsonl, "a") as fh:
                fh.write(json.dumps(r) + "\n")
        what = (f"runs {[x['status'] for x in r.get('runs', [])]}" if r["case"] == "hand"
                else f"mu={np.round(r.get('mu', []), 3).tolist()} pred {r.get('predicted')} "
                     f"obs {r.get('observed')}")
        print(f"{r['case']} #{r['index']} {r['engine']} {r['status']:12s} control "
              f"{r.get('control_status', '-'):10s} {where(r)} {what} [{r['wall_s']:.1f} s]",
              flush=True)

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
