"""``python -m scenarios list`` / ``python -m scenarios run NAME --engine pymunk --out DIR``."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from planner.errors import InputError


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    parser = parser or argparse.ArgumentParser(prog="python -m scenarios")
    sub = parser.add_subparsers(dest="action", metavar="ACTION")
    sub.add_parser("list", help="list registered scenarios")
    run = sub.add_parser("run", help="run one scenario and write DIR/summary.json")
    run.add_argument("name")
    run.add_argument("--engine", default="pymunk", help="pymunk or mujoco")
    run.add_argument("--out", required=True, type=Path)
    run.add_argument("--no-render", action="store_true", help="skip the plot and GIF")
    return parser


def execute(args: argparse.Namespace) -> int:
    """Run the parsed action; exit code 0 the expectation held, 1 it did not (a disagreement
    where agreement was expected, or an inconclusive run), 2 bad input, 3 simulator fault."""
    from scenarios.registry import Expect, all_scenarios, get

    if args.action == "list":
        for name, sc in all_scenarios().items():
            print(f"{name:24s} {sc.expect.value:8s} {','.join(sc.engines):14s} {sc.summary}")
        return 0
    if args.action != "run":
        raise InputError(f"action: expected 'list' or 'run', got {args.action!r}")
    sc = get(args.name)
    if sc.engines and args.engine not in sc.engines:
        raise InputError(f"engine: expected one of {sc.engines}, got {args.engine!r}")
    summary = sc.run(args.out, engine=args.engine, render=not args.no_render)
    keys = ("scenario", "engine", "status", "passed", "agreement", "reason")
    print(json.dumps({k: summary[k] for k in keys if k in summary} or summary, default=str))
    if summary.get("status") == "fault":
        return 3
    if sc.expect is Expect.INFO and "passed" not in summary:
        return 0
    return 0 if summary.get("passed") else 1


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return execute(args)
    except InputError as exc:
        print(f"scenarios: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
