"""The validation campaign's random hands: drawn, planned and validated through the commands a
user types (``qsplan plan HAND.json --out plan.json``, ``qsplan validate plan.json --engine E
--mu M --out DIR``), in process (:func:`qsplan.cli.main`), so the hands keep working whatever
the plan model becomes.

A hand (:func:`draw_hand`) is a shipped hand file (:data:`TEMPLATES`, one per index in turn)
through :func:`planner.sweeps.random_hands.random_hand`: scaled by 0.7-1.4, mirrored on half
the draws, vertices, finger pivots and the centre of mass jittered, masses and load redrawn,
a random friction box in [0, 0.4] per contact or one for all. It is planned with the defaults;
a draw the planner cannot guarantee (exit 1) or refuses (exit 2, the message kept for review)
is redrawn, up to :data:`REDRAWS` times, and every attempt is recorded.

Each plan is validated at every value of its ``mu.validate`` list (the plan's own choice, as
``qsplan validate`` without ``--mu``); the row's status is ``agreed`` only when every value
agreed. The negative control (:func:`control_for`): the same plan at a friction outside its box
where the planner's own prediction at the first waypoint no longer contains the claim (the
box's ends scaled by :data:`CONTROL_FACTORS`), else the plan with its torques reversed
(:func:`planner.plan.model.negative_control`); a control that agrees while the plan agreed
is a false agreement.

A plan whose run would last longer than :data:`MAX_RUN_S` simulated seconds (``slow motion``:
every rate divided so that the fastest contact moves at the settings' drive speed) is not run;
the row records why (``status: "not run"``).
"""

from __future__ import annotations

import contextlib
import io
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ("two_finger_hand", "three_finger_hand", "prismatic_finger_hand",
             "two_link_finger_hand", "table_push_hand")
MU_RANGE = (0.0, 0.4)
REDRAWS = 6
#: Longest simulated run [s] the campaign starts (the longest planned hand run of the shipped
#: files is about 40 s: two_finger_hand's 41 waypoints in slow motion).
MAX_RUN_S = 300.0
#: A control friction: the box's upper ends times these, then its lower ends times these
#: (the first at which the planner's prediction at the first waypoint loses the claim).
CONTROL_FACTORS = (1.5, 2.0, 3.0, 0.5, 0.25, 0.0)


def cli(*argv: str) -> tuple[int, str, str]:
    """``qsplan ARGV...`` in process: (exit code, stdout, stderr)."""
    from qsplan.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            rc = main(list(argv))
        except SystemExit as exc:  # argparse usage errors
            rc = int(exc.code or 0)
    return rc, out.getvalue(), err.getvalue()


def draw_hand(index: int, seed: int, attempt: int) -> tuple[str, dict[str, Any]]:
    """``(template, hand-file dict)`` of hand ``index``, draw ``attempt`` (seeded by all
    three: the same draw whatever else runs)."""
    from planner.sweeps.random_hands import random_hand

    name = TEMPLATES[index % len(TEMPLATES)]
    template = json.loads((ROOT / "scenarios" / "data" / f"{name}.json").read_text())
    rng = np.random.default_rng([seed, 7, index, attempt])
    return name, random_hand(template, rng, mu_range=MU_RANGE)


def _plan(hand: dict[str, Any], folder: Path, tag: str) -> tuple[int, str, dict[str, Any]]:
    """``qsplan plan`` of ``hand`` written to ``folder/hand<tag>.json``: (exit, plan path,
    attempt record)."""
    path = folder / f"hand{tag}.json"
    path.write_text(json.dumps(hand, indent=1))
    plan = folder / f"plan{tag}.json"
    t0 = time.perf_counter()
    rc, out, err = cli("plan", str(path), "--out", str(plan))
    return rc, str(plan), {"hand": str(path), "exit": rc, "plan_s": time.perf_counter() - t0,
                           "message": (err or out).strip()[-400:]}


def planned(index: int, seed: int, folder: Path) -> dict[str, Any]:
    """Draw and plan hand ``index`` into ``folder`` (module docstring; reused when already
    there: drawing and planning are deterministic). Every third hand (``index % 3 == 2``) is
    then given a goal -- the workpiece pose its own plan reaches at 50-90 % of the way (drawn)
    -- and planned again as a whole task; when that fails, the goal-free plan is validated and
    the row says so. Returns the record of the attempts and, on success, the paths."""
    done = folder / "done.json"
    if done.is_file():
        return dict(json.loads(done.read_text()))
    folder.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {"attempts": []}
    for attempt in range(REDRAWS):
        name, hand = draw_hand(index, seed, attempt)
        rc, plan, rec = _plan(hand, folder, str(attempt))
        record["attempts"].append({"template": name, **rec})
        if rc == 0:
            record.update(template=name, hand=rec["hand"], plan=plan, attempt=attempt)
            break
    if "plan" in record and index % 3 == 2:
        rng = np.random.default_rng([seed, 7, index, 100])
        wps = _load(record["plan"]).segments[0].waypoints
        pose = [float(x) for x in wps[int(round(rng.uniform(0.5, 0.9) * (len(wps) - 1)))].pose]
        hand = json.loads(Path(record["hand"]).read_text())
        hand["goal"] = {"pose": pose}
        rc, plan, rec = _plan(hand, folder, f"{record['attempt']}_goal")
        record["goal"] = {"pose": pose, **rec}
        if rc == 0:
            record.update(hand=rec["hand"], plan=plan)
    from planner.files.atomic import atomic_write_json

    atomic_write_json(done, record)
    return record


