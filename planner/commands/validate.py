"""``qsplan validate PLAN.json --engine pymunk|mujoco [--out DIR]``: run a plan in a simulator.

Exit codes: 0 validation passed, 1 failed, 2 bad input, 3 simulator fault.
The simulator and the plan loader are imported lazily inside :func:`run`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from planner.errors import InputError

ENGINES = ("pymunk", "mujoco")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "validate",
        help="run a plan file in a simulator and compare observed with predicted modes",
        description=(
            "Run PLAN.json (written by `qsplan plan`) in slow motion in the chosen engine, "
            "classify the observed contact modes and compare them and the workpiece poses with "
            "the plan. Exit 0 pass, 1 fail, 2 bad input, 3 simulator fault."
        ),
    )
    p.add_argument("plan", help="plan file (JSON; see docs/plan-format.md)")
    p.add_argument("--engine", default="pymunk", help="pymunk or mujoco")
    p.add_argument("--out", help="output folder for summary.json, timeline plot and GIF")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.engine not in ENGINES:
        raise InputError(f"--engine: expected one of {', '.join(ENGINES)}, got {args.engine!r}")
    path = Path(args.plan)
    if not path.is_file():
        raise InputError(f"plan: expected an existing plan file, got {str(path)!r}")
    import sys

    try:
        from planner.plan import load_plan  # PLANNING's module (issue 5)
    except ImportError as exc:
        print(f"qsplan validate: cannot read plans, planner.plan is unavailable ({exc})",
              file=sys.stderr)
        return 3
    load_plan(path)
    print("qsplan validate: plan execution in the simulator is not implemented yet",
          file=sys.stderr)
    return 3
