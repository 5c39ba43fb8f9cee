"""Benchmark: the field tasks planned and validated over the whole uncertainty set, through the
commands a user types.

For each task (shipped hand files, scenarios/data) the hand file gets an ``uncertainty`` section
(:func:`planner.sweeps.set_samples.with_uncertainty`: mass ``+-MASS`` as a fraction, centre of
mass ``+-COM`` m in both body coordinates, every contact ``+-CONTACTS`` m along its feature, the
file's own friction box kept; docs/planning.md, "Uncertainty beyond friction", "Contact
positions"), then:

* ``qsplan plan HAND --out plan.json`` (a subprocess; exit code, wall time, segments, modes,
  waypoints, and the margins the plan writes: ``extra.uncertainty.tolerated``, the largest
  ``+-`` of each axis alone the commands keep guaranteed);
* ``qsplan validate plan.json --engine E --mu MU --set corners,centre --no-render --out DIR`` at
  each of the plan's ``mu.validate`` values in each engine, every point's verdict read from its
  ``set/<point>/summary.json`` (status, what the planner predicts there, the share of the
  segment in the claimed mode, the final position off as a share of the travel, wall time);
* the gap (docs/planning.md, "Validating at points of the set"): ``--set outside --outside K``
  at each step of ``--outside``: a number (half-widths of each axis past its end), or
  ``beyond`` -- :func:`beyond_step`, the contact axes pushed past the planner's stated reach.
  Per outside point: its axis, its distance from the nominal, the stated reach of that axis,
  whether it lies beyond the reach, what the planner predicts there and what the engine judged.

Jobs (one ``qsplan validate`` each) run on ``--workers`` processes in priority order: the set's
points at the first friction value, the outside points in the first engine, the set at the
other friction values, the outside points in the other engines.  A job whose estimated end
(points times the engine's measured seconds per run) falls after ``--deadline`` (UTC ``HH:MM``)
is not started and is recorded as such.  The JSON is written (atomically) after every plan and
every job, so a stopped run keeps what finished.

    PYTHONPATH=. python benchmarks/set_field_tasks.py \
        --tasks box_pivot_down,box_pivot_up,side_push --engines pymunk,mujoco \
        --outside 0.25,beyond --deadline 19:55 --out benchmarks/results/set_field_tasks.json
    PYTHONPATH=. python benchmarks/set_field_tasks.py --table RESULTS.json   # its table
"""

from __future__ import annotations

import argparse
import datetime as dt
import itertools
import json
import os
import platform
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from planner.files.atomic import atomic_write_json
from planner.sweeps.set_samples import with_uncertainty

ROOT = Path(__file__).resolve().parents[1]
TASKS = ("box_pivot_down", "box_pivot_up", "side_push", "flip_against_wall")
#: Seconds per simulated point before an engine has been measured in this run (a
#: ``block_tilting`` point took about 20 s in pymunk and 32 s in MuJoCo on the shared machine).
FIRST_GUESS_S = {"pymunk": 20.0, "mujoco": 32.0, "dart": 40.0}
#: How far past the planner's stated reach the ``beyond`` step puts the contact axes, in
#: half-widths of the axis.
BEYOND_EXTRA = 0.5


def reach_in_half_widths(tolerated: dict[str, Any], halves: dict[str, float]
                         ) -> dict[str, float | None]:
    """Per axis kind (``mass``, ``com``, ``contacts``) how far past the set's end the plan's
    stated reach lies, in half-widths of the set: ``reach / half - 1`` (``None`` when the reach
    is unbounded or not computed, or the set has no width there).  ``tolerated`` is the plan's
    ``extra.uncertainty.tolerated`` (``mass_kg``, ``com_m``, ``contacts_m``), ``halves`` the
    set's half-widths in the same units (kg, m, m)."""
    out: dict[str, float | None] = {}
    for kind, reach in stated_reach(tolerated).items():
        half = halves.get(kind, 0.0)
        out[kind] = float(reach) / half - 1.0 if half > 0 and reach is not None else None
    return out


