"""``qsplan simulate SYSTEM.json --engine ENGINE [--mu ..] [--mu-kinetic ..]
[--judge-mu ..] [--duration S] [--speed V] [--out DIR]``: simulate any system file and judge
the run against the planner's prediction (:func:`scenarios.runs.simulate_system`: the one
pipeline of :mod:`sim.jobs`, for one workpiece or several, driven or static).

Exit codes: 0 agreed, 1 disagreed or inconclusive, 2 bad input, 3 simulator fault. The
simulators are imported lazily inside :func:`run`.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from qsplan.options import MU_MAX, input_warnings, parse_number, parse_numbers
from scenarios.registry import RUN_ENTRIES
from sim.backends import ENGINES, require_engine


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
    p.add_argument("--engine", default="pymunk", help=f"{' | '.join(ENGINES)} (default pymunk)")
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
                                 "written into place only when the run has finished")
    p.add_argument("--no-render", action="store_true", help="skip the timeline plot")
    p.set_defaults(func=run)


def _mu(text: str | None, what: str) -> list[float] | float | None:
    if text is None:
        return None
    values = parse_numbers(text, what, lo=0.0, hi=MU_MAX)
    return values[0] if len(values) == 1 else values


def run(args: argparse.Namespace) -> int:
    require_engine(args.engine, "--engine")
    options: dict[str, Any] = {
        "mu": _mu(args.mu, "--mu"),
        "mu_kinetic": _mu(args.mu_kinetic, "--mu-kinetic"),
        "judge_mu": _mu(args.judge_mu, "--judge-mu"),
        "duration": None if args.duration is None else parse_number(
            args.duration, "--duration", lo=0.0, hi=600.0),
        "speed": None if args.speed is None else parse_number(args.speed, "--speed",
                                                              lo=0.0, hi=10.0),
    }
    entries = RUN_ENTRIES[:1] if args.no_render else RUN_ENTRIES
    if args.out is not None:
        from planner.files.outputs import output_set

        # the destination and every entry are checked before any work
        with output_set(args.out, "dir", entries=entries) as work:
            line, code = _run(args, options, work)
    else:
        line, code = _run(args, options, None)
    if not getattr(args, "quiet", False):  # printed once the outputs are in place
        print(json.dumps(line, default=str))
    return code


def _run(args: argparse.Namespace, options: dict[str, Any], work: Path | None
         ) -> tuple[dict[str, Any], int]:
    """Simulate and judge; write the run into ``work`` (the staging folder of --out).  Returns
    the result line and the exit code."""
    from planner.files.system_file import load_system
    from scenarios.runs import simulate_system, write_run
    from sim.verdict import Outcome

    with input_warnings("simulate"):  # a GeometryWarning: one line on stderr
        system = load_system(args.system)  # FileFormatError -> exit 2
    res = simulate_system(system, args.engine, name=f"simulate {Path(args.system).name}",
                          source=str(args.system), **options)
    summary = res.summary.to_dict()
    if work is not None:
        summary = write_run(res, work, render=not args.no_render)
    line = {k: summary[k] for k in ("engine", "status", "agreement", "judged_steps", "reason")}
    line["predicted"] = summary["predicted"]["labels"]
    line["observed"] = summary["observed"]["counts"]
    outcome = res.verdict.outcome
    if outcome is Outcome.FAULT:
        return line, 3
    return line, 0 if outcome is Outcome.AGREED else 1
