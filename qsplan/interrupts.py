"""Interrupts of the command line: SIGINT, SIGTERM and SIGHUP end any command within a second.

The contract (docs/robustness.md, "Interrupts"): a command that receives SIGINT (Ctrl-C),
SIGTERM or SIGHUP ends with exit code ``128 + n`` (130, 143, 129) and one line on stderr naming
the command, the signal and what became of its outputs; the previous outputs are whole (an
output set is committed whole or not at all: :mod:`planner.files.outputs`), no staging folder
and no child process is left.

How:

* :func:`install` sets one handler for the three signals.  Once :func:`arm`-ed (inside the
  command line's ``try``) it raises :class:`Interrupted` (a ``KeyboardInterrupt``) in the main
  thread, so ``finally`` blocks delete staging folders and the CLI prints the line; before
  that (Python still importing) and after it, it prints the line and ends the process at once
  (nothing was started, or everything is finished).  A signal during an output set's commit is
  deferred to its end (:func:`planner.files.outputs.defer_interrupt`).  A second signal while
  the first unwinds is ignored.
* Child processes (process pools of ``sweep --workers`` and ``demo --jobs``) are killed
  (SIGKILL) by the handler, so a pool's shutdown does not wait for queued tasks.  Forked
  children ignore SIGINT and SIGHUP (the terminal sends them to the whole process group; the
  parent decides), take SIGTERM's default action and, on Linux, get SIGKILL when the parent
  dies (``PR_SET_PDEATHSIG``).
* Once Python runs its exit handlers (the command's result decided, its outputs written), the
  three signals are ignored: Python would otherwise reset them to their default action while
  it collects its objects, and a late signal would kill the process without a word.
* With ``watchdog=True`` (the ``qsplan`` process itself, not an in-process call) a thread
  wakes on every signal through ``signal.set_wakeup_fd``; if the process still runs
  :data:`GRACE_S` seconds after the first one -- the main thread stuck in a long call of
  compiled code, where Python cannot run its handler -- it deletes the staging folders
  (:func:`planner.files.outputs.abandon_staging`, which waits for a running commit), kills the
  children, prints the line and ends the process with ``128 + n``.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

SIGNALS: dict[int, str] = {signal.SIGINT: "SIGINT (Ctrl-C)", signal.SIGTERM: "SIGTERM"}
if hasattr(signal, "SIGHUP"):
    SIGNALS[signal.SIGHUP] = "SIGHUP"
GRACE_S = 0.8
"""Seconds the watchdog gives the main thread to unwind after the first signal."""

_STATE: dict[str, Any] = {"installed": False, "armed": False, "phase": "starting",
                          "signum": None, "t_signal": 0.0,
                          "pid": os.getpid(), "command": "qsplan", "t0": time.monotonic(),
                          "forked_from_main": False, "fork_hook": False,
                          "process": False}


class Interrupted(KeyboardInterrupt):
    """The command was interrupted by signal ``signum`` (exit code ``128 + signum``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return 128 + self.signum

    def __str__(self) -> str:
        return f"interrupted by {signal_name(self.signum)}"


def signal_name(signum: int) -> str:
    return SIGNALS.get(signum, f"signal {signum}")


def outputs_status() -> str:
    """What became of this process's outputs so far: those committed, those not written."""
    outputs = sys.modules.get("planner.files.outputs")

    def listed(name: str) -> list[str]:
        # a signal may come while the module is still being imported (partly initialised):
        # then it has no outputs to report yet
        get = getattr(outputs, name, None)
        return [str(p) for p in get()] if get is not None else []

    done, pending = listed("committed_outputs"), listed("pending_outputs")
    parts = []
    if done:
        parts.append(f"outputs written: {', '.join(map(repr, done))}")
    if pending:
        parts.append(f"not written: {', '.join(map(repr, pending))} (previous contents left "
                     "as they were)")
    left = listed("staging_left")
    if left:
        parts.append(f"the file system refused to delete the staging folder "
                     f"{', '.join(map(repr, left))}")
    return "; ".join(parts) or "no outputs written"


def describe(signum: int, command: str | None = None) -> str:
    """The one line printed for an interrupt: the command, the signal, the time it ran and
    what became of its outputs."""
    command = command or _STATE["command"]
    status = outputs_status()
    if _STATE["phase"] == "starting" and status == "no outputs written":
        return f"{command}: interrupted by {signal_name(signum)} while starting; nothing done"
    seconds = time.monotonic() - _STATE["t0"]
    return f"{command}: interrupted by {signal_name(signum)} after {seconds:.1f} s; {status}"


def say(line: str) -> None:
    """``line`` to stderr with one ``write`` (never raises: stderr may be closed)."""
    with contextlib.suppress(OSError, ValueError):
        os.write(2, (line + "\n").encode("utf-8", "replace"))


def descendants(pid: int | None = None) -> list[int]:
    """Process ids of every descendant of ``pid`` (default: this process), from ``/proc``;
    empty where there is no ``/proc``."""
    root = os.getpid() if pid is None else pid
    parent_of: dict[int, int] = {}
    try:
        names = os.listdir("/proc")
    except OSError:
        return []
    for name in names:
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat", "rb") as fh:
                    stat = fh.read()
            except OSError:
                continue
            fields = stat[stat.rfind(b")") + 2:].split()
            if len(fields) > 1:
                parent_of[int(name)] = int(fields[1])
    found: list[int] = []
    frontier = [root]
    while frontier:
        p = frontier.pop()
        kids = [c for c, pp in parent_of.items() if pp == p and c not in found]
        found += kids
        frontier += kids
    return found


def kill_children() -> list[int]:
    """SIGKILL every descendant process (pool workers); returns their ids.  Without ``/proc``:
    the processes ``multiprocessing`` started."""
    kids = descendants()
    if not kids and "multiprocessing" in sys.modules:
        with contextlib.suppress(Exception):
            kids = [p.pid for p in sys.modules["multiprocessing"].active_children()
                    if p.pid is not None]
    for pid in kids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    return kids


def _handler(signum: int, frame: Any) -> None:
    if os.getpid() != _STATE["pid"]:  # a forked child that kept the handler: the parent decides
        if signum == signal.SIGTERM:
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
        return
    if _STATE["signum"] is not None:
        return  # already ending: a second signal changes nothing
    _STATE["signum"], _STATE["t_signal"] = signum, time.monotonic()
    threading.excepthook = _quiet_after_signal  # before the workers die under their threads
    kill_children()
    if not _STATE["armed"] and _STATE["process"]:
        say(describe(signum))  # importing, parsing or exiting: nothing to unwind
        os._exit(128 + signum)
    outputs = sys.modules.get("planner.files.outputs")

    def deliver() -> None:
        raise Interrupted(signum)

    defer = getattr(outputs, "defer_interrupt", None)  # None while the module is imported
    if defer is not None and defer(deliver):
        return
    deliver()


def _quiet_after_signal(args: threading.ExceptHookArgs) -> None:
    """Thread exceptions once the command is ending on a signal: a process pool's management
    thread fails when it finds the workers the handler killed ("terminate_broken"), which is
    the intended end of those workers, not a fault to print; before a signal, Python's own
    hook."""
    if _STATE["signum"] is None:
        threading.__excepthook__(args)


def _before_fork() -> None:
    _STATE["forked_from_main"] = threading.current_thread() is threading.main_thread()


def _after_fork_in_child() -> None:
    if not _STATE["installed"]:
        return
    _STATE["installed"] = False
    with contextlib.suppress(ValueError, OSError):
        signal.set_wakeup_fd(-1)
    for signum in SIGNALS:
        with contextlib.suppress(ValueError, OSError):
            signal.signal(signum, signal.SIG_DFL if signum == signal.SIGTERM
                          else signal.SIG_IGN)
    if _STATE["forked_from_main"] and sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG
            if os.getppid() == 1:  # the parent died before the line above
                os._exit(128 + signal.SIGKILL)


def install(command: str = "qsplan", *, watchdog: bool = False) -> Callable[[], None]:
    """Set the handler for :data:`SIGNALS` (main thread only; elsewhere a no-op) and, with
    ``watchdog``, start the watchdog thread.  Returns a function that restores the previous
    handlers (a no-op when nothing was installed here)."""
    if threading.current_thread() is not threading.main_thread() or _STATE["installed"]:
        return lambda: None
    _STATE.update(installed=True, armed=False, phase="starting", signum=None, pid=os.getpid(),
                  command=command, t0=time.monotonic(), process=watchdog)
    previous = {s: signal.signal(s, _handler) for s in SIGNALS}
    if not _STATE["fork_hook"]:
        os.register_at_fork(before=_before_fork, after_in_child=_after_fork_in_child)
        _STATE["fork_hook"] = True
    if watchdog:
        _start_watchdog()
        atexit.register(_ignore_while_exiting)  # registered first: runs after the others

    def restore() -> None:
        for s, h in previous.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)
        _STATE.update(installed=False, armed=False, signum=None)

    return restore


