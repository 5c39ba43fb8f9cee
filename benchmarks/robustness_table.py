"""Robustness table: long fuzz campaigns, cross-checked answers and the fault suite.

Campaigns (each ``--n`` inputs unless stated):

``system loader: mutated trees``
    valid system files (``tests/planner/test_fuzz.py:seed_system_files``: the paper's examples, a
    chain-form hand, random systems in every manipulator form) mutated by ``mutate_tree`` --
    including the values and nesting depths known to crash (``KNOWN_CRASH_VALUES``, depth 5000)
    -- and fed to ``system_from_dict``; an accepted system must round-trip through
    ``system_to_dict`` (else: wrong answer) and ``feasible_modes`` must answer.
``system loader: file bytes``
    the same files serialised and corrupted by ``mutate_text`` (truncated, bit flips, non-UTF-8,
    NaN literals, deep nesting, BOM, duplicate keys), written to disk and read by ``load_system``.
``system loader: hypothesis JSON``
    hypothesis' arbitrary JSON trees and "plausible" system dicts (``tests/planner/test_fuzz.py``).
``plan loader: mutated files``
    if ``planner.plan.plan_file`` exists: a valid plan file mutated at tree and byte level and
    read by
    ``load_plan``; a mutation that changes a value but keeps the stale digest must be rejected
    (else: wrong answer).
``feasible_modes: random systems`` / ``feasible_modes: degenerate systems``
    seeded random systems (``tests/randsys.py``; 2-6 contacts, 0-2 effort joints, scale
    ``1e-3..1e3``) and degenerate ones (coincident / nearly coincident contacts, parallel or
    concurrent lines of action, zero speeds, ``mu = 0`` or huge, zero load, extreme scales,
    zero Jacobian columns, the Sec. 5.1 rod exactly on ``l1 mu2 = l2 mu1``). Cross-checks, each
    a *wrong answer* when it fails: every certificate re-checked by ``tests/certify.py``; the
    mode labels unchanged under a relative ``1e-12`` perturbation of every input number unless
    one of the two predictions flags a boundary; every ``--search-every``-th system also through
    ``planner.predict.search.search_modes``, which must list the same modes.
``public API: argument fuzz``
    garbage arguments to ``System.from_contacts``, ``System.from_wrench_matrix`` and
    ``feasible_modes(system, mu, tol=...)``.
``simulator fault suite``
    every injected fault of ``tests/sim/test_sim_faults.py`` on both engines plus clean runs: a
    missed fault or a false alarm is a wrong answer.

A *crash* is any exception that is not a ``planner.errors.QsplanError`` (the documented
types); crashes are grouped by exception type and innermost project frame. *Boundary cases*
are inputs whose prediction the tool itself flagged as within tolerance of a boundary
(``on_boundary`` or ``boundary_modes``).

    PYTHONPATH=. python benchmarks/robustness_table.py --n 10000 \
        --out benchmarks/results/robustness_table.json

Writes JSON (atomic) and prints a Markdown table. ``--n 300`` is a 1-minute smoke run.
``--only overhead`` times ``sim.run.EngineWatch`` (same run with and without, both engines).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import platform
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from certify import check_certificate  # noqa: E402
from randsys import random_system  # noqa: E402
from test_fuzz import (  # noqa: E402
    KNOWN_CRASH_LITERALS,
    KNOWN_CRASH_VALUES,
    LITERALS,
    NASTY_VALUES,
    json_values,
    mutate_text,
    mutate_tree,
    plausible_system,
    seed_system_files,
    system_round_trips,
)

from planner import QsplanError, System, feasible_modes  # noqa: E402
from planner.files.atomic import atomic_write_json  # noqa: E402
from planner.files.system_file import load_system, system_from_dict, system_to_dict  # noqa: E402
from planner.model.system import JointControl  # noqa: E402


# ---------------------------------------------------------------------------------------------
# Bookkeeping
# ---------------------------------------------------------------------------------------------
@dataclass
class Campaign:
    """Counts of one campaign (one row of the table)."""

    name: str
    inputs: int = 0
    accepted: int = 0
    rejected: int = 0
    crashes: int = 0
    wrong: int = 0
    boundary: int = 0
    seconds: float = 0.0
    crash_kinds: dict[str, dict[str, Any]] = field(default_factory=dict)
    wrong_kinds: dict[str, dict[str, Any]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def crash(self, exc: BaseException, example: str) -> None:
        self.crashes += 1
        frames = [f for f in traceback.extract_tb(exc.__traceback__)
                  if "/planner/" in f.filename or "/sim/" in f.filename]
        def at(f: traceback.FrameSummary) -> str:
            return f"{Path(f.filename).parent.name}/{Path(f.filename).name}:{f.lineno} {f.name}"

        where = "outside the project"
        if frames:
            where = at(frames[-1])
            if len(frames) > 1:
                where += f" (from {at(frames[0])})"
        key = f"{type(exc).__name__} at {where.split(' (from ')[0]}"
        slot = self.crash_kinds.setdefault(key, {"count": 0, "message": str(exc)[:200],
                                                 "call": where, "example": example[:300]})
        slot["count"] += 1

    def wrong_answer(self, kind: str, example: str) -> None:
        self.wrong += 1
        slot = self.wrong_kinds.setdefault(kind, {"count": 0, "example": example})
        slot["count"] += 1

    def guarded(self, fn: Callable[..., Any], *args: Any, example: str = "",
                count_rejection: bool = False, **kwargs: Any) -> tuple[bool, Any]:
        """``(ok, value)``: ok False on a documented rejection (counted in ``rejected`` when
        ``count_rejection``) or a (recorded) crash."""
        try:
            return True, fn(*args, **kwargs)
        except QsplanError:
            self.rejected += count_rejection
            return False, None
        except RecursionError as exc:  # keep the traceback short
            self.crash(exc, example)
            return False, None
        except Exception as exc:  # noqa: BLE001 - counting every non-project exception
            self.crash(exc, example)
            return False, None

    def row(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in (
            "name", "inputs", "accepted", "rejected", "crashes", "wrong", "boundary", "seconds",
            "crash_kinds", "wrong_kinds", "notes")}


def _short(value: Any, limit: int = 20_000) -> str:
    """JSON text of ``value`` (at most ``limit`` characters) for reproducing a finding."""
    try:
        text = json.dumps(value, default=str)
    except (ValueError, RecursionError):
        text = repr(type(value))
    return text if len(text) <= limit else text[:limit - 3] + "..."


# ---------------------------------------------------------------------------------------------
# Loader campaigns
# ---------------------------------------------------------------------------------------------
def _solve_accepted(c: Campaign, system: System, example: str) -> None:
    ok, pred = c.guarded(feasible_modes, system, example=example)
    if ok and (pred.on_boundary or pred.boundary_modes):
        c.boundary += 1


def system_tree_campaign(n: int, seed: int) -> Campaign:
    c = Campaign("system loader: mutated trees")
    seeds = seed_system_files()
    rng = np.random.default_rng(seed)
    values = NASTY_VALUES + KNOWN_CRASH_VALUES
    for _ in range(n):
        data = mutate_tree(seeds[int(rng.integers(len(seeds)))], rng, deep=(3, 50, 5000),
                           values=values)
        example = _short(data)
        c.inputs += 1
        ok, system = c.guarded(system_from_dict, data, example=example, count_rejection=True)
        if not ok:
            continue
        c.accepted += 1
        rt_ok, same = c.guarded(system_round_trips, system, example=example)
        if rt_ok and not same:
            c.wrong_answer("accepted system does not round-trip through its file form", example)
        _solve_accepted(c, system, example)
    return c


def system_bytes_campaign(n: int, seed: int, workdir: Path) -> Campaign:
    c = Campaign("system loader: file bytes")
    seeds = [json.dumps(d, indent=1) for d in seed_system_files()]
    rng = np.random.default_rng(seed)
    path = workdir / "system.json"
    for _ in range(n):
        blob = mutate_text(seeds[int(rng.integers(len(seeds)))], rng,
                           literals=LITERALS + KNOWN_CRASH_LITERALS)
        path.write_bytes(blob)
        example = repr(blob[:300])
        c.inputs += 1
        ok, system = c.guarded(load_system, path, example=example, count_rejection=True)
        if not ok:
            continue
        c.accepted += 1
        _solve_accepted(c, system, example)
    return c


def hypothesis_campaign(n: int) -> Campaign:
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import strategies as st

    c = Campaign("system loader: hypothesis JSON")

    @settings(max_examples=n, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(st.one_of(json_values, plausible_system()))
    def run(data: Any) -> None:
        example = _short(data)
        c.inputs += 1
        ok, system = c.guarded(system_from_dict, data, example=example, count_rejection=True)
        if ok:
            c.accepted += 1
            _solve_accepted(c, system, example)

    run()
    return c


def plan_campaign(n: int, seed: int, workdir: Path) -> Campaign:
    """Inputs rotate over stale-digest tree mutations, re-signed ones and byte mutations."""
    c = Campaign("plan loader: mutated files")
    try:
        import test_fuzz_plan as tfp
    except ImportError as exc:
        c.notes.append(f"not run: {exc}")
        return c
    rng = np.random.default_rng(seed)
    base_path = tfp.valid_plan_file(workdir)
    base_text = base_path.read_text()
    base = json.loads(base_text)
    path = workdir / "plan.json"
    kinds = {"stale digest": 0, "re-signed": 0, "bytes": 0}
    for k in range(n):
        kind = ("stale digest", "re-signed", "bytes")[k % 3]
        kinds[kind] += 1
        if kind == "bytes":
            blob = mutate_text(base_text, rng, literals=LITERALS + KNOWN_CRASH_LITERALS)
            path.write_bytes(blob)
            example = repr(blob[:300])
        else:
            data = mutate_tree(base, rng, deep=(3, 50, 5000),
                               values=NASTY_VALUES + KNOWN_CRASH_VALUES)
            if kind == "re-signed":
                tfp.resign(data)
            tfp._write(path, data)
            example = f"{kind}: {_short(data, 2000)}"
        c.inputs += 1
        ok, plan = c.guarded(tfp.load_plan, path, example=example, count_rejection=True)
        if not ok:
            continue
        c.accepted += 1
        if kind != "re-signed" and not tfp.same_plan_content(plan, base_path):
            c.wrong_answer("tampered or corrupted plan accepted", example)
        if kind == "re-signed" and not all(np.all(np.isfinite(s.poses()))
                                           and np.all(np.diff(s.times()) > 0)
                                           for s in plan.segments):
            c.wrong_answer("re-signed plan with non-finite poses or unordered times", example)
    c.notes.append(f"inputs per kind: {kinds}")
    return c


# ---------------------------------------------------------------------------------------------
# Public API campaigns
# ---------------------------------------------------------------------------------------------
def system_kwargs(s: System) -> dict[str, Any]:
    kw: dict[str, Any] = dict(points=s.points.copy(), normals=s.normals.copy(), mu=s.mu.copy(),
                              external_wrench=s.g_obj.copy())
    if s.virtual_joints:
        kw["contact_velocities"] = s.joint_inputs.reshape(-1, 2).copy()
    else:
        kw["jacobian"] = s.J.reshape(s.n_contacts, 2, -1).copy()
        kw["joints"] = [{"velocity" if c is JointControl.VELOCITY else "effort": float(v)}
                        for c, v in zip(s.control, s.joint_inputs)]
        kw["joint_loads"] = s.g_man.copy()
    return kw


def exact_dict(s: System) -> dict[str, Any]:
    """Every field of ``s`` as JSON (bit-exact floats), see :func:`system_from_exact`."""
    out: dict[str, Any] = {k: getattr(s, k).tolist() for k in (
        "W", "mu", "g_obj", "J", "joint_inputs", "g_man", "points", "normals")}
    out["control"] = [c.value for c in s.control]
    out["virtual_joints"] = bool(s.virtual_joints)
    return out


def system_from_exact(d: dict[str, Any]) -> System:
    """The exact system of a finding (no re-normalisation, unlike the file loader)."""
    kw = dict(d)
    kw["control"] = tuple(JointControl(c) for c in d["control"])
    return System(**kw)


def _perturb_tree(tree: Any, rng: np.random.Generator, eps: float) -> Any:
    if isinstance(tree, dict):
        return {k: _perturb_tree(v, rng, eps) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_perturb_tree(v, rng, eps) for v in tree]
    if isinstance(tree, float):
        return tree * (1.0 + eps * rng.uniform(-1.0, 1.0))
    return tree


def perturbed(system: System, rng: np.random.Generator, eps: float = 1e-12) -> System:
    """Every number of the system file multiplied by ``1 + eps u``, ``u ~ U(-1, 1)``."""
    return system_from_dict(_perturb_tree(system_to_dict(system), rng, eps))


def random_case(rng: np.random.Generator) -> tuple[str, System]:
    n_c = int(rng.integers(2, 7))
    n_e = int(rng.integers(0, 3))
    scale = float(10.0 ** rng.uniform(-3, 3))
    return f"random n_c={n_c} effort={n_e}", random_system(rng, n_c, n_e, scale=scale)


DEGENERATE_KINDS = (
    "coincident", "near_coincident", "parallel", "concurrent", "zero_speed", "mu_zero",
    "mu_huge", "zero_load", "extreme_scale", "zero_jacobian_column", "rod_boundary",
    "collinear_points",
)


def degenerate_case(rng: np.random.Generator) -> tuple[str, System]:
    kind = DEGENERATE_KINDS[int(rng.integers(len(DEGENERATE_KINDS)))]
    n_c = int(rng.integers(3, 6))
    base = random_system(rng, n_c, int(rng.integers(0, 2)))
    kw = system_kwargs(base)
    if kind == "coincident":
        for key in ("points", "normals", "mu", "contact_velocities", "jacobian"):
            if key in kw:
                kw[key] = np.concatenate([kw[key], kw[key][:1]])
    elif kind == "near_coincident":
        for key in ("points", "normals", "mu", "contact_velocities", "jacobian"):
            if key in kw:
                kw[key] = np.concatenate([kw[key], kw[key][:1]])
        kw["points"][-1] = kw["points"][-1] + 1e-13 * rng.normal(size=2)
    elif kind == "parallel":
        kw["normals"] = np.tile([[0.0, 1.0]], (n_c, 1))
        kw["points"] = np.c_[np.sort(rng.uniform(-1, 1, n_c)), np.zeros(n_c)]
    elif kind == "concurrent":
        ang = np.sort(rng.uniform(0, 2 * np.pi, n_c))
        kw["points"] = np.c_[np.cos(ang), np.sin(ang)]
        kw["normals"] = -kw["points"]
    elif kind == "zero_speed":
        if "contact_velocities" in kw:
            kw["contact_velocities"] = np.zeros_like(kw["contact_velocities"])
        else:
            kw["joints"] = [{k: (0.0 if k == "velocity" else v)} for j in kw["joints"]
                            for k, v in j.items()]
    elif kind == "mu_zero":
        kw["mu"] = np.zeros(n_c)
    elif kind == "mu_huge":
        kw["mu"] = np.full(n_c, 1e6)
    elif kind == "zero_load":
        kw["external_wrench"] = np.zeros(3)
        if "joint_loads" in kw:
            kw["joint_loads"] = np.zeros_like(kw["joint_loads"])
    elif kind == "extreme_scale":
        length, load, speed = (10.0 ** rng.uniform(-9, 9, 3))
        kw["points"] = kw["points"] * length
        kw["external_wrench"] = kw["external_wrench"] * np.array([load, load, load * length])
        if "contact_velocities" in kw:
            kw["contact_velocities"] = kw["contact_velocities"] * speed
        else:
            kw["joint_loads"] = kw["joint_loads"] * load
            kw["joints"] = [{k: v * (speed if k == "velocity" else load)} for j in kw["joints"]
                            for k, v in j.items()]
    elif kind == "zero_jacobian_column":
        if "jacobian" in kw:
            kw["jacobian"][:, :, int(rng.integers(kw["jacobian"].shape[2]))] = 0.0
        else:
            kw["contact_velocities"][int(rng.integers(n_c))] = 0.0
    elif kind == "rod_boundary":
        l1, l2, mu1 = rng.uniform(0.05, 1.0, 3)
        mu2 = l2 * mu1 / l1  # l1 mu2 = l2 mu1 up to rounding: Fig. 8's switching line
        speed = float(rng.uniform(0.1, 2.0))
        kw = dict(points=[[-l1, 0.0], [l2, 0.0]], normals=[[0.0, 1.0], [0.0, 1.0]],
                  mu=[mu1, mu2], external_wrench=[0.0, -1.0, 0.0],
                  contact_velocities=[[0.0, -speed], [0.0, speed]])
    elif kind == "collinear_points":
        kw["points"] = np.c_[np.linspace(-1, 1, n_c), np.zeros(n_c)]
    return kind, System.from_contacts(**kw)


def _flagged(pred: Any) -> bool:
    return bool(pred.on_boundary or pred.boundary_modes)


def feasibility_campaign(name: str, make: Callable[[np.random.Generator], tuple[str, System]],
                         n: int, seed: int, search_every: int) -> Campaign:
    from planner.predict.search import search_modes

    c = Campaign(name)
    rng = np.random.default_rng(seed)
    per_kind: dict[str, int] = {}
    boundary_kind: dict[str, int] = {}
    for k in range(n):
        ok, made = c.guarded(make, rng, example=f"generator seed {seed} input {k}",
                             count_rejection=True)
        c.inputs += 1
        if not ok:
            continue
        kind, system = made
        per_kind[kind.split(" ")[0]] = per_kind.get(kind.split(" ")[0], 0) + 1
        example = f"{kind}: {_short(exact_dict(system))}"
        ok, pred = c.guarded(feasible_modes, system, example=example, count_rejection=True)
        if not ok:
            continue
        c.accepted += 1
        flagged = _flagged(pred)
        for fm in pred.modes + pred.indeterminate_modes:
            try:
                check_certificate(system, fm)
            except AssertionError as exc:
                what = " ".join(str(exc).split(" ")[2:5]) if str(exc).startswith("contact") \
                    else " ".join(str(exc).split(" ")[:3])
                cls = "force-indeterminate" if fm.force_indeterminate else "determinate"
                c.wrong_answer(f"certificate re-check fails ({cls} mode, {kind.split(' ')[0]}"
                               f" input): {what}", f"{fm.label} ({exc}); {example}")
        ok_p, other = c.guarded(perturbed, system, rng, example=example)
        if ok_p:
            ok_q, pred2 = c.guarded(feasible_modes, other, example=example)
            if ok_q:
                flagged |= _flagged(pred2)
                if sorted(pred.labels) != sorted(pred2.labels) and not flagged:
                    c.wrong_answer("labels flip under a 1e-12 perturbation, no boundary flag",
                                   f"{pred.labels} vs {pred2.labels}; {example}")
        if search_every and k % search_every == 0:
            ok_s, res = c.guarded(search_modes, system, example=example)
            if ok_s and sorted(res.prediction.labels) != sorted(pred.labels):
                c.wrong_answer("search_modes lists other modes than feasible_modes",
                               f"{res.prediction.labels} vs {pred.labels}; {example}")
        c.boundary += flagged
        short = kind.split(" ")[0]
        boundary_kind[short] = boundary_kind.get(short, 0) + flagged
    c.notes.append(f"inputs per kind: {dict(sorted(per_kind.items()))}")
    c.notes.append(f"boundary-flagged per kind: {dict(sorted(boundary_kind.items()))}")
    return c


def api_argument_campaign(n: int, seed: int) -> Campaign:
    c = Campaign("public API: argument fuzz")
    rng = np.random.default_rng(seed)
    pool = NASTY_VALUES + KNOWN_CRASH_VALUES

    def junk(shape: tuple[int, ...]) -> Any:
        r = rng.random()
        if r < 0.5:
            a = rng.normal(size=shape) * 10.0 ** rng.uniform(-300, 300)
            if a.size and rng.random() < 0.3:
                a.flat[int(rng.integers(a.size))] = float(rng.choice([np.nan, np.inf, -np.inf]))
            return a.tolist()
        if r < 0.8:
            return pool[int(rng.integers(len(pool)))]
        return rng.normal(size=tuple(int(rng.integers(0, 4)) for _ in range(len(shape))))

    base = random_system(rng, 3, 0, virtual=True)
    for _ in range(n):
        n_c = int(rng.integers(0, 6))
        form = int(rng.integers(3))
        c.inputs += 1
        if form == 0:
            args = dict(points=junk((n_c, 2)), normals=junk((n_c, 2)), mu=junk((n_c,)),
                        external_wrench=junk((3,)), contact_velocities=junk((n_c, 2)))
            ok, s = c.guarded(System.from_contacts, example=_short(args), count_rejection=True,
                              **args)
        elif form == 1:
            args = dict(W=junk((3, 2 * n_c)), mu=junk((n_c,)), external_wrench=junk((3,)),
                        contact_velocities=junk((n_c, 2)))
            ok, s = c.guarded(lambda a=args: System.from_wrench_matrix(
                a["W"], a["mu"], external_wrench=a["external_wrench"],
                contact_velocities=a["contact_velocities"]), example=_short(args),
                count_rejection=True)
        else:
            s, ok = base, True
        if not ok:
            continue
        mu = junk((s.n_contacts,)) if rng.random() < 0.7 else None
        tol = float(rng.choice([1e-9, 0.0, -1.0, math.nan, math.inf, 1e300]))
        ok, pred = c.guarded(feasible_modes, s, mu, tol=tol, example=f"mu={_short(mu)} tol={tol}",
                             count_rejection=True)
        if ok:
            c.accepted += 1
            c.boundary += _flagged(pred)
    return c


# ---------------------------------------------------------------------------------------------
# Simulator fault suite
# ---------------------------------------------------------------------------------------------
def fault_campaign(workdir: Path) -> Campaign:
    import dataclasses

    import test_sim_faults as tsf

    from sim.backends import make_backend
    from sim.run import FaultKind, run_scene
    from sim.scene import Load
    from sim.verdict import Outcome

    c = Campaign("simulator fault suite")
    cases: list[tuple[str, str, Callable[[], Any], FaultKind | None]] = []
    for eng in tsf.ENGINES:
        cases += [
            (eng, "NaN load", lambda e=eng: run_scene(dataclasses.replace(
                tsf._scene(), loads=(Load("workpiece", (np.nan, -1.0), 0.0),)),
                make_backend(e), tsf._settings()), FaultKind.NAN),
            (eng, "contact lost at start", lambda e=eng: run_scene(
                tsf._scene(gap=1e-3), make_backend(e), tsf._settings()),
             FaultKind.CONTACT_LOST_AT_START),
            (eng, "body leaves the scene", lambda e=eng: run_scene(dataclasses.replace(
                tsf._scene(), loads=(Load("workpiece", (-15.0, 50.0), 0.0),),
                bounds=(-0.3, -0.3, 0.3, 0.3)), make_backend(e),
                tsf._settings(duration=2.0, penetration_tol=1.0)), FaultKind.LEFT_SCENE),
            (eng, "penetration beyond tolerance", lambda e=eng: run_scene(
                tsf._scene(), make_backend(e), tsf._settings(penetration_tol=1e-7)),
             FaultKind.PENETRATION),
            (eng, "clean run", lambda e=eng: run_scene(tsf._scene(), make_backend(e),
                                                       tsf._settings()), None),
        ]
        for value in (np.nan, np.inf, 1e13):
            want = FaultKind.NAN if (eng == "mujoco" or not np.isfinite(value)) else \
                FaultKind.LEFT_SCENE
            cases.append((eng, f"{value} finger command", lambda e=eng, v=value: run_scene(
                tsf._command_after(tsf._scene(), v), make_backend(e), tsf._settings()), want))
    cases.append(("mujoco", "arena too small (CONTACTFULL/CNSTRFULL)", _small_arena_run,
                  FaultKind.ENGINE_WARNING))
    cases.append(("pymunk", "exception swallowed in a collision callback",
                  lambda: run_scene(tsf._scene(), tsf._FailingReadout(), tsf._settings()),
                  FaultKind.ENGINE_WARNING))
    cwd = os.getcwd()
    os.chdir(workdir)  # MuJoCo writes MUJOCO_LOG.TXT into the working directory
    rows = []
    try:
        for eng, label, run, want in cases:
            c.inputs += 1
            with contextlib.redirect_stdout(io.StringIO()):
                ok, rec = c.guarded(run, example=f"{eng}: {label}")
            if not ok:
                rows.append((eng, label, "crash"))
                continue
            got = rec.fault.kind if rec.fault is not None else None
            judged = tsf._judge(rec).outcome
            rows.append((eng, label, rec.fault.reason if rec.fault else "no fault"))
            if got != want or (want is not None and judged != Outcome.FAULT):
                c.wrong_answer("fault missed or false alarm",
                               f"{eng} {label}: expected {want}, got {got} ({judged})")
            else:
                c.accepted += 1
    finally:
        os.chdir(cwd)
    c.notes += [f"{e} | {lbl} | {r}" for e, lbl, r in rows]
    return c


def watch_overhead_campaign(workdir: Path, repeat: int = 3) -> Campaign:
    """Cost of ``sim.run.EngineWatch``: the same 1000-step run with and without it, both
    engines, best of ``repeat``, in this process (ratios in ``notes``; not part of the table
    unless asked for with ``--only overhead``)."""
    import test_sim_faults as tsf

    from sim.backends import make_backend
    from sim.run import EngineWatch, run_scene

    c = Campaign("EngineWatch overhead")
    cwd = os.getcwd()
    os.chdir(workdir)

    def best(engine: str) -> float:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            run_scene(tsf._scene(), make_backend(engine), tsf._settings(duration=1.0))
            times.append(time.perf_counter() - t0)
        return min(times)

    check, step = EngineWatch.check, EngineWatch.step
    try:
        for engine in tsf.ENGINES:
            with_watch = best(engine)
            EngineWatch.check = lambda self: None  # type: ignore[method-assign]
            EngineWatch.step = lambda self, dt: self.backend.step(dt)  # type: ignore
            without = best(engine)
            EngineWatch.check, EngineWatch.step = check, step  # type: ignore[method-assign]
            c.inputs += 2 * repeat
            c.notes.append(f"{engine}: 1000 steps {with_watch:.3f} s with the watch, "
                           f"{without:.3f} s without, ratio {with_watch / without:.3f}")
    finally:
        EngineWatch.check, EngineWatch.step = check, step  # type: ignore[method-assign]
        os.chdir(cwd)
    return c


def _small_arena_run() -> Any:
    import mujoco
    import test_sim_faults as tsf

    import sim.backends.mujoco_engine as mb
    from sim.run import run_scene

    real = mujoco.MjSpec

    def small() -> Any:
        spec = real()
        spec.memory = 2000
        return spec

    mb.mujoco.MjSpec = small
    try:
        return run_scene(tsf._scene(), mb.MujocoBackend(), tsf._settings())
    finally:
        mb.mujoco.MjSpec = real


# ---------------------------------------------------------------------------------------------
def _markdown(rows: list[dict[str, Any]]) -> str:
    head = ("| campaign | inputs tried | accepted | rejected (documented error) | crashes | "
            "wrong answers | boundary cases | time [s] |\n|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        lines.append(f"| {r['name']} | {r['inputs']} | {r['accepted']} | {r['rejected']} | "
                     f"{r['crashes']} | {r['wrong']} | {r['boundary']} | {r['seconds']:.0f} |")
    tot = {k: sum(r[k] for r in rows) for k in ("inputs", "crashes", "wrong", "boundary")}
    lines.append(f"| **total** | {tot['inputs']} | | | {tot['crashes']} | {tot['wrong']} | "
                 f"{tot['boundary']} | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10_000, help="inputs per campaign")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--search-every", type=int, default=10,
                    help="cross-check every k-th system with search_modes (0: never)")
    ap.add_argument("--only", default="", help="comma-separated campaign keys to run")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    keys = {
        "tree": lambda wd: system_tree_campaign(args.n, args.seed),
        "bytes": lambda wd: system_bytes_campaign(args.n, args.seed + 1, wd),
        "hypothesis": lambda wd: hypothesis_campaign(args.n),
        "plan": lambda wd: plan_campaign(args.n, args.seed + 2, wd),
        "random": lambda wd: feasibility_campaign(
            "feasible_modes: random systems", random_case, args.n, args.seed + 3,
            args.search_every),
        "degenerate": lambda wd: feasibility_campaign(
            "feasible_modes: degenerate systems", degenerate_case, args.n, args.seed + 4,
            args.search_every),
        "api": lambda wd: api_argument_campaign(args.n, args.seed + 5),
        "faults": fault_campaign,
        "overhead": watch_overhead_campaign,
    }
    chosen = [k for k in keys if (k in args.only.split(",")) or (not args.only and k != "overhead")]
    # overflow warnings of extreme-scale inputs are expected; the answers are what we check
    warnings.simplefilter("ignore", RuntimeWarning)
    rows = []
    with tempfile.TemporaryDirectory(prefix="qsplan-robust-") as tmp:
        for key in chosen:
            t0 = time.perf_counter()
            camp = keys[key](Path(tmp))
            camp.seconds = time.perf_counter() - t0
            rows.append(camp.row())
            print(f"{camp.name}: {camp.inputs} inputs, {camp.crashes} crashes, "
                  f"{camp.wrong} wrong, {camp.boundary} boundary ({camp.seconds:.0f} s)",
                  file=sys.stderr)
            if key == "overhead":
                print("    " + "\n    ".join(camp.notes), file=sys.stderr)
            for kind, info in camp.crash_kinds.items():
                print(f"    crash x{info['count']}: {kind}: {info['message'][:120]}",
                      file=sys.stderr)
            for kind, info in camp.wrong_kinds.items():
                print(f"    wrong x{info['count']}: {kind}: {info['example'][:160]}",
                      file=sys.stderr)
    table = _markdown(rows)
    print(table)
    if args.out is not None:
        atomic_write_json(args.out, {
            "benchmark": "robustness_table",
            "command": "PYTHONPATH=. python benchmarks/robustness_table.py " +
                       " ".join(argv if argv is not None else sys.argv[1:]),
            "n_per_campaign": args.n,
            "seed": args.seed,
            "python": platform.python_version(),
            "numpy": np.__version__,
            "campaigns": rows,
            "markdown": table,
        })
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