def stated_reach(tolerated: dict[str, Any]) -> dict[str, float | None]:
    """Per axis kind (``mass``, ``com``, ``contacts``) the plan's stated reach [kg or m] from its
    ``extra.uncertainty.tolerated`` (``None`` when not given, or for contacts not computed)."""
    return {"mass": tolerated.get("mass_kg"), "com": tolerated.get("com_m"),
            "contacts": tolerated.get("contacts_m") if tolerated.get("contacts_computed")
            else None}


def beyond_step(reach: dict[str, float | None], extra: float = BEYOND_EXTRA) -> float | None:
    """The ``--outside`` step that puts the contact axes ``extra`` half-widths past the
    planner's stated reach (:func:`reach_in_half_widths`); ``None`` without a contact reach.
    At least ``extra``: a reach inside the set (negative) still steps outside it."""
    r = reach.get("contacts")
    return None if r is None else max(r, 0.0) + extra


def axis_distance(point: dict[str, Any], nominal: dict[str, float]) -> tuple[str, str, float]:
    """The outside point's axis key (``m``, ``cx``, ``s2``), its kind (``mass``, ``com``,
    ``contacts``) and its distance from the nominal value along that axis [kg or m]."""
    key = point["point"].removeprefix("out-")[:-1]
    kind = "mass" if key == "m" else "com" if key in ("cx", "cy") else "contacts"
    return key, kind, abs(point["values"][key] - nominal[key])


def mu_text(mu: Any) -> str:
    return f"{mu:g}" if isinstance(mu, (int, float)) else "/".join(f"{x:g}" for x in mu)


def run(cmd: list[str], cwd: Path) -> tuple[int, float, str]:
    t0 = time.perf_counter()
    proc = subprocess.run(["nice", "-n", "5", *cmd], cwd=cwd, capture_output=True, text=True)
    return proc.returncode, time.perf_counter() - t0, proc.stdout + proc.stderr


def point_rows(folder: Path) -> list[dict[str, Any]]:
    """Every ``set/<point>/summary.json`` under ``folder``: the point and its verdict."""
    rows = []
    for f in sorted((folder / "set").glob("*/summary.json")):
        s = json.loads(f.read_text())
        sp = s["parameters"]["set_point"]
        rows.append({"point": sp["name"], "kind": sp["kind"], "inside": sp["inside"],
                     "values": sp["values"], "expect": sp["expect"],
                     "claim_only_share": sp.get("claim_only_share"),
                     "ends_early": sp.get("ends_early", []),
                     "status": s["status"], "passed": s["passed"],
                     "claim_fraction": s.get("claim_fraction"),
                     "final_error_of_travel": s.get("final_error_of_travel"),
                     "fault_kind": s.get("fault_kind"), "reason": s.get("reason"),
                     "wall_time_s": s.get("wall_time_s")})
    return rows


def job_rows(task: dict[str, Any], folder: Path, step: float | None) -> list[dict[str, Any]]:
    """The points of one job's ``--out`` ``folder`` (:func:`point_rows`); for outside points
    (``step`` given) also the axis each pushes, its distance from the nominal and whether that
    lies beyond the plan's stated reach of the axis (``task``'s ``tolerated``)."""
    rows = point_rows(folder) if folder.exists() else []
    if step is not None:
        reach = stated_reach(task["plan"].get("tolerated") or {})
        for r in rows:
            key, kind, d = axis_distance(r, task["nominal"])
            lim = reach[kind]
            r.update(axis=key, distance=d, stated_reach=lim,
                     beyond_reach=None if lim is None else d > lim)
    return rows


def tag_job(tag: str) -> tuple[str, str, str, float | None]:
    """``engine, mu, kinds, step`` from a job folder's name (``mujoco_mu0.6_corners-centre``,
    ``pymunk_mu0.6_outside_0.25``; :meth:`Bench.run_job`)."""
    eng, rest = tag.split("_mu", 1)
    parts = rest.split("_")
    step = float(parts[2]) if len(parts) > 2 else None
    return eng, parts[0].replace("-", "/"), parts[1].replace("-", ","), step


