"""The ``qsplan`` command line.

Subcommands live in :mod:`qsplan.commands`: every module there defines
``register(subparsers)`` that adds its parser and sets ``func(args) -> int`` as the default.

Exit codes: 0 success; 1 the job ran and a check failed (e.g. a validation disagreed);
2 bad input (usage, a malformed file, invalid values, an unusable output path, a request beyond
the memory budget); 3 internal, simulator or environment fault (a full disk, a permission lost
mid-run: named as such, with the path); ``128 + n`` interrupted by signal ``n`` (SIGINT 130,
SIGTERM 143, SIGHUP 129; :mod:`qsplan.interrupts`).  An unexpected exception never reaches the
terminal as a traceback: one line names the fault and the log file holding the traceback
(``--debug`` prints it instead).  The exit code is the command's result whatever happens to
stdout and stderr (a reader that closes the pipe early: :mod:`qsplan.streams`).
"""

from __future__ import annotations

import os
import sys


def _started_as_command() -> bool:
    """True in the ``qsplan`` process itself (the console script or ``python -m
    qsplan.cli``), False when another program imports this module."""
    return __name__ == "__main__" or os.path.basename(sys.argv[0] or "") in ("qsplan",
                                                                              "qsplan.exe")


def _interrupted_while_starting(signum: int, frame: object) -> None:
    """The first handler: nothing started yet, so one line and the exit code."""
    name = {2: "SIGINT (Ctrl-C)", 15: "SIGTERM", 1: "SIGHUP"}.get(signum, f"signal {signum}")
    try:
        os.write(2, f"qsplan: interrupted by {name} while starting; nothing done\n".encode())
    finally:
        os._exit(128 + signum)


if _started_as_command():  # a Ctrl-C while Python imports is one line, not a traceback
    _signal = __import__("_signal")  # the C module: at once (signal.py's enums take ~50 ms)
    for _signum in (2, 15, 1):
        _signal.signal(_signum, _interrupted_while_starting)

from qsplan import interrupts  # noqa: E402 - standard library only

if _started_as_command():
    interrupts.install(watchdog=True)

import argparse  # noqa: E402
import contextlib  # noqa: E402
import datetime  # noqa: E402
import errno  # noqa: E402
import importlib  # noqa: E402
import pkgutil  # noqa: E402
import re  # noqa: E402
import tempfile  # noqa: E402
import traceback  # noqa: E402
import warnings  # noqa: E402
from collections.abc import Iterator, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, NoReturn  # noqa: E402

from qsplan.streams import guarded_streams  # noqa: E402

EXIT_OK, EXIT_FAILED, EXIT_INPUT, EXIT_FAULT = 0, 1, 2, 3
LOG_DIR_ENV = "QSPLAN_LOG_DIR"


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions as written (line breaks kept); every option's default in its help unless
    the default is None/False or the help already mentions it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if ("%(default)" in text or "default" in text or default is None or default is False
                or default is argparse.SUPPRESS or not action.option_strings):
            return text
        return text + " (default: %(default)s)"


_ARGPARSE_MESSAGES = (
    (re.compile(r"argument (?P<arg>\S+): invalid (?P<type>int|float) value: (?P<got>.*)"),
     lambda m: f"argument {m['arg']}: expected "
               f"{'an integer' if m['type'] == 'int' else 'a number'}, got {m['got']}"),
    (re.compile(r"argument (?P<arg>\S+): invalid choice: (?P<got>.*?) \(choose from (?P<c>.*)\)"),
     lambda m: f"argument {m['arg']}: expected one of {m['c']}, got {m['got']}"),
    (re.compile(r"the following arguments are required: (?P<args>.*)"),
     lambda m: f"expected the arguments {m['args']}, got none"),
    (re.compile(r"unrecognized arguments: (?P<args>.*)"),
     lambda m: f"expected only known arguments, got {m['args']}"),
    (re.compile(r"argument (?P<arg>\S+): expected one argument"),
     lambda m: f"argument {m['arg']}: expected one value, got none"),
    (re.compile(r"argument (?P<arg>\S+): not allowed with argument (?P<other>\S+)"),
     lambda m: f"argument {m['arg']}: expected without {m['other']}, got both"),
)


