"""Output paths and output sets: checked entirely before any work, moved into place at the end.

A command that writes several files (a plan and its figures, a mu-space JSON and its PNG, a
validation folder) writes them into a hidden staging folder and moves them into place only
when everything was written (:func:`output_set`).  A failed or interrupted run therefore leaves
the previous outputs whole and no new or empty folders.  Single files keep the atomic writes of
:mod:`planner.files.atomic`.

Declaring an output set (the API for commands)::

    with output_set(args.out, "dir", entries=("summary.json", "timeline.png", "mu_0.1/")
                    ) as work:
        ...  # the work; write work / "summary.json", work / "mu_0.1" / "summary.json", ...

``entries`` names every top-level entry the command may write in the folder, a trailing ``/``
for a folder.  Before the block runs -- before any work -- the destination is checked
(:func:`check_output_path`) and so is every declared entry of an existing folder
(:func:`check_entry`): an entry that exists must be of the declared kind (a regular file where
a file goes, a directory where a folder goes), never a symbolic link or a special file (FIFO,
socket, device); a folder entry is replaced as a whole, so nothing anywhere inside it may be a
special file or a mount point (they are never deleted).  Each problem raises
:class:`planner.errors.InputError` naming the path (exit 2).  The block may write only declared
entries (writing another one is a programming error).  Without ``entries`` the same checks run
on what the block wrote, at the end (after the work).

Committing: a new destination is one ``rename`` of the staging folder (missing parent folders
are created, like ``mkdir -p``, only then).  Into an existing folder, the written entries
replace the entries of the same name, each as a whole, and a declared entry this run did not
write goes with the old set (a set is never half old, half new); other files stay: the targets are
checked again, the old entries are moved aside and the new ones moved in, and if any rename
fails every rename is undone (the old set stays whole).  The commit is one uninterruptible step:
an interrupt that a handler defers through :func:`defer_interrupt` (the command line's does)
takes effect when the commit is over, and concurrent commits to one folder are serialised by
an advisory lock (``flock``) on it.

Paths inside a staging folder are not the outputs' names: :func:`final_path` maps them to the
destination (for summaries, messages, report titles).  :func:`abandon_staging` deletes every
staging folder of this process (an emergency exit that cannot unwind); :func:`staging_left`
names those a file system refused to delete (read-only, or a permission lost mid-run).  The
checks live in :mod:`planner.files.output_checks` (re-exported here).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

from planner.errors import InputError
from planner.files.atomic import current_umask
from planner.files.output_checks import (
    Entry,
    Kind,
    check_entry,
    check_output_path,
    check_output_set,
    describe_mode,
    nearest_existing_ancestor,
    parse_entries,
)

__all__ = ["Entry", "Kind", "OLD_PREFIX", "STAGING_PREFIX", "abandon_staging", "check_entry",
           "check_output_path", "check_output_set", "committed_outputs", "defer_interrupt",
           "describe_mode", "final_path", "forget_history", "nearest_existing_ancestor",
           "output_set", "parse_entries", "pending_outputs", "staging_left", "uninterruptible"]

STAGING_PREFIX = ".qsplan-staging-"
OLD_PREFIX = ".qsplan-old-"

_LOCK = threading.Lock()  # held by a commit and by abandon_staging
_LIVE: dict[Path, tuple[Path, Kind]] = {}  # staging / old-entries folder -> (destination, kind)
_NAMES: dict[Path, tuple[Path, Kind]] = {}  # every staging folder of this process -> the same
_COMMITTED: list[Path] = []
_ABANDONED: list[Path] = []  # destinations whose set was not committed (failed, interrupted)
_LEFT: list[Path] = []  # staging folders the file system refused to delete
_DEPTH = [0]  # uninterruptible sections entered (main thread)
_DEFERRED: list[Callable[[], None]] = []


# -- interrupts, locks and the registry ------------------------------------------------------
@contextlib.contextmanager
def uninterruptible() -> Iterator[None]:
    """A section an interrupt must not cut: an interrupt deferred during it
    (:func:`defer_interrupt`) is delivered when the outermost section ends."""
    _DEPTH[0] += 1
    try:
        yield
    finally:
        _DEPTH[0] -= 1
        if not _DEPTH[0] and _DEFERRED:
            deliver = _DEFERRED[0]
            _DEFERRED.clear()
            deliver()


def defer_interrupt(deliver: Callable[[], None]) -> bool:
    """For a signal handler: inside an :func:`uninterruptible` section of the main thread,
    keep ``deliver`` (it raises the interrupt) for the section's end and return True; else
    return False (the handler raises now)."""
    if _DEPTH[0] and threading.current_thread() is threading.main_thread():
        _DEFERRED.append(deliver)
        return True
    return False


@contextlib.contextmanager
def _folder_lock(folder: Path) -> Iterator[None]:
    """An exclusive advisory lock (``flock``) on a folder, where the platform has one."""
    try:
        import fcntl

        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except (ImportError, OSError):
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def final_path(path: str | os.PathLike[str]) -> Path:
    """The name ``path`` has once its output set is committed: a path inside a staging folder
    of this process (live, committed or given up) maps to the destination; any other path is
    returned as it is."""
    p = Path(path)
    absolute = p.absolute()
    for staging, (dest, kind) in list(_NAMES.items()):
        try:
            rel = absolute.relative_to(staging)
        except ValueError:
            continue
        if kind == "file":
            return dest if rel == Path(dest.name) else dest.parent / rel
        return dest if rel == Path(".") else dest / rel
    return p


def committed_outputs() -> tuple[Path, ...]:
    """Destinations committed by this process so far."""
    return tuple(_COMMITTED)


def pending_outputs() -> tuple[Path, ...]:
    """Destinations of the output sets of this process not committed: being written now, or
    given up (a failed or interrupted block)."""
    live = [dest for staging, (dest, _) in list(_LIVE.items())
            if staging.name.startswith(STAGING_PREFIX)]
    return tuple(dict.fromkeys(_ABANDONED + live))


def forget_history() -> None:
    """Start a new command's record: no committed, given-up or left-behind sets (for a
    program that runs several commands in one process)."""
    _COMMITTED.clear()
    _ABANDONED.clear()
    _LEFT.clear()


def staging_left() -> tuple[Path, ...]:
    """Staging folders of this process that could not be deleted (the file system refused:
    read-only, or the permission to write there was lost)."""
    return tuple(_LEFT)


def abandon_staging(timeout: float = 10.0) -> tuple[Path, ...]:
    """Delete every staging folder of this process and keep every later commit from starting
    (for an exit that cannot unwind the stack); waits up to ``timeout`` s for a running commit.
    Returns the destinations that were left as they were."""
    _LOCK.acquire(timeout=timeout)  # never released: the process is about to end
    dests = []
    for staging, (dest, _) in list(_LIVE.items()):
        shutil.rmtree(staging, ignore_errors=True)
        if not staging.name.startswith(OLD_PREFIX):
            dests.append(dest)
    return tuple(dests)


# -- the output set ----------------------------------------------------------------------------
@contextlib.contextmanager
def output_set(dest: str | os.PathLike[str], kind: Kind = "dir", what: str = "--out",
               entries: Iterable[str] | None = None) -> Iterator[Path]:
    """Stage a command's outputs and move them to ``dest`` when the block ends without error.

    ``kind="dir"``: yields a staging folder; write the output set into it (``entries``: the
    top-level names the block may write, a trailing ``/`` for folders; module docstring).  On
    success, if ``dest`` does not exist the folder is renamed to ``dest``; if it does, each
    written entry replaces the entry of the same name in ``dest`` (other files there are left
    alone).  ``kind="file"``: yields the path to write the file at; on success it replaces
    ``dest``.  On an exception the staging folder is deleted and ``dest`` is untouched.

    The destination and the declared entries are checked and the staging folder created
    before the block runs, so an unusable destination fails before any work.
    """
    declared = parse_entries(entries) if entries is not None else None
    if kind == "file" and declared:
        raise ValueError("output_set: entries are for kind='dir'")
    target = check_output_set(dest, kind, what, declared or ())
    home = target if kind == "dir" and target.is_dir() else nearest_existing_ancestor(
        target if kind == "dir" else target.absolute(), what)
    try:
        staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=home)).absolute()
    except OSError as exc:
        raise InputError(f"{what}: expected a writable location, got {os.fspath(dest)!r} "
                         f"({exc.strerror} in {str(home)!r})") from None
    os.chmod(staging, 0o777 & ~current_umask())  # mkdtemp makes 0700; a plain mkdir would not
    _LIVE[staging] = _NAMES[staging] = (target, kind)
    old: Path | None = None
    committed = False
    try:
        yield staging / target.name if kind == "file" else staging
        with uninterruptible():
            with _LOCK:
                if kind == "file":
                    moved = _commit_file(staging / target.name, target, home, what)
                else:
                    moved, old = _commit_dir(staging, target, home, what, declared)
                    if old is not None:
                        _LIVE[old] = (target, kind)
                if moved:
                    _COMMITTED.append(target)
                committed = True
    finally:
        if not committed:
            _ABANDONED.append(target)
        for folder in (staging, old):
            if folder is not None:
                shutil.rmtree(folder, ignore_errors=True)
                _LIVE.pop(folder, None)
                if os.path.lexists(folder):  # a file system turned read-only, a lost permission
                    _LEFT.append(folder)


def _commit_file(produced: Path, dest: Path, home: Path, what: str) -> bool:
    """Move the written file into place; False when none was written."""
    if not produced.exists():
        return False
    with _folder_lock(home):
        check_output_path(dest, "file", what)  # again: the world may have changed meanwhile
        dest.absolute().parent.mkdir(parents=True, exist_ok=True)
        os.replace(produced, dest)
    return True


def _commit_dir(staging: Path, dest: Path, home: Path, what: str,
                declared: tuple[Entry, ...] | None) -> tuple[bool, Path | None]:
    """Move the written entries into place; returns (anything moved, the folder holding the
    replaced old entries (to delete) or None)."""
    written = [Entry(p.name, "dir" if p.is_dir() and not p.is_symlink() else "file")
               for p in sorted(staging.iterdir())]
    if declared is not None:
        allowed = set(declared)
        wrong = [e for e in written if e not in allowed]
        if wrong:
            raise RuntimeError(f"output set {str(dest)!r}: wrote undeclared entries "
                               f"{[e.name + ('/' if e.kind == 'dir' else '') for e in wrong]}")
    if not written:
        return False, None  # nothing written: no empty folder
    with _folder_lock(home):
        if not os.path.lexists(dest):
            dest.absolute().parent.mkdir(parents=True, exist_ok=True)
            try:
                os.rename(staging, dest)  # the whole set in one move
                return True, None
            except OSError:  # created meanwhile by another writer: move the entries in
                pass
        check_output_path(dest, "dir", what)
        same = dest.absolute() == home.absolute()
        with contextlib.nullcontext() if same else _folder_lock(dest):
            # a declared entry this run did not write belongs to the old set: it goes too
            stale = [e for e in (declared or ()) if e not in written
                     and os.path.lexists(dest / e.name)]
            for e in written + stale:
                check_entry(dest, e, what)  # again: the world may have changed meanwhile
            return True, _swap_in(staging, dest, [e.name for e in written],
                                  [e.name for e in stale])


def _swap_in(staging: Path, dest: Path, names: list[str],
             stale: Sequence[str] = ()) -> Path:
    """Old entries aside (``names`` and the ``stale`` declared entries not written this
    time), new entries in; every rename undone if one fails."""
    old = Path(tempfile.mkdtemp(prefix=OLD_PREFIX, dir=dest))
    moved_old: list[str] = []
    moved_new: list[str] = []
    try:
        for n in [*names, *stale]:
            if os.path.lexists(dest / n):
                os.rename(dest / n, old / n)
                moved_old.append(n)
        for n in names:
            os.rename(staging / n, dest / n)
            moved_new.append(n)
    except BaseException:
        for n in reversed(moved_new):
            with contextlib.suppress(OSError):
                os.rename(dest / n, staging / n)
        for n in reversed(moved_old):
            with contextlib.suppress(OSError):
                os.rename(old / n, dest / n)
        with contextlib.suppress(OSError):
            os.rmdir(old)
        raise
    return old
