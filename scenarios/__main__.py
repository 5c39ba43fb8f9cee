"""``python -m scenarios list`` / ``show NAME`` / ``run NAME --engine ENGINE --out DIR
[--set key=value ...]`` (typed parameters: :class:`scenarios.registry.Parameter`)."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from planner.errors import InputError
from sim.backends import ENGINES, require_engine


def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    parser = parser or argparse.ArgumentParser(prog="python -m scenarios")
    sub = parser.add_subparsers(dest="action", metavar="ACTION")
    sub.add_parser("list", help="list registered scenarios")
    show = sub.add_parser("show", help="one scenario: what it shows and its parameters "
                                       "(defaults, units, ranges)")
    show.add_argument("name")
    run = sub.add_parser("run", help="run one scenario and write DIR/summary.json")
    run.add_argument("name")
    run.add_argument("--engine", default="pymunk",
                     help=f"{' | '.join(ENGINES)} (default pymunk; the scenario's engines)")
    run.add_argument("--out", required=True, type=Path)
    run.add_argument("--no-render", action="store_true", help="skip the plot and GIF")
    run.add_argument("--set", action="append", metavar="KEY=VALUE",
                     help="set a typed parameter (repeatable; `show NAME` lists them)")
    return parser


def execute(args: argparse.Namespace) -> int:
    """Run the parsed action; exit code 0 the expectation held, 1 it did not (a disagreement
    where agreement was expected, or an inconclusive run), 2 bad input, 3 simulator fault."""
    from scenarios.registry import Expect, all_scenarios, get, parse_settings

    if args.action == "list":
        for name, sc in all_scenarios().items():
            print(f"{name:24s} {sc.expect.value:8s} {','.join(sc.engines):20s} {sc.summary}")
        return 0
    if args.action == "show":
        print(describe(get(args.name)))
        return 0
    if args.action != "run":
        raise InputError(f"action: expected 'list', 'show' or 'run', got {args.action!r}")
    sc = get(args.name)
    if sc.engines and args.engine not in sc.engines:
        raise InputError(f"engine: expected one of {sc.engines}, got {args.engine!r}")
    if sc.engines:
        require_engine(args.engine, "--engine")
    params = parse_settings(sc, getattr(args, "set", None))
    from scenarios.runs import run_scenario

    summary = run_scenario(sc, args.out, engine=args.engine, render=not args.no_render, **params)
    keys = ("name", "scenario", "engine", "status", "passed", "agreement", "reason")
    print(json.dumps({k: summary[k] for k in keys if k in summary} or summary, default=str))
    if summary.get("status") == "fault":
        return 3
    if sc.expect is Expect.INFO and "passed" not in summary:
        return 0
    return 0 if summary.get("passed") else 1


def describe(sc: Any) -> str:
    """``show``: name, summary, reference, expectation, engines and the parameter table."""
    lines = [f"{sc.name}: {sc.summary}", f"reference: {sc.reference}",
             f"expect: {sc.expect.value}   engines: {', '.join(sc.engines) or '-'}"]
    if not sc.parameters:
        lines.append("parameters: none")
    else:
        lines.append("parameters (--set KEY=VALUE):")
        for p in sc.parameters:
            default = ",".join(map(str, p.default)) if isinstance(p.default, tuple) \
                else ("engine default" if p.default is None else str(p.default))
            rng = f"[{'' if p.lo is None else p.lo}, {'' if p.hi is None else p.hi}]"
            lines.append(f"  {p.name:8s} {p.kind:6s} default {default:16s} unit {p.unit:6s} "
                         f"range {rng:14s} {p.help}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return execute(args)
    except InputError as exc:
        print(f"scenarios: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
