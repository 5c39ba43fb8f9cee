"""The ``qsplan`` command line.

Subcommands live in :mod:`qsplan.commands`: every module there defines
``register(subparsers)`` that adds its parser and sets ``func(args) -> int`` as the default.
Exit codes: 0 success, 1 the job ran and its check failed (e.g. a validation disagreed),
2 bad input (usage, malformed file, invalid values), 3 internal/simulator fault.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence

from planner.errors import QsplanError

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_FAULT = 0, 1, 2, 3


def build_parser() -> argparse.ArgumentParser:
    """Parser with every subcommand of :mod:`qsplan.commands` registered."""
    parser = argparse.ArgumentParser(
        prog="qsplan",
        description=(
            "Quasistatic planar contact-mode prediction, torque-bound planning and simulator "
            "validation (Trinkle & Zeng 1994)."
        ),
    )
    verbosity = parser.add_mutually_exclusive_group()
    verbosity.add_argument("-q", "--quiet", action="store_true", help="print only errors")
    verbosity.add_argument("-v", "--verbose", action="store_true", help="print more detail")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    import qsplan.commands as commands_pkg

    for info in sorted(pkgutil.iter_modules(commands_pkg.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"qsplan.commands.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    # -q/-v are accepted after the subcommand too (``qsplan plan ... -q``).
    for subparser in sub.choices.values():
        group = subparser.add_mutually_exclusive_group()
        group.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                           help="print only errors")
        group.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS,
                           help="print more detail")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``qsplan`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_INPUT
    try:
        return int(args.func(args) or 0)
    except QsplanError as exc:
        print(f"qsplan {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:  # e.g. piped into `head`
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
