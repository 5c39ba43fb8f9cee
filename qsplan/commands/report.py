"""``qsplan report RUN_DIR [--out FILE]``: one self-contained HTML page of a run's outputs."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="turn a run directory into a self-contained HTML report",
        description=(
            "Scan RUN_DIR recursively for *.png, *.gif, summary*.json and plan*.json and write "
            "one HTML page with every figure embedded (base64) and a table of which checks "
            "passed. Exit 0 on success, 2 if RUN_DIR is not a directory."
        ),
    )
    p.add_argument("run_dir", help="directory written by qsplan demo/scenarios/validate")
    p.add_argument("--out", help="output HTML file (default RUN_DIR/report.html)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from planner.errors import InputError
    from planner.files.outputs import output_set
    from qsplan.report import write_report

    if not str(args.run_dir).strip():
        raise InputError("run directory: expected an existing directory, got ''")
    run_dir = Path(args.run_dir)
    if not run_dir.is_dir():
        raise InputError(f"run directory: expected an existing directory, got {str(run_dir)!r}")
    target = Path(args.out) if args.out is not None else run_dir / "report.html"
    with output_set(target, "file", "--out") as tmp:
        write_report(run_dir, tmp)
    if not getattr(args, "quiet", False):
        print(f"wrote {target}")
    return 0
