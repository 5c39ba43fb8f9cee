"""``qsplan validate PLAN.json --engine ENGINE[,ENGINE..] [--mu 0.1] [--out DIR]``: run a plan
in a simulator and compare observed with predicted modes and poses.

Several engines (``--engine pymunk,mujoco,dart``): the same runs in each, then per friction
value the verdicts side by side and their consensus (:mod:`sim.consensus`: the odd engine
and the engine artefact its run measured); ``--out`` holds one folder per engine and
``consensus.json``, and the exit code is the consensus verdicts'.

Default friction: every value of the plan's ``mu.validate`` list (the plan passes only if every
run agrees).  A plan guaranteed over a mass / centre-of-mass set also runs at the set's corners
and centre (``--set``, :mod:`qsplan.commands.validate_set`). Exit codes: 0 agreed, 1 disagreed
or inconclusive, 2 bad input (missing, malformed or tampered plan, bad option), 3 simulator
fault. The simulator is imported lazily inside :func:`run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.model.validation import FrictionValue
from qsplan.commands.validate_set import add_options as add_set_options
from qsplan.options import MU_MAX, fmt, parse_engines, parse_number
from scenarios.registry import RUN_ENTRIES
from sim.backends import ENGINES


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "validate",
        help="run a plan file in a simulator and compare observed with predicted modes",
        description=(
            "Run PLAN.json (written by `qsplan plan`) in slow motion in the chosen engine, "
            "classify the observed contact modes from contact data and compare them and the "
            "workpiece poses with the plan: the claimed mode on >= 95% of the segment and the "
            "final position within 2% of the travel. A plan of several segments (a whole "
            "task) runs in one continuous simulation (every segment's contacts in one scene, "
            "joints switching control at segment boundaries), sliced per segment for a verdict per "
            "segment and one for the whole. Exit 0 pass, 1 fail, 2 bad input, "
            "3 simulator fault."
        ),
        epilog="example: qsplan validate plan.json --engine mujoco --mu 0.1 --out val/",
    )
    p.add_argument("plan", help="plan file (JSON; see docs/plan-format.md)")
    p.add_argument("--engine", default="pymunk",
                   help=f"{' | '.join(ENGINES)}, or several comma-separated (verdicts side by "
                        f"side and their consensus; default pymunk)")
    p.add_argument("--mu", default=None,
                   help="friction to simulate: one number, or comma-separated values (each "
                        "its own run); a run with one coefficient per contact is written "
                        "a/b/c/...; default: the plan's mu.validate list")
    p.add_argument("--out", help="output folder: summary.json, timeline.png and animation.gif "
                                 "per run (subfolders mu_<value> when several); written "
                                 "into place only when every run has finished")
    p.add_argument("--no-render", action="store_true", help="skip the timeline and GIF")
    add_set_options(p)
    p.set_defaults(func=run)


MAX_RUNS = 100


def parse_mu_list(text: str) -> list[FrictionValue]:
    """``"0.1"`` or ``"0,0.1,0.2"`` -> coefficients (finite, >= 0), one run each; a run written
    ``"0.1/0.2/0.3"`` has one coefficient per contact (checked against the plan's contacts)."""
    want = ("comma-separated runs, each a coefficient or per-contact coefficients joined by "
            "'/' (e.g. 0.1,0.2 or 0.1/0.2/0.1/0.1)")
    runs = str(text).split(",")
    if any(not r.strip() or any(not p.strip() for p in r.split("/")) for r in runs):
        raise InputError(f"--mu: expected {want}, got {text!r}")
    for tok in (p.strip() for r in runs for p in r.split("/")):
        try:
            float(tok)
        except ValueError:
            raise InputError(f"--mu: expected comma-separated numbers, got {tok!r}"
                             + (f" in {text!r}" if tok != str(text).strip() else "")
                             + " (a run with one coefficient per contact joins them with "
                               "'/')") from None
    out: list[FrictionValue] = []
    for run in runs:
        vals = [parse_number(p, "--mu", lo=0.0, hi=MU_MAX) for p in run.split("/")]
        out.append(vals[0] if "/" not in run else tuple(vals))
    if len(out) > MAX_RUNS:
        raise InputError(f"--mu: expected at most {MAX_RUNS} values, got {len(out)}")
    return out


def mu_text(mu: FrictionValue) -> str:
    """``0.1`` or ``0.1/0.2/0.3`` (per contact): as printed, and in folder names."""
    return fmt(mu) if isinstance(mu, (int, float)) else "/".join(fmt(x) for x in mu)


def check_contacts(mus: list[FrictionValue], n_c: int) -> None:
    """Per-contact values must have one coefficient per contact of the plan's hand."""
    for m in mus:
        if not isinstance(m, (int, float)) and len(m) != n_c:
            raise InputError(f"--mu: expected {n_c} coefficients (one per contact) in "
                             f"{mu_text(m)!r}, got {len(m)}")


def run(args: argparse.Namespace) -> int:
    from planner.plan.plan_file import load_plan

    engines = parse_engines(args.engine, "--engine")
    mus = parse_mu_list(args.mu) if args.mu is not None else None
    path = Path(args.plan)
    if not path.is_file():
        raise InputError(f"plan: expected an existing plan file, got {str(path)!r}")
    if args.out is not None:  # the destination first; its entries need the plan's mu values
        from planner.files.outputs import check_output_path

        check_output_path(args.out, "dir")
    plan = load_plan(path)  # FileFormatError (a ValueError) -> exit 2 in cli.main
    if not plan.segments:
        raise InputError(f"plan: expected at least one segment to run, got a partial plan that "
                         f"stops before its first ({str(path)!r})")
    mus = _mu_values(mus, plan.validate_mu)
    check_contacts(mus, len(plan.segments[0].mu_intervals))
    from qsplan.commands.validate_set import chosen_points
    from qsplan.commands.validate_set import entries as set_entries

    args.points = chosen_points(args, plan)  # bad --set / --outside: before any simulation
    render = not args.no_render and len(plan.segments) == 1
    if args.out is not None:
        from planner.files.outputs import output_set

        # the destination and every entry are checked before any simulation
        entries = output_entries(mus, render) + set_entries(args.points[1])
        if len(engines) > 1:
            entries = (*(f"{e}/" for e in engines), CONSENSUS_FILE)
        with output_set(args.out, "dir", entries=entries) as work:
            lines, code = _run_engines(args, engines, plan, path, mus, work, render)
    else:
        lines, code = _run_engines(args, engines, plan, path, mus, None, render)
    if not getattr(args, "quiet", False):  # printed once the outputs are in place
        print("\n".join(lines))
    return code


def mu_folder(mu: FrictionValue) -> str:
    """The folder of one friction value's run when several are validated: ``mu_0.1``,
    ``mu_0.1-0.2-0.3`` (per contact)."""
    return f"mu_{mu_text(mu).replace('/', '-')}"


def output_entries(mus: list[FrictionValue], render: bool) -> tuple[str, ...]:
    """The entries ``--out`` gets: one friction value's run folder
    (:func:`scenarios.runs.write_run`: ``summary.json`` and, with ``render``, ``timeline.png``,
    ``animation.gif`` and ``problem.png``), or one ``mu_<v>/`` folder per value."""
    if len(mus) == 1:
        return RUN_ENTRIES if render else RUN_ENTRIES[:1]
    return tuple(dict.fromkeys(f"{mu_folder(mu)}/" for mu in mus))


CONSENSUS_FILE = "consensus.json"
"""Several engines: per friction value the consensus of their runs (and per segment)."""


def _run_engines(args: argparse.Namespace, engines: list[str], plan: Any, path: Path,
                 mus: list[FrictionValue], work: Path | None, render: bool
                 ) -> tuple[list[str], int]:
    """:func:`_run` per engine (its folder ``work/<engine>`` when several); with several,
    per friction value a consensus line and the exit code of the consensus verdicts
    (:func:`qsplan.commands.simulate.consensus_exit_code`, the worst)."""
    if len(engines) == 1:
        one, code, _ = _run(args, engines[0], plan, path, mus, work, render)
        return one, code
    from planner.files.atomic import atomic_write_json
    from qsplan.commands.simulate import consensus_exit_code
    from sim.consensus import consensus, segment_consensus

    lines = []
    runs: dict[str, list[dict[str, Any]]] = {}
    for engine in engines:
        more, _, summaries = _run(args, engine, plan, path, mus,
                                  None if work is None else work / engine, render)
        lines += more
        runs[engine] = summaries
    codes, table = [], []
    for k, mu in enumerate(mus):
        same = [runs[e][k] for e in engines]
        c = consensus(same)
        codes.append(consensus_exit_code(c))
        segs = segment_consensus(same) if len(plan.segments) > 1 else []
        table.append({"mu": mu_text(mu), "whole": c.to_dict(),
                      "segments": [sc.to_dict() for sc in segs]})
        lines.append(f"consensus mu={mu_text(mu)}: {c.text}")
        lines += [f"  segment {j + 1}: {sc.text}" for j, sc in enumerate(segs)
                  if not sc.unanimous]
    if work is not None:
        atomic_write_json(work / CONSENSUS_FILE, {"engines": engines, "runs": table})
    code = 3 if 3 in codes else 1 if 1 in codes else 0
    return lines, code


def _run(args: argparse.Namespace, engine: str, plan: Any, path: Path,
         mus: list[FrictionValue], work: Path | None, render: bool
         ) -> tuple[list[str], int, list[dict[str, Any]]]:
    """Validate ``plan`` (read from ``path``) at each friction value; outputs go to ``work``
    (the staging folder of --out).  A plan of one segment and a whole task both run through
    :func:`scenarios.runs.validate_plan` (one continuous run, a verdict per segment).  Returns
    the lines to print, the exit code and the summaries."""
    from scenarios.runs import validate_plan, write_run
    from sim.verdict import Outcome

    n_seg = len(plan.segments)
    statuses = []
    lines: list[str] = []
    summaries: list[dict[str, Any]] = []
    for mu in mus:
        res = validate_plan(plan, engine, mu, name=f"validate {path.name} mu={mu_text(mu)}",
                            source=str(path))
        v = res.verdict
        statuses.append(v.outcome)
        wall = f"[{res.summary.wall_time_s:.1f} s]"
        if n_seg > 1:
            lines.append(f"{engine} mu={mu_text(mu)}: {v.outcome.value.upper()} (whole "
                         f"task, {len(res.judgement.segments)} of {n_seg} segments run) {wall}")
            for sv in res.judgement.segments:
                pm = sv.verdict.plan
                extra = (f"claim observed {pm.claim_fraction:.1%}, final position "
                         f"{pm.final_error_of_travel:.2%} of its travel" if pm is not None else
                         sv.verdict.reason)
                lines.append(f"  segment {sv.index + 1} {sv.claim}: {sv.verdict.outcome.value} "
                             f"({extra})")
        elif v.plan is not None:
            pm = v.plan
            lines.append(f"{engine} mu={mu_text(mu)}: {v.outcome.value.upper()}  "
                         f"claim {pm.claim.label!r} observed {pm.claim_fraction:.1%} (predicted "
                         f"modes {pm.predicted_fraction:.1%}), final position "
                         f"{pm.final_error_of_travel:.2%} of travel {wall}")
        else:
            lines.append(f"{engine} mu={mu_text(mu)}: {v.outcome.value.upper()} {wall}")
        if v.outcome is not Outcome.AGREED:
            lines.extend(f"    {r}" for r in v.reasons)
        if work is not None:
            out = work if len(mus) == 1 else work / mu_folder(mu)
            summaries.append(write_run(res, out, render=render))
        else:
            summaries.append(res.summary.to_dict())
    code = _exit_code(statuses)
    axes, points = getattr(args, "points", ((), ()))
    if points:
        from qsplan.commands import validate_set

        more, runs = validate_set.run_points(engine, plan, path, mus, axes, points, work,
                                             mu_text, mu_folder)
        lines += more + [f"{engine} {validate_set.summary_line(runs)}"]
        other = validate_set.exit_code(runs)
        code = 3 if 3 in (code, other) else max(code, other)
    return lines, code, summaries


def _mu_values(mus: list[FrictionValue] | None, validate_mu: tuple[FrictionValue, ...]
               ) -> list[FrictionValue]:
    """``--mu`` values, else the plan's ``mu.validate`` list (an error when it is empty)."""
    if mus is None:
        mus = list(validate_mu)
        if not mus:
            raise InputError("--mu: the plan lists no mu.validate values (its per-contact "
                             "friction intervals share no single coefficient, and a run uses "
                             "one for every contact); expected --mu VALUE")
    return mus


def _exit_code(statuses: list) -> int:
    """3 on a simulator fault, 1 when a run did not agree, else 0."""
    from sim.verdict import Outcome

    if any(s is Outcome.FAULT for s in statuses):
        return 3
    return 0 if all(s is Outcome.AGREED for s in statuses) else 1