class ArgumentParser(argparse.ArgumentParser):
    """argparse with usage errors phrased as the project's messages: expected vs got."""

    def error(self, message: str) -> NoReturn:
        for pattern, phrase in _ARGPARSE_MESSAGES:
            m = pattern.fullmatch(message)
            if m:
                message = phrase(m)
                break
        super().error(message)


def _global_options(parser: argparse.ArgumentParser, suppress: bool) -> None:
    kw: dict[str, Any] = {"default": argparse.SUPPRESS} if suppress else {}
    verbosity = parser.add_mutually_exclusive_group()
    verbosity.add_argument("-q", "--quiet", action="store_true", help="print only errors", **kw)
    verbosity.add_argument("-v", "--verbose", action="store_true", help="print more detail",
                           **kw)
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of an internal fault and numpy warnings",
                        **kw)
    parser.add_argument("--memory-gib", type=float, metavar="GIB",
                        help="memory budget of the command in GiB; larger requests are refused "
                             "(default $QSPLAN_MEMORY_GIB or 4)", **kw)


def build_parser() -> argparse.ArgumentParser:
    """Parser with every subcommand of :mod:`qsplan.commands` registered."""
    parser = ArgumentParser(
        prog="qsplan",
        description=(
            "Quasistatic planar contact-mode prediction, torque-bound planning and simulator "
            "validation (Trinkle & Zeng 1994). Exit codes: 0 ok, 1 a check failed, 2 bad "
            "input, 3 internal, simulator or environment fault, 128+n interrupted by signal "
            "n."
        ),
        formatter_class=HelpFormatter,
    )
    _global_options(parser, suppress=False)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    import qsplan.commands as commands_pkg

    for info in sorted(pkgutil.iter_modules(commands_pkg.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"qsplan.commands.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    # The global options are accepted after the subcommand too (``qsplan plan ... -q``).
    for subparser in sub.choices.values():
        _finish_subparser(subparser)
    return parser


def _finish_subparser(parser: argparse.ArgumentParser) -> None:
    """:class:`HelpFormatter` and the global options for ``parser`` and its nested
    subcommands (``qsplan scenarios run NAME ... -q``)."""
    parser.formatter_class = HelpFormatter
    _global_options(parser, suppress=True)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for nested in action.choices.values():
                _finish_subparser(nested)


def log_dir() -> Path:
    """Folder of the fault logs: ``$QSPLAN_LOG_DIR`` or ``<tmp>/qsplan-logs``."""
    return Path(os.environ.get(LOG_DIR_ENV) or Path(tempfile.gettempdir()) / "qsplan-logs")


def write_fault_log(command: str, argv: Sequence[str], exc: BaseException) -> Path | None:
    """Write the traceback of ``exc`` to a new file in :func:`log_dir`; None if impossible."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    text = (f"qsplan {command}: internal fault\nargv: {list(argv)}\n\n"
            + "".join(traceback.format_exception(exc)))
    try:
        folder = log_dir()
        folder.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f"qsplan-{command}-{stamp}-", suffix=".log",
                                    dir=folder)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        return Path(name)
    except OSError:
        return None


@contextlib.contextmanager
def _quiet_numerics(debug: bool) -> Iterator[None]:
    """numpy's RuntimeWarnings (overflow, invalid value) are for developers: hidden unless
    ``--debug``; progress bars only on a terminal."""
    saved = os.environ.get("TQDM_DISABLE")
    if not sys.stderr.isatty():
        os.environ["TQDM_DISABLE"] = "1"  # read by tqdm when first imported
    try:
        with warnings.catch_warnings():
            if not debug:
                warnings.simplefilter("ignore", RuntimeWarning)
            yield
    finally:
        if saved is None:
            os.environ.pop("TQDM_DISABLE", None)
        else:
            os.environ["TQDM_DISABLE"] = saved


#: Failures of the machine rather than of qsplan or its input: named as such, with the path.
ENVIRONMENT_ERRNOS = {
    errno.ENOSPC: "no space left on the device", errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "the file system is read-only", errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted", errno.EIO: "input/output error",
    errno.EFBIG: "file too large", errno.EMFILE: "too many open files",
    errno.ENFILE: "too many open files in the system",
}


def environment_failure(exc: BaseException) -> str | None:
    """The message of an environment failure (disk full, permission lost, read-only file
    system, ...): what failed, where (the output's own name, never its staging folder) and
    what became of the outputs; None for any other exception."""
    if not isinstance(exc, OSError) or exc.errno not in ENVIRONMENT_ERRNOS:
        return None
    outputs = sys.modules.get("planner.files.outputs")
    paths = [str(outputs.final_path(f) if outputs else f)
             for f in (exc.filename, exc.filename2) if f]
    where = f" at {', '.join(repr(p) for p in paths)}" if paths else ""
    return (f"environment failure: {ENVIRONMENT_ERRNOS[exc.errno]} "
            f"({errno.errorcode[exc.errno]}){where}; {interrupts.outputs_status()}")


@contextlib.contextmanager
def _memory_budget(args: argparse.Namespace) -> Iterator[None]:
    """``--memory-gib`` as the process's memory budget (the loaders check it too) while the
    command runs."""
    from planner.files.reader import GIB, memory_budget, set_memory_budget
    from qsplan.options import parse_number

    if getattr(args, "memory_gib", None) is not None:
        args.memory_gib = parse_number(str(args.memory_gib), "--memory-gib", lo=1e-6, hi=1e6)
        set_memory_budget(int(args.memory_gib * GIB))
    else:
        memory_budget()  # a bad $QSPLAN_MEMORY_GIB is bad input before any work
    try:
        yield
    finally:
        set_memory_budget(None)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``qsplan`` console script; returns the exit code."""
    restore = interrupts.install()  # in-process callers: handlers for this call only
    try:
        with guarded_streams():
            code = _main(argv)
    finally:
        restore()
    interrupts.end_if_interrupted(code)
    return code


def _main(argv: Sequence[str] | None) -> int:
    from planner.errors import QsplanError
    from planner.files.outputs import forget_history

    forget_history()  # what became of the outputs: this command's only
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_INPUT
    debug = bool(getattr(args, "debug", False))
    name = f"qsplan {args.command}"
    try:
        with interrupts.armed(name), _memory_budget(args):
            with _quiet_numerics(debug):
                return int(args.func(args) or 0)
    except interrupts.Interrupted as exc:
        interrupts.say(interrupts.describe(exc.signum, name))
        return exc.exit_code
    except KeyboardInterrupt:  # a Ctrl-C that reached Python's own handler
        import signal

        interrupts.say(interrupts.describe(signal.SIGINT, name))
        return 128 + signal.SIGINT
    except QsplanError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except MemoryError:
        print(f"{name}: error: out of memory: the machine had less memory left than this "
              "request needed; expected a smaller request (requests sized before they start "
              "are refused beyond --memory-gib)", file=sys.stderr)
        return EXIT_FAULT
    except Exception as exc:  # noqa: BLE001 - the one place that turns faults into exit 3
        environment = environment_failure(exc)
        if environment is not None and not debug:
            print(f"{name}: {environment}", file=sys.stderr)
            return EXIT_FAULT
        if debug:
            traceback.print_exc()
            return EXIT_FAULT
        log = write_fault_log(args.command, argv, exc)
        where = f"traceback in {log}" if log else "no log could be written"
        print(f"{name}: internal fault: {type(exc).__name__}: {_one_line(exc)} ({where}; "
              "--debug prints it)", file=sys.stderr)
        return EXIT_FAULT


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:300] + ("..." if len(text) > 300 else "")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
