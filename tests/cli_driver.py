"""Run the ``qsplan`` process with one subcommand replaced by a scripted one (tests only).

    python tests/cli_driver.py SCRIPT OUT [SIGNAL]

starts the command line exactly as the console script does (``sys.argv[0] == "qsplan"``: the
signal handlers and the watchdog go in before the slow imports) and runs ``qsplan modes`` with
its function replaced by SCRIPT, a deterministic stand-in for a long command:

``signal_in_set``
    writes a new output set into OUT, sends itself SIGNAL in the middle, keeps working;
``signal_in_commit``
    writes the set and sends itself SIGNAL during the first rename of the commit;
``stuck_in_c``
    writes the set, sends itself SIGNAL and runs a long LAPACK call (compiled code: Python's
    handler cannot run before it returns -- the watchdog must end the process);
``pool``
    writes the set while two pool workers sleep, waits (the test sends the signal);
``print_in_set``
    prints 20,000 lines inside the output set, then returns 1 (a failed check);
``slow_exit``
    writes the set, prints "done" and returns 0, leaving an object whose finaliser takes 3 s
    when Python collects it at exit (a signal then comes after the result is decided).
"""

from __future__ import annotations

import os
import signal
import sys
import time

ARGS = sys.argv[1:]
sys.argv = ["qsplan", "modes", "unused.json"]  # as the console script starts


def _parse() -> tuple[str, str, int]:
    script, out = ARGS[0], ARGS[1]
    signum = getattr(signal, ARGS[2]) if len(ARGS) > 2 else signal.SIGTERM
    return script, out, signum


def _sleep(seconds: float) -> None:
    time.sleep(seconds)


class SlowToCollect:
    def __del__(self) -> None:
        time.sleep(3.0)


KEEP: list[object] = []


def main() -> int:
    script, out, signum = _parse()
    import qsplan.cli as cli  # the handlers are installed by this import (argv[0] is qsplan)

    def command(args: object) -> int:
        from planner.files.outputs import output_set

        entries = ("summary.json", "mu_0/", "mu_0.1/")
        with output_set(out, "dir", entries=entries) as work:
            (work / "summary.json").write_text("new\n")
            (work / "mu_0").mkdir()
            (work / "mu_0" / "summary.json").write_text("new 0\n")
            if script == "signal_in_set":
                os.kill(os.getpid(), signum)
                _sleep(30)
            elif script == "stuck_in_c":
                import numpy as np

                os.kill(os.getpid(), signum)
                np.linalg.eigvals(np.random.default_rng(0).random((2000, 2000)))
                _sleep(30)
            elif script == "pool":
                from concurrent.futures import ProcessPoolExecutor

                with ProcessPoolExecutor(max_workers=2) as pool:
                    print("pool started", flush=True)
                    list(pool.map(_sleep, [30.0] * 8))
            elif script == "slow_exit":
                KEEP.append(SlowToCollect())
            elif script == "print_in_set":
                for k in range(20000):
                    print(f"line {k}")
                (work / "mu_0.1").mkdir()
                (work / "mu_0.1" / "summary.json").write_text("new 0.1\n")
                return 1
            elif script == "signal_in_commit":
                real = os.rename

                def rename(src: object, dst: object) -> None:
                    os.rename = real
                    os.kill(os.getpid(), signum)
                    real(src, dst)  # type: ignore[arg-type]

                os.rename = rename  # type: ignore[assignment]
        if script == "slow_exit":
            print("done", flush=True)
        return 0

    real_build = cli.build_parser

    def build():  # type: ignore[no-untyped-def]
        parser = real_build()
        parser._subparsers._group_actions[0].choices["modes"].set_defaults(func=command)
        return parser

    cli.build_parser = build  # type: ignore[assignment]
    return cli.main()


if __name__ == "__main__":
    sys.exit(main())
