"""``qsplan scenarios list | run NAME --engine ENGINE --out DIR`` (simulator validation).

The scenario package and the simulators are imported lazily inside the command.
"""

from __future__ import annotations

import argparse
import contextlib
import io
from typing import Any

DESCRIPTION = """\
List or run the registered scenarios: the paper's examples (Sec. 4.1 eq. 37, Sec. 4.3 eq. 42)
and the ruler of Sec. 5.1 simulated in pymunk, MuJoCo or DART and compared with the planner's
prediction (expect "agree", or "disagree" for negative controls), and "info" scenarios that only
write figures and data (friction-space maps of Figs. 3, 6 and 8).  `scenarios list` prints
name, expectation, engines and summary; `scenarios run NAME --engine ENGINE --out DIR` writes
DIR/summary.json (plus figures) and prints its status line."""

EPILOG = """\
examples:
  qsplan scenarios list
  qsplan scenarios run ex41_3s --engine mujoco --out out/ex41_3s
  qsplan scenarios run ruler_muspace --out out/fig8
exit codes: 0 passed, 1 check failed, 2 bad input, 3 simulator fault."""


def register(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("scenarios", help="list or run simulator validation scenarios",
                            description=DESCRIPTION, epilog=EPILOG)
    from scenarios.__main__ import build_parser

    build_parser(parser)
    for action in parser._actions:  # keep --out as typed: Path("") would silently be "."
        if isinstance(action, argparse._SubParsersAction):
            for sub_parser in action.choices.values():
                for opt in sub_parser._actions:
                    if "--out" in opt.option_strings:
                        opt.type = str
                        opt.help = ("output folder (summary.json, figures); written into place "
                                    "only when the run has finished")
                    elif opt.dest == "name" and not opt.option_strings:
                        opt.help = "scenario name (see `qsplan scenarios list`)"
    parser.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    """``list``, or ``run`` with its outputs staged and moved to ``--out`` at the end (a failed
    run leaves the previous outputs whole)."""
    from scenarios.__main__ import execute

    if getattr(args, "action", None) != "run":
        return execute(args)
    from planner.errors import InputError
    from planner.files.outputs import output_set
    from scenarios.registry import all_scenarios

    names = list(all_scenarios())
    if args.name not in names:  # bad input before any folder is touched
        raise InputError(f"unknown scenario {args.name!r}: expected one of {', '.join(names)}; "
                         f"got {args.name!r}")
    # the destination and every entry are checked before any work
    with output_set(str(args.out), "dir", entries=output_entries(
            all_scenarios()[args.name], render=not args.no_render)) as work:
        final = args.out
        args.out = work
        try:
            with contextlib.redirect_stdout(io.StringIO()) as result:
                code = execute(args)
        finally:
            args.out = final
    if not getattr(args, "quiet", False):  # printed once the outputs are in place
        print(result.getvalue(), end="")
    return code


def output_entries(scenario: Any, render: bool) -> tuple[str, ...] | None:
    """The entries ``--out`` gets: a simulator scenario's run folder
    (:func:`scenarios.runs.write_run`: ``summary.json`` and, with ``render``, the pictures),
    another scenario's declared ``outputs``; None (checked after the run) when it declares
    none."""
    from scenarios.registry import RUN_ENTRIES

    if scenario.spec is not None:
        return RUN_ENTRIES if render else RUN_ENTRIES[:1]
    return scenario.outputs or None