def record(out: str, task_name: str, tag: str, code: int | None, wall: float | None,
           folder: str | None = None) -> None:
    """Add a job run by hand (the command :meth:`Bench.run_job` would run, in the task's work
    folder) to the results ``out``, in place of its ``not run`` row; ``folder``: where its
    summaries are when not the job's ``--out`` (a stopped run's staging folder); ``code`` and
    ``wall`` None when not known."""
    result = json.loads(Path(out).read_text())
    task = next(t for t in result["tasks"] if t["task"] == task_name)
    eng, mu, kinds, step = tag_job(tag)
    work = Path(task["hand"]).parent
    rows = job_rows(task, Path(folder) if folder else work / tag, step)
    cmd = (f"qsplan validate plan.json --engine {eng} --mu {mu} --set {kinds} --no-render "
           f"--out {tag}" + (f" --outside {step:g}" if step is not None else ""))
    row = {"engine": eng, "mu": mu, "set": kinds, "outside": step, "points": len(rows),
           "command": cmd, "run_by_hand": True, "exit_code": code, "wall_s": wall,
           "complete": folder is None, "runs": rows}
    task["jobs"] = [j for j in task["jobs"] if not (
        j["engine"] == eng and j["mu"] == mu and j["set"] == kinds and j["outside"] == step
        and "runs" not in j)] + [row]
    atomic_write_json(out, result)