def _load(plan: str) -> Any:
    from planner.plan.plan_file import load_plan

    return load_plan(plan)


def run_length(plan: str, engine: str, mu: Any) -> float:
    """Simulated seconds of ``qsplan validate``'s run of ``plan`` at ``mu`` (the job's
    duration, slow motion included)."""
    from sim.jobs import job_for_plan

    return float(job_for_plan(_load(plan), engine, mu).run.duration)


def control_for(plan: str) -> tuple[str, Any]:
    """``("friction", mu)`` outside the plan's box where the planner at the first waypoint
    predicts no claim, else ``("reversed", None)`` (module docstring)."""
    from planner.predict.feasibility import feasible_modes
    from sim.schedule import plan_layout

    p = _load(plan)
    lay = plan_layout(p)
    hand, q, sched = lay.hands[0], lay.q_starts[0], lay.schedules[0]
    joints = [{c: float(v)} for c, v in zip(sched.controls, sched.commands[0])]
    box = np.array([tuple(iv) for iv in p.segments[0].mu_intervals], dtype=float)
    claim = sched.claim.label
    for end, factors in ((1, CONTROL_FACTORS[:3]), (0, CONTROL_FACTORS[3:])):
        for f in factors:
            mu = np.clip(box[:, end] * f, 0.0, 3.0)
            if end == 1 and np.all(box[:, 1] == 0.0):
                mu = np.full(len(box), 0.3 * f)
            full = np.broadcast_to(mu, (hand.n_contacts,)) if len(mu) == 1 else mu
            if claim not in feasible_modes(hand.system(q, full, joints)).labels:
                return "friction", float(mu[0]) if len(mu) == 1 else [float(x) for x in mu]
    return "reversed", None


def near_boundary(plan: str, mu: Any, near: float, slip: float) -> dict[str, bool]:
    """Where a run of ``plan`` at ``mu`` lies, by the systems' rules applied at every waypoint
    of every segment, at the plan's own commands: ``near_boundary`` when the planner's
    prediction no longer is the claim alone with one coefficient (one for all contacts under
    the ``common`` model, else each contact's) moved by ``+-near``; ``near_velocity`` when a
    contact the claim slides moves slower than ``2 slip`` times the segment's drive speed
    (:func:`sim.schedule.contact_drive_speed`; the classifier's slip threshold is ``slip``
    times it)."""
    from planner.model.modes import SLIDE
    from planner.predict.feasibility import feasible_modes
    from sim.schedule import contact_drive_speed, plan_layout

    p = _load(plan)
    lay = plan_layout(p)
    out = {"near_boundary": False, "near_velocity": False}
    for seg, hand, sched, q0 in zip(p.segments, lay.hands, lay.schedules, lay.q_starts):
        base = np.broadcast_to(np.asarray(mu, dtype=float), (hand.n_contacts,)).copy()
        params = ([list(range(hand.n_contacts))] if np.ndim(mu) == 0
                  else [[i] for i in range(hand.n_contacts)])
        claim = sched.claim.label
        drive = contact_drive_speed(hand, q0, sched.controls, sched.commands)
        sliding = np.array([c == SLIDE for c in sched.claim.codes])
        for w, row in zip(seg.waypoints, sched.commands):
            q = np.r_[np.asarray(w.pose, dtype=float), np.asarray(w.angles, dtype=float)]
            joints = [{c: float(v)} for c, v in zip(sched.controls, row)]
            for m in feasible_modes(hand.system(q, base, joints)).all_modes:
                vt = np.abs(np.asarray(m.contact_velocities, dtype=float)[:, 1])
                if m.label == claim and np.any(sliding & (vt < 2 * slip * drive)):
                    out["near_velocity"] = True
            for ix in params:
                for d in (-near, near):
                    m = base.copy()
                    m[ix] = np.maximum(0.0, m[ix] + d)
                    if feasible_modes(hand.system(q, m, joints)).labels != [claim]:
                        out["near_boundary"] = True
            if all(out.values()):
                return out
    return out


def where_flags(plan: str, k: int, mu: Any, near: float, slip: float) -> dict[str, bool]:
    """:func:`near_boundary` of the run at the plan's ``k``-th ``mu.validate`` value, cached
    beside the plan (the planner's answer, the same for both engines)."""
    cache = Path(plan).parent / f"where{k}.json"
    if not cache.is_file():
        from planner.files.atomic import atomic_write_json

        atomic_write_json(cache, {"near": near, "slip": slip, "mu": np.asarray(mu).tolist(),
                                  **near_boundary(plan, mu, near, slip)})
    flags = json.loads(cache.read_text())
    return {"near_boundary": bool(flags["near_boundary"]),
            "near_velocity": bool(flags["near_velocity"])}


