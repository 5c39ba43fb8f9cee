"""``qsplan modes SYSTEM.json [--mu 0.2,0.3,0.1] [--json] [--search [--workers N | --dask ADDR]]``:
all feasible contact modes (exhaustive eq. 49 enumeration, or the exact pruned search)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

from planner.errors import InputError
from qsplan.options import (
    MU_MAX,
    check_int,
    fmt,
    fmt_list,
    input_warnings,
    parse_numbers,
)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "modes",
        help="all feasible contact modes of a system file, with certificates",
        description=(
            "Enumerate the candidate modes (eq. 49) of the system in SYSTEM.json and print every "
            "feasible one with its certificate: workpiece velocity qdot, joint velocities, "
            "contact forces and joint efforts (eqs. 24-28). Statuses: unique (one mode: it moves "
            "so), ambiguous (several: the model cannot tell which), jammed (driven, no mode: the "
            "commanded motion is impossible), at_rest (nothing driven, a static equilibrium "
            "holds), moving (nothing driven, no equilibrium: the load accelerates it, which way "
            "is printed), no_candidates (too few contacts); docs/conventions.md, 'Statuses'. "
            "Exit 0 on success, 2 on bad input."
        ),
    )
    p.add_argument("system", help="system file (JSON; see docs/file-formats.md)")
    p.add_argument(
        "--mu", help="friction coefficients, comma separated, one per contact (or one for all), "
                     "or GROUP=V,... for the file's friction groups"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--boundary", action="store_true",
                   help="also list the boundary-tolerance modes: candidates that miss a strict "
                        "kinematic constraint (a breaking contact separating, a sliding one "
                        "slipping) by at most the tolerance, with contact forces that satisfy "
                        "Coulomb; not feasible, counted by default; the same list with --search")
    p.add_argument(
        "--indeterminate", action=argparse.BooleanOptionalAction, default=None,
        help="search the relaxed-utility (force-indeterminate) modes at any n_c, whatever the "
             "cost (--indeterminate) or not at all (--no-indeterminate); default: while "
             "C(2 n_c, 3 + |tau_I|) row subsets fit the budget. A skipped search is printed "
             "as a limit",
    )
    p.add_argument(
        "--search", action="store_true",
        help="exact pruned search (planner.predict.search, docs/scaling.md) instead of testing "
             "every candidate: the same modes, far fewer tests for many contacts",
    )
    p.add_argument(
        "--workers", type=int, default=1,
        help="with --search: search subtrees on this many local processes",
    )
    p.add_argument(
        "--dask", default=None,
        help="with --search: search subtrees on a Dask scheduler, e.g. tcp://host:8786",
    )
    p.set_defaults(func=run)


def parse_mu(text: str | None) -> list[float] | None:
    """Parse ``"0.2,0.3,0.1"`` (finite, >= 0); errors name the bad token."""
    if text is None:
        return None
    return parse_numbers(text, "--mu", lo=0.0, hi=MU_MAX)


def mu_for(text: str | None, system: Any) -> Any:
    """The friction of ``--mu``: one value for all, one per contact, or ``GROUP=V,...`` for
    the system's friction groups (the other contacts keep the file's values)."""
    if text is None:
        return None
    if "=" not in text:
        values = parse_mu(text)
        assert values is not None
        return values[0] if len(values) == 1 else values
    from planner.model.layout import group_mu

    pairs = {}
    for item in text.split(","):
        name, _, value = item.partition("=")
        pairs[name.strip()] = parse_numbers(value, f"--mu {name.strip()}", lo=0.0,
                                            hi=MU_MAX)[0]
    if not system.friction_groups:
        raise InputError(f"--mu: expected numbers (the system file has no friction groups), "
                         f"got {text!r}")
    return group_mu(system.mu, system.friction_groups, pairs)


def run(args: argparse.Namespace) -> int:
    from planner.files.system_file import load_system
    from planner.predict.feasibility import feasible_modes

    check_int(args.workers, "--workers", 1, 1024)
    if not args.search and (args.workers != 1 or args.dask is not None):
        given = "--dask" if args.dask is not None else f"--workers {args.workers}"
        raise InputError(f"--workers/--dask: expected together with --search, got {given} "
                         "without --search")
    with input_warnings("modes"):
        system = load_system(args.system)
    mu = mu_for(args.mu, system)
    indeterminate = args.indeterminate
    stats = None
    if args.search:
        from planner.predict.search import search_modes
        from planner.sweeps.executor import make_executor

        executor = None
        if args.dask is not None or args.workers > 1:
            executor = make_executor(args.dask, args.workers)
        try:
            res = search_modes(
                system, mu, indeterminate=indeterminate, executor=executor,
                progress=(executor is not None and not getattr(args, "quiet", False)
                          and sys.stderr.isatty()),
            )
        finally:
            if executor is not None:
                executor.close()
        pred, stats = res.prediction, res.stats
    else:
        # Exhaustive enumeration streams its candidates in chunks (bounded memory at any n_c);
        # feasible_modes refuses, with the count, requests too large to finish.
        pred = feasible_modes(system, mu, indeterminate=indeterminate)
    if args.json:
        out = pred.to_dict()
        if stats is not None:
            out["search"] = stats.to_dict()
        from planner.files.atomic import jsonable

        json.dump(jsonable(out), sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
        return 0
    if getattr(args, "quiet", False):
        return 0
    print(format_prediction(pred, system, boundary=args.boundary))
    if stats is not None:
        # a candidate with sliding contacts can sit in both the S+ and the S- branch of a
        # contact, so the kinematic tests can outnumber the eq. (49) candidates
        print(f"\nsearch: {stats.tested} kinematic tests for the {stats.candidates} candidates "
              f"of eq. (49) (one per sliding-direction branch that reaches the candidate), "
              f"{stats.lp_solves} pruning LPs, {_engine_note(stats.engine)}")
    return 0


def _engine_note(engine: str) -> str:
    """Which engine ran the search, and why Python when the native core could not be built."""
    if engine == "native":
        return "native core"
    from planner.predict.native_search import native_status

    status = native_status()
    return "Python engine" + ("" if status.available else f" (native core: {status.reason})")


def _rounding_noise_to_zero(values: Any, tol: float) -> np.ndarray:
    """``values`` with entries below ``tol`` times the largest one set to zero: a velocity of
    -1.1e-16 next to 2.0 is rounding, and the tolerance policy (docs/conventions.md) judges it
    as zero, so the table prints it as 0."""
    arr = np.asarray(values, dtype=float)
    scale = float(np.max(np.abs(arr))) if arr.size else 0.0
    return np.where(np.abs(arr) <= tol * scale, 0.0, arr)


#: One sentence per status: what it means physically (docs/conventions.md, "Statuses").
STATUS_WORDS = {
    "unique": "one feasible mode: the system moves in it",
    "ambiguous": "several feasible modes: the model cannot tell which one happens (Sec. 4.3)",
    "jammed": "no feasible mode while driven: the commanded motion is impossible (a jam)",
    "at_rest": "nothing is driven and a static equilibrium holds: it stays",
    "moving": "nothing is driven and no static equilibrium holds: the load moves it",
    "no_candidates": "too few contacts for any mode (eq. 49)",
}


def format_contacts(system: Any, mu: Any) -> list[str]:
    """One line per contact: where it is, its frame, friction and manipulator velocity in the
    contact frame (computed from world-frame motion for a geometry-first file)."""
    labels = system.contact_labels or ("",) * system.n_contacts
    group_of = {i: g for g, members in system.friction_groups for i in members}
    lines = ["contacts (point, inward normal, mu; manipulator velocity (v_n, v_t) in the contact "
             "frame):"]
    for i in range(system.n_contacts):
        mu_text = fmt(mu[i], ".3g") + (f" ({group_of[i]})" if i in group_of else "")
        vel = ""
        if system.virtual_joints:
            v = system.joint_inputs[2 * i:2 * i + 2]
            vel = "  fixed" if system.environment[i] else f"  v {fmt_list(v.tolist())}"
        where = f"  {labels[i]}" if labels[i] else ""
        lines.append(f"  {i + 1:>3}  point {fmt_list(system.points[i].tolist())}  normal "
                     f"{fmt_list(system.normals[i].tolist())}  mu {mu_text}{vel}{where}")
    return lines


def format_prediction(pred: Any, system: Any = None, *, boundary: bool = False) -> str:

    """A readable table of a :class:`planner.predict.feasibility.Prediction` (numbers without
    ``-0`` or numpy type names; entries at rounding level, ``|x| <= tol * max|x|`` per column,
    printed as 0 -- ``--json`` keeps the raw values)."""
    lines = [
        f"status: {pred.status.value} -- {STATUS_WORDS.get(pred.status.value, '')}",
        f"candidates (eq. 49): {pred.candidates}   mu: {fmt_list(pred.mu)}",
    ]
    if pred.reason:
        lines.append(f"reason: {pred.reason}")
    if system is not None:
        lines += format_contacts(system, pred.mu)
    for limit in getattr(pred, "limits", ()):
        lines.append(f"limit: {limit}")
    if not pred.all_modes:
        lines.append("no feasible mode" + (" (jammed)" if pred.status.value == "jammed" else ""))
    if pred.all_modes:
        lines.append("")
        lines.append(f"feasible modes: {len(pred.all_modes)}")
    for m in pred.all_modes:
        flags = []
        if m.force_indeterminate:
            flags.append("force-indeterminate")
        if m.on_boundary:
            flags.append("on boundary")
        lines.append("")
        lines.append(f"mode {m.label}  ({m.mode.family})  margin {fmt(m.margin, '.3g')}"
                     + (f"  [{', '.join(flags)}]" if flags else ""))
        qdot = _rounding_noise_to_zero(m.qdot, pred.tol)
        per_body = " per body" if qdot.size > 3 else ""  # several workpieces: 3 per body
        lines.append(f"  qdot (vx, vy, omega){per_body}: {fmt_list(qdot.tolist())}")
        joint_v = _rounding_noise_to_zero(m.joint_velocities, pred.tol)
        lines.append(f"  joint velocities:     {fmt_list(joint_v.tolist())}")
        lines.append("  contact   v_n         v_t         c_n         c_t")
        vel = _rounding_noise_to_zero(m.contact_velocities, pred.tol)
        force = _rounding_noise_to_zero(m.contact_forces, pred.tol)
        for i, (v, c) in enumerate(zip(vel, force)):
            cells = "".join(f"{fmt(x, '<11.4g')} " for x in (v[0], v[1], c[0], c[1]))
            lines.append(f"  {i + 1:>7}   {cells.rstrip()}")
        efforts = _rounding_noise_to_zero(m.joint_efforts, pred.tol)
        lines.append(f"  joint efforts:        {fmt_list(efforts.tolist())}")
    if pred.boundary_modes:
        lines.append("")
        n_b = len(pred.boundary_modes)
        lines.append(f"boundary-tolerance modes: {n_b} (not feasible: each misses a strict "
                     "kinematic constraint by at most the tolerance, its forces within Coulomb; "
                     + ("listed below)" if boundary else "--boundary lists them)"))
        if boundary:
            lines += [f"  {signed_label(m)}" for m in pred.boundary_modes]
    return "\n".join(lines)


def signed_label(mode: Any) -> str:
    """A mode label in which a contact sliding at zero speed (no sign) reads ``S±``."""
    return " ".join(f"{'S±' if tok == 'S' else tok}{i + 1}" for i, tok in enumerate(mode.tokens))