@contextlib.contextmanager
def armed(command: str) -> Iterator[None]:
    """Inside: a signal raises :class:`Interrupted` (the caller turns it into the exit code)."""
    _STATE.update(command=command, armed=_STATE["installed"], phase="running")
    try:
        yield
    finally:
        _STATE.update(armed=False, phase="finishing")


def _ignore_while_exiting() -> None:
    """The last exit handler: the command's result is decided and its outputs are written,
    and Python is about to put its signal handling away (``SIG_DFL``) before collecting its
    objects (up to a second after a simulation); a signal then would kill the process without
    a word.  Ignored instead: the process ends with its own exit code."""
    for signum in SIGNALS:
        with contextlib.suppress(ValueError, OSError):
            signal.signal(signum, signal.SIG_IGN)


def _start_watchdog() -> None:
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    try:
        signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    except (ValueError, OSError):
        os.close(read_fd)
        os.close(write_fd)
        return
    threading.Thread(target=_watch, args=(read_fd,), name="qsplan-interrupt-watchdog",
                     daemon=True).start()


def _watch(read_fd: int) -> None:
    pid = os.getpid()
    while True:
        try:
            data = os.read(read_fd, 64)
        except OSError:
            return
        if not data or os.getpid() != pid:
            return
        signum = next((b for b in data if b in SIGNALS), None)
        if signum is None:
            continue
        time.sleep(GRACE_S)
        if os.getpid() != pid:
            return
        force_exit(_STATE["signum"] or signum)


def end_if_interrupted(code: int) -> None:
    """In the ``qsplan`` process, after a signal: flush stdout and stderr and end the process
    now with ``code`` -- Python's own shutdown (garbage collection, engine objects' finalisers)
    can take most of a second after a simulation, and nothing is left to do."""
    if _STATE["process"] and _STATE["signum"] is not None and os.getpid() == _STATE["pid"]:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)


def force_exit(signum: int) -> None:
    """End the process now: staging folders deleted (after a running commit), children
    killed, the line printed, exit ``128 + signum``."""
    abandon = getattr(sys.modules.get("planner.files.outputs"), "abandon_staging", None)
    if abandon is not None:  # None while the module is still being imported
        abandon()
    kill_children()
    say(describe(signum))
    os._exit(128 + signum)