def _mu_arg(mu: Any) -> str:
    return "/".join(repr(float(x)) for x in mu) if np.ndim(mu) else repr(float(mu))


def validate(plan: str, engine: str, mu: Any, out: Path) -> dict[str, Any]:
    """``qsplan validate PLAN --engine E --mu M --out OUT --no-render``; its exit code and the
    summary it wrote."""
    rc, stdout, stderr = cli("validate", plan, "--engine", engine, "--mu", _mu_arg(mu),
                             "--out", str(out), "--no-render")
    res: dict[str, Any] = {"exit": rc, "mu": mu, "stdout": stdout.strip()[-600:]}
    if stderr.strip():
        res["stderr"] = stderr.strip()[-400:]
    summary = out / "summary.json"
    if summary.is_file():
        s = json.loads(summary.read_text())
        res.update(status=s["status"], reason=s.get("reason"),
                   segments=[{k: sv.get(k) for k in ("index", "claim", "status", "reason")}
                             for sv in s.get("segments", [])],
                   wall_s=s.get("wall_time_s"))
    else:
        res["status"] = "fault" if rc == 3 else "error"
    return res


def run_hand(index: int, engine: str, seed: int, root: Path, near: float, slip: float
             ) -> dict[str, Any]:
    """One random hand in ``engine`` (module docstring): a campaign row; each run at a
    ``mu.validate`` value placed by :func:`near_boundary` with ``near`` and ``slip``."""
    t0 = time.perf_counter()
    folder = root / f"seed{seed}" / f"hand{index:03d}"
    rec = planned(index, seed, folder)
    row: dict[str, Any] = {"case": "hand", "engine": engine, "index": index, "seed": seed,
                           "attempts": rec["attempts"], "near_boundary": False,
                           "near_velocity": False, "wedge": []}
    if "plan" not in rec:
        row.update(status="no plan", wall_s=time.perf_counter() - t0)
        return row
    plan = rec["plan"]
    p = _load(plan)
    row.update(template=rec["template"], hand=rec["hand"], plan=plan, goal=rec.get("goal"),
               claims=[s.claim for s in p.segments], segments=len(p.segments),
               validate_mu=[np.asarray(m).tolist() for m in p.validate_mu])
    runs = []
    for k, mu in enumerate(p.validate_mu):
        length = run_length(plan, engine, mu)
        if length > MAX_RUN_S:
            runs.append({"mu": np.asarray(mu).tolist(), "status": "not run",
                         "reason": f"the run would last {length:.4g} s (slow motion), over "
                                   f"{MAX_RUN_S:g} s"})
            continue
        run = validate(plan, engine, np.asarray(mu).tolist(), folder / engine / f"mu{k}")
        run.update(where_flags(plan, k, mu, near, slip))
        runs.append(run)
    row["runs"] = runs
    statuses = [r["status"] for r in runs]
    row["status"] = next((s for s in ("not run", "fault", "error", "disagreed",
                                      "inconclusive") if s in statuses), "agreed")
    kind, cmu = control_for(plan)
    row["control"] = kind
    if kind == "friction":
        row["control_mu"] = cmu
        ctrl_plan = plan
    else:
        from planner.plan.model import negative_control
        from planner.plan.plan_file import save_plan

        ctrl_plan = str(folder / "control_plan.json")
        save_plan(negative_control(p), ctrl_plan)
        cmu = np.asarray(p.validate_mu[len(p.validate_mu) // 2]).tolist()
    if run_length(ctrl_plan, engine, cmu) <= MAX_RUN_S:
        c = validate(ctrl_plan, engine, cmu, folder / engine / "control")
        row["control_status"] = c["status"]
        row["control_run"] = c
    row["wall_s"] = time.perf_counter() - t0
    return row


def hand_entries(r: dict[str, Any]) -> list[dict[str, Any]]:
    """The campaign table's entries of row ``r``: a system row as it is; a hand row as one
    entry per run at a ``mu.validate`` value (its own near flags; the hand's control on the
    first, set against the whole plan's status), or the row itself (``no plan``)."""
    if r["case"] != "hand" or not r.get("runs"):
        return [r]
    out = []
    for k, run in enumerate(r["runs"]):
        e = {"case": "hand", "engine": r["engine"], "status": run["status"],
             "near_boundary": bool(run.get("near_boundary")),
             "near_velocity": bool(run.get("near_velocity")), "control_of": r["status"]}
        if k == 0 and "control_status" in r:
            e["control_status"] = r["control_status"]
        out.append(e)
    return out


def refresh_where(path: str, rows: list[dict[str, Any]], near: float, slip: float) -> None:
    """Re-derive every hand run's near flags of ``rows`` from its plan (:func:`where_flags`)
    and rewrite the campaign file ``path`` with them."""
    from planner.files.atomic import atomic_write_text

    for r in rows:
        if r["case"] == "hand":
            for k, run in enumerate(r.get("runs", [])):
                run.update(where_flags(r["plan"], k, run["mu"], near, slip))
    atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in rows))
