"""``qsplan simulate SYSTEM.json --engine ENGINE[,ENGINE..] [--mu ..] [--mu-kinetic ..]
[--judge-mu ..] [--duration S] [--speed V] [--out DIR]``: simulate any system file and judge
the run against the planner's prediction (:func:`scenarios.runs.simulate_system`: the one
pipeline of :mod:`sim.jobs`, for one workpiece or several, driven or static).

Several engines (``--engine pymunk,mujoco,dart``): one run each, the verdicts side by side
and their consensus (:mod:`sim.consensus`: which engine is the odd one and the engine artefact
its run measured); ``--out`` then holds one run folder per engine and ``consensus.json``.

Exit codes: 0 agreed, 1 disagreed or inconclusive, 2 bad input, 3 simulator fault (several
engines: of their consensus verdict, :func:`consensus_exit_code`). The simulators are imported
lazily inside :func:`run`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from qsplan.options import MU_MAX, input_warnings, parse_engines, parse_number, parse_numbers
from scenarios.registry import RUN_ENTRIES
from sim.backends import ENGINES


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="simulate a system file and compare observed with predicted contact modes",
        description=(
            "Predict the feasible contact modes of SYSTEM.json (as `qsplan modes`), build a "
            "scene from it (the workpiece polygon of its `workpiece` key or one derived from "
            "the contacts; `environment` contacts as fixed flat surfaces; the other contacts "
            "as fingertips driven with their commanded velocities, or a `manipulator.chain` "
            "as its links on their joints, in slow motion), run it in "
            "the chosen engine, classify the observed modes from the simulator's contact data "
            "and compare (docs/simulation.md). A file with several workpieces (`workpieces`) "
            "is judged per contact and per body twist. A file with no "
            "commanded motion is a static question: it is run without a drive and judged "
            "'stays' (its predicted equilibria) against 'moves' (none predicted). The scene is "
            "simulated at a size between 3 cm and 40 cm (a similar copy of a larger or smaller "
            "one). Exit 0 agreed, 1 disagreed or inconclusive, 2 bad input, 3 simulator fault."
        ),
        epilog=("examples:\n  qsplan simulate scenarios/data/box_on_table_high.json "
                "--engine pymunk --out out/box\n"
                "  qsplan simulate box.json --judge-mu 0.3,0.3,0   # negative control\n"
                "  qsplan simulate scenarios/data/stacked_blocks.json --engine mujoco  "
                "# several workpieces"),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("system", help="system file (JSON; see docs/file-formats.md)")
    p.add_argument("--engine", default="pymunk",
                   help=f"{' | '.join(ENGINES)}, or several comma-separated (verdicts side by "
                        f"side and their consensus; default pymunk)")
    p.add_argument("--mu", help="friction to simulate: one value, or one per contact "
                                "(default: the file's)")
    p.add_argument("--mu-kinetic", help="kinetic friction (static = --mu): one value or one per "
                                        "contact; default: a single Coulomb coefficient")
    p.add_argument("--judge-mu", help="judge the run against the prediction at this friction "
                                      "(a negative control); default: --mu")
    p.add_argument("--duration", help="simulated time [s] (default per engine)")
    p.add_argument("--speed", help="speed of the fastest contact [m/s] (default per engine, "
                                   "scaled to the scene)")
    p.add_argument("--out", help="output folder: summary.json (+ timeline.png, animation.gif); "
                                 "several engines: one folder per engine and consensus.json; "
                                 "written into place only when every run has finished")
    p.add_argument("--no-render", action="store_true", help="skip the timeline plot")
    p.set_defaults(func=run)


def _mu(text: str | None, what: str) -> list[float] | float | None:
    if text is None:
        return None
    values = parse_numbers(text, what, lo=0.0, hi=MU_MAX)
    return values[0] if len(values) == 1 else values


def run(args: argparse.Namespace) -> int:
    engines = parse_engines(args.engine, "--engine")
    options: dict[str, Any] = {
        "mu": _mu(args.mu, "--mu"),
        "mu_kinetic": _mu(args.mu_kinetic, "--mu-kinetic"),
        "judge_mu": _mu(args.judge_mu, "--judge-mu"),
        "duration": None if args.duration is None else parse_number(
            args.duration, "--duration", lo=0.0, hi=600.0),
        "speed": None if args.speed is None else parse_number(args.speed, "--speed",
                                                              lo=0.0, hi=10.0),
    }
    entries: tuple[str, ...] = RUN_ENTRIES[:1] if args.no_render else RUN_ENTRIES
    if len(engines) > 1:
        entries = (*(f"{e}/" for e in engines), CONSENSUS_FILE)
    if args.out is not None:
        from planner.files.outputs import output_set

        # the destination and every entry are checked before any work
        with output_set(args.out, "dir", entries=entries) as work:
            lines, code = _run_engines(args, engines, options, work)
    else:
        lines, code = _run_engines(args, engines, options, None)
    if not getattr(args, "quiet", False):  # printed once the outputs are in place
        for line in lines:
            print(json.dumps(line, default=str))
    return code


#: The consensus of several engines' runs in ``--out`` (:meth:`sim.consensus.Consensus.to_dict`).
CONSENSUS_FILE = "consensus.json"


def _run_engines(args: argparse.Namespace, engines: list[str], options: dict[str, Any],
                 work: Path | None) -> tuple[list[dict[str, Any]], int]:
    """One run per engine (its folder ``work/<engine>`` when several) and, with several, a
    last line ``{"consensus": ...}``; the exit code of the one run or of the consensus."""
    if len(engines) == 1:
        line, code, _ = _run(args, engines[0], options, work)
        return [line], code
    from planner.files.atomic import atomic_write_json
    from sim.consensus import consensus

    lines, summaries = [], []
    for engine in engines:
        line, _, summary = _run(args, engine, options,
                                None if work is None else work / engine)
        line["engine_artefacts"] = [
            a["text"] for a in summary["observed"]["engine_measures"]["artefacts"]]
        lines.append(line)
        summaries.append(summary)
    c = consensus(summaries)
    if work is not None:
        atomic_write_json(work / CONSENSUS_FILE, c.to_dict())
    lines.append({"consensus": c.majority, "odd": list(c.odd), "text": c.text})
    return lines, consensus_exit_code(c)


def consensus_exit_code(c: Any) -> int:
    """The exit code of a :class:`sim.consensus.Consensus`: 0 when its verdict is
    ``agreed``, 3 when it is ``fault``, 1 otherwise (no majority: 3 if an engine faulted,
    else 1)."""
    if c.majority == "agreed":
        return 0
    if c.majority == "fault" or (c.majority is None and "fault" in c.verdicts.values()):
        return 3
    return 1


def _run(args: argparse.Namespace, engine: str, options: dict[str, Any], work: Path | None
         ) -> tuple[dict[str, Any], int, dict[str, Any]]:
    """Simulate and judge in ``engine``; write the run into ``work`` (the staging folder of
    --out, or its engine's folder).  Returns the result line, the exit code and the
    summary."""
    from planner.files.system_file import load_system
    from scenarios.runs import simulate_system, write_run
    from sim.verdict import Outcome

    with input_warnings("simulate"):  # a GeometryWarning: one line on stderr
        system = load_system(args.system)  # FileFormatError -> exit 2
    res = simulate_system(system, engine, name=f"simulate {Path(args.system).name}",
                          source=str(args.system), **options)
    summary = res.summary.to_dict()
    if work is not None:
        summary = write_run(res, work, render=not args.no_render)
    line = {k: summary[k] for k in ("engine", "status", "agreement", "judged_steps", "reason")}
    line["predicted"] = summary["predicted"]["labels"]
    line["observed"] = summary["observed"]["counts"]
    outcome = res.verdict.outcome
    if outcome is Outcome.FAULT:
        return line, 3, summary
    return line, 0 if outcome is Outcome.AGREED else 1, summary
