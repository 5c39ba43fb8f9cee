"""``qsplan scenarios list | run NAME --engine pymunk|mujoco --out DIR`` (simulator validation).

The scenario package and the simulators are imported lazily inside the command.
"""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("scenarios", help="list or run simulator validation scenarios")
    from scenarios.__main__ import build_parser

    build_parser(parser)
    parser.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from scenarios.__main__ import execute

    return execute(args)