class Bench:
    """The run's state: tasks, the job queue, the JSON written after every step."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.lock = threading.Lock()
        self.jobs: queue.PriorityQueue[Any] = queue.PriorityQueue()
        self.seq = itertools.count()
        self.per_run = dict(FIRST_GUESS_S)
        self.tasks: list[dict[str, Any]] = []
        self.deadline = None
        if args.deadline:
            hh, mm = (int(x) for x in args.deadline.split(":"))
            now = dt.datetime.now(dt.timezone.utc)
            self.deadline = now.replace(hour=hh, minute=mm, second=0, microsecond=0)
        self.started = dt.datetime.now(dt.timezone.utc)
        self.load_start = os.getloadavg()

    def write(self) -> None:
        with self.lock:
            atomic_write_json(self.args.out, {
                "command": "PYTHONPATH=. python benchmarks/set_field_tasks.py " + " ".join(
                    f"--{k.replace('_', '-')} {v}" for k, v in vars(self.args).items()
                    if v is not None),
                "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                            "load_at_start": self.load_start, "load_now": os.getloadavg()},
                "started_utc": self.started.isoformat(timespec="seconds"),
                "written_utc": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
                "seconds_per_run": self.per_run,
                "tasks": self.tasks})

    def plan_task(self, order: int, name: str) -> None:
        a = self.args
        work = Path(a.work) / name
        work.mkdir(parents=True, exist_ok=True)
        data = json.loads((ROOT / "scenarios" / "data" / f"{name}.json").read_text())
        hand = work / "hand.json"
        hand.write_text(json.dumps(with_uncertainty(data, a.mass, a.com, a.contacts), indent=1))
        code, secs, text = run([a.qsplan, "plan", str(hand), "--out", "plan.json"], work)
        task: dict[str, Any] = {
            "task": name, "hand": str(hand), "set": {"mass_fraction": a.mass, "com_m": a.com,
                                                     "contacts_m": a.contacts},
            "plan": {"exit_code": code, "seconds": round(secs, 2),
                     "output": text.strip().splitlines()[:4]},
            "jobs": []}
        with self.lock:
            self.tasks.append(task)
        plan_path = work / "plan.json"
        if code not in (0, 1) or not plan_path.exists():
            self.write()
            return
        plan = json.loads(plan_path.read_text())
        segs = plan.get("segments") or []
        unc = (plan.get("extra") or {}).get("uncertainty") or {}
        task["plan"].update(
            segments=len(segs), modes=[s["claim"] for s in segs],
            waypoints=sum(len(s["waypoints"]) for s in segs),
            reached=plan.get("reached"), set=unc.get("set"), tolerated=unc.get("tolerated"))
        if not segs:
            self.write()
            return
        from planner.plan.plan_file import load_plan
        from planner.plan.set_points import plan_axes, set_points

        p = load_plan(plan_path)
        axes = plan_axes(p)
        nominal = {ax.key: ax.nominal for ax in axes}
        halves = {"mass": next(ax.half for ax in axes if ax.key == "m"),
                  "com": max(ax.half for ax in axes if ax.key in ("cx", "cy")),
                  "contacts": max([ax.half for ax in axes if ax.key.startswith("s")],
                                  default=0.0)}
        reach = reach_in_half_widths(unc.get("tolerated") or {}, halves)
        steps = []
        for word in a.outside.split(",") if a.outside else []:
            k = beyond_step(reach) if word == "beyond" else float(word)
            if k is not None:
                steps.append(round(k, 4))
        task.update(axes=[{"key": ax.key, "name": ax.name, "lo": ax.lo, "hi": ax.hi,
                           "nominal": ax.nominal} for ax in axes],
                    half_widths=halves, reach_past_set_half_widths=reach, outside_steps=steps,
                    nominal=nominal)
        n_set = len(set_points(axes, ("corners", "centre")))
        engines = a.engines.split(",")
        mus = list(p.validate_mu)
        for i, mu in enumerate(mus):
            for j, eng in enumerate(engines):
                tier = 0 if i == 0 else 2
                self.jobs.put(((tier, order, i, j), next(self.seq),
                               (task, eng, mu_text(mu), "corners,centre", None, n_set)))
        for s_i, step in enumerate(steps):
            n_out = len(set_points(axes, ("outside",), step))
            for j, eng in enumerate(engines):
                tier = 1 if j == 0 else 3
                self.jobs.put(((tier, order, s_i, j), next(self.seq),
                               (task, eng, mu_text(mus[0]), "outside", step, n_out)))
        self.write()

    def run_job(self, job: tuple[Any, ...]) -> None:
        task, eng, mu, kinds, step, n = job
        a = self.args
        est = (n + 1) * self.per_run.get(eng, 40.0)
        row: dict[str, Any] = {"engine": eng, "mu": mu, "set": kinds, "outside": step,
                               "points": n, "estimated_s": round(est, 1)}
        now = dt.datetime.now(dt.timezone.utc)
        if self.deadline is not None and now + dt.timedelta(seconds=est) > self.deadline:
            row["status"] = f"not run: estimated end after --deadline {a.deadline} UTC"
            with self.lock:
                task["jobs"].append(row)
            self.write()
            return
        work = Path(a.work) / task["task"]
        tag = f"{eng}_mu{mu.replace('/', '-')}_{kinds.replace(',', '-')}" + (
            f"_{step:g}" if step is not None else "")
        out = work / tag
        cmd = [a.qsplan, "validate", "plan.json", "--engine", eng, "--mu", mu, "--set", kinds,
               "--no-render", "--out", tag]
        if step is not None:
            cmd += ["--outside", f"{step:g}"]
        row["command"] = "qsplan " + " ".join(cmd[1:])
        row["started_utc"] = now.isoformat(timespec="seconds")
        code, secs, text = run(cmd, work)
        row.update(exit_code=code, wall_s=round(secs, 1),
                   output_tail=text.strip().splitlines()[-3:])
        rows = job_rows(task, out, step)
        row["runs"] = rows
        if rows:
            with self.lock:
                self.per_run[eng] = secs / (len(rows) + 1)
        with self.lock:
            task["jobs"].append(row)
        self.write()
        done = sum(r["passed"] for r in rows)
        print(f"{task['task']} {eng} mu={mu} {kinds} {step or ''}: exit {code}, {done}/"
              f"{len(rows)} as predicted, {secs:.0f} s", flush=True)

    def worker(self) -> None:
        while True:
            item = self.jobs.get()
            if item[2] is None:
                return
            self.run_job(item[2])


def job_line(job: dict[str, Any]) -> str:
    """One row of the table: the job, how many points ran and agreed, each point that did not
    (its status, what the planner predicts there, why the engine judged so) and, for outside
    points, whether each lies beyond the plan's stated reach of its axis."""
    what = job["set"] + (f" --outside {job['outside']:g}" if job.get("outside") else "")
    head = f"  {job['engine']} mu={job['mu']} {what}: "
    if "runs" not in job:
        return head + job.get("status", "")
    runs = job["runs"]
    ok = sum(r["status"] == "agreed" for r in runs)
    wall = "?" if job.get("wall_s") is None else f"{job['wall_s']:.0f}"
    text = head + f"{ok}/{len(runs)} agreed, exit {job.get('exit_code')}, {wall} s" + (
        "" if job.get("complete", True) else " (stopped: the points that finished)")
    for r in runs:
        beyond = r.get("beyond_reach")
        where = ("" if beyond is None else
                 f", {r['axis']} {1000 * r['distance']:.3g} {'g' if r['axis'] == 'm' else 'mm'}"
                 f" from nominal, {'beyond' if beyond else 'within'} the stated reach "
                 f"{1000 * r['stated_reach']:.3g}")
        if r["status"] != "agreed" or r["expect"] != "agree" or beyond:
            why = "" if r["status"] == "agreed" else f" ({r['reason']})"
            text += (f"\n    {r['point']}: {r['status']}, predicted {r['expect']}{where}"
                     f"{why}")
    return text


def table(result: dict[str, Any]) -> str:
    """The results of a run (the JSON this script writes) as text, per task and job."""
    lines = []
    for t in result["tasks"]:
        p = t["plan"]
        tol = p.get("tolerated") or {}
        lines.append(f"{t['task']}: plan exit {p['exit_code']} in {p['seconds']:.0f} s, "
                     f"{p.get('segments')} segment(s) {p.get('modes')}, {p.get('waypoints')} "
                     f"waypoints; tolerated mass {tol.get('mass_kg')} kg, com "
                     f"{tol.get('com_m')} m, contacts {tol.get('contacts_m')} m; reach past "
                     f"the set (half-widths) {t.get('reach_past_set_half_widths')}")
        lines += [job_line(j) for j in t["jobs"]]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--engines", default="pymunk,mujoco")
    ap.add_argument("--outside", default="0.25,beyond",
                    help="outside steps: numbers (half-widths past the set) or 'beyond' "
                         "(the contact axes past the planner's stated reach)")
    ap.add_argument("--mass", type=float, default=0.2, help="mass +- fraction (default 0.2)")
    ap.add_argument("--com", type=float, default=0.005, help="centre of mass +- m (0.005)")
    ap.add_argument("--contacts", type=float, default=0.002,
                    help="every contact +- m along its feature (0.002)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--deadline", default=None, help="UTC HH:MM: no job that would end later")
    ap.add_argument("--work", default="/tmp/set_field_tasks", help="hand files, plans, runs")
    ap.add_argument("--qsplan", default=str(Path(sys.executable).with_name("qsplan")))
    ap.add_argument("--out", default="benchmarks/results/set_field_tasks.json")
    ap.add_argument("--table", default=None, metavar="JSON",
                    help="print the table of a finished (or stopped) run's JSON and exit")
    ap.add_argument("--record", nargs="+", default=None,
                    metavar="TASK TAG EXIT WALL_S [FOLDER]",
                    help="add a job run by hand to --out (record; '?' for an exit code or "
                         "wall time not known) and exit")
    args = ap.parse_args()
    if args.record:
        t, tag, code, wall, *folder = args.record
        record(args.out, t, tag, None if code == "?" else int(code),
               None if wall == "?" else float(wall), folder[0] if folder else None)
        return
    if args.table:
        print(table(json.loads(Path(args.table).read_text())))
        return
    bench = Bench(args)
    threads = [threading.Thread(target=bench.worker) for _ in range(args.workers)]
    for t in threads:
        t.start()
    for order, name in enumerate(args.tasks.split(",")):
        bench.plan_task(order, name)
        print(f"{name}: planned, {bench.tasks[-1]['plan']}", flush=True)
    for _ in range(args.workers):
        bench.jobs.put(((9, 0, 0, 0), next(bench.seq), None))
    for t in threads:
        t.join()
    bench.write()


if __name__ == "__main__":
    main()
