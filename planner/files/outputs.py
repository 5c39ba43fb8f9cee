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
replace the entries of the same name, each as a whole, other files stay: the targets are
checked again, the old entries are moved aside and the new ones moved in, and if any rename
fails every rename is undone (the old set stays whole).  The commit is one uninterruptible step:
an interrupt that a handler defers through :func:`defer_interrupt` (the command line's does)
takes effect when the commit is over, and concurrent commits to one folder are serialised by
an advisory lock (``flock``) on it.

Paths inside a staging folder are not the outputs' names: :func:`final_path` maps them to the
destination (for summaries, messages, report titles).  :func:`abandon_staging` deletes every
staging folder of this process (an emergency exit that cannot unwind).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from planner.errors import InputError
from planner.files.atomic import current_umask

Kind = Literal["file", "dir"]
STAGING_PREFIX = ".qsplan-staging-"
OLD_PREFIX = ".qsplan-old-"

_LOCK = threading.Lock()  # held by a commit and by abandon_staging
_LIVE: dict[Path, tuple[Path, Kind]] = {}  # staging / old-entries folder -> (destination, kind)
_NAMES: dict[Path, tuple[Path, Kind]] = {}  # every staging folder of this process -> the same
_COMMITTED: list[Path] = []
_ABANDONED: list[Path] = []  # destinations whose set was not committed (failed, interrupted)
_DEPTH = [0]  # uninterruptible sections entered (main thread)
_DEFERRED: list[Callable[[], None]] = []


def describe_mode(mode: int) -> str:
    """A word for the kind of file ``mode`` (from ``os.stat``) is: "a FIFO", "a socket", ..."""
    for test, word in ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a directory"),
                       (stat.S_ISLNK, "a symbolic link"),
                       (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device")):
        if test(mode):
            return word
    return "a special file"


def _stat(path: Path, what: str) -> os.stat_result | None:
    """``os.stat`` (following symlinks); None when nothing is there."""
    try:
        return os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            raise InputError(f"{what}: expected a regular file or directory, got a dangling "
                             f"symbolic link {str(path)!r}") from None
        return None
    except NotADirectoryError:
        raise InputError(f"{what}: expected a path below a directory, got {str(path)!r} (a "
                         "parent is a regular file)") from None
    except OSError as exc:
        raise InputError(f"{what}: expected an accessible path, got {str(path)!r} "
                         f"({exc.strerror})") from None


def nearest_existing_ancestor(path: Path, what: str) -> Path:
    """The closest existing folder at or above ``path``'s parent; errors if it is not a
    writable directory."""
    parent = path.absolute().parent
    while True:
        st = _stat(parent, what)
        if st is not None:
            break
        parent = parent.parent
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{what}: expected a path below a directory, got {str(path)!r} "
                         f"({str(parent)!r} is {describe_mode(st.st_mode)})")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{what}: expected a writable location, got {str(path)!r} (no "
                         f"permission to write in {str(parent)!r})")
    return parent


def check_output_path(path: str | os.PathLike[str], kind: Kind, what: str = "--out") -> Path:
    """Check that ``path`` can become an output of ``kind`` ("file" or "dir") without replacing
    anything but a regular file (``kind="file"``) or writing into an existing directory
    (``kind="dir"``); nothing is created.  Returns the path.

    Raises :class:`planner.errors.InputError` naming ``what`` (e.g. ``"--out"``), what was
    expected and what is there.
    """
    text = os.fspath(path)
    if not text or "\x00" in text:
        raise InputError(f"{what}: expected a path, got {text!r}")
    p = Path(text)
    if len(os.fsencode(p.name)) > 255:
        raise InputError(f"{what}: expected a file name of at most 255 bytes, got one of "
                         f"{len(os.fsencode(p.name))}")
    st = _stat(p, what)
    wanted = "a regular file" if kind == "file" else "a directory"
    if st is None:
        nearest_existing_ancestor(p, what)
        return p
    if kind == "file" and stat.S_ISREG(st.st_mode) or kind == "dir" and stat.S_ISDIR(st.st_mode):
        folder = p.absolute().parent if kind == "file" else p
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputError(f"{what}: expected a writable location, got {text!r} (no "
                             f"permission to write in {str(folder)!r})")
        return p
    link = " (through a symbolic link)" if os.path.islink(p) else ""
    raise InputError(f"{what}: expected {wanted} or a new path, got {text!r}, which is "
                     f"{describe_mode(st.st_mode)}{link}; it is not replaced")


# -- declared entries ----------------------------------------------------------------------
@dataclass(frozen=True)
class Entry:
    """A top-level entry of an output folder: its ``name`` and ``kind`` ("file" or "dir")."""

    name: str
    kind: Kind


def parse_entries(entries: Iterable[str]) -> tuple[Entry, ...]:
    """``("summary.json", "mu_0.1/")`` -> entries (a trailing ``/``: a folder).  A name with a
    path separator, ``.``/``..``, the staging prefix or a repeat is a programming error
    (``ValueError``)."""
    out: dict[str, Entry] = {}
    for text in entries:
        name = text[:-1] if text.endswith("/") else text
        if (not name or "/" in name or "\x00" in name or name in (".", "..")
                or name.startswith(".qsplan-") or name in out):
            raise ValueError(f"output entry: expected a new top-level name, got {text!r}")
        out[name] = Entry(name, "dir" if text.endswith("/") else "file")
    return tuple(out.values())


def _lstat(path: Path, what: str) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise InputError(f"{what}: expected an accessible path, got {str(path)!r} "
                         f"({exc.strerror})") from None


def check_entry(folder: Path, entry: Entry, what: str = "--out") -> None:
    """Check that ``folder / entry.name`` can be replaced by the entry: absent, or of the same
    kind and neither a symbolic link nor a special file; a folder must hold nothing that
    replacing it would delete and must not (special files, mount points)."""
    target = folder / entry.name
    st = _lstat(target, what)
    if st is None:
        return
    wanted = "a regular file" if entry.kind == "file" else "a directory"
    fits = stat.S_ISREG(st.st_mode) if entry.kind == "file" else stat.S_ISDIR(st.st_mode)
    if not fits:
        got = describe_mode(st.st_mode)
        if stat.S_ISLNK(st.st_mode):
            got += f" to {os.readlink(target)!r}"
        raise InputError(f"{what}: expected {str(target)!r} to be {wanted} or absent (the "
                         f"command writes it), got {got}; it is not replaced")
    if entry.kind == "dir":
        _check_tree(target, what)


def _check_tree(folder: Path, what: str) -> None:
    """Everything under ``folder`` (replaced as a whole): regular files, folders and symbolic
    links only (a link is removed, never followed), no mount point, every folder writable."""
    stack = [folder]
    while stack:
        d = stack.pop()
        if d != folder and os.path.ismount(d):
            raise InputError(f"{what}: expected only files and folders inside {str(folder)!r}, "
                             f"which the command replaces as a whole, got the mount point "
                             f"{str(d)!r}; it is not replaced")
        if not os.access(d, os.W_OK | os.X_OK):
            raise InputError(f"{what}: expected a writable folder {str(d)!r} inside "
                             f"{str(folder)!r}, which the command replaces as a whole, got no "
                             "permission to delete in it")
        try:
            with os.scandir(d) as it:
                found = [(Path(e.path), e.stat(follow_symlinks=False).st_mode) for e in it]
        except OSError as exc:
            raise InputError(f"{what}: expected a readable folder, got {str(d)!r} "
                             f"({exc.strerror})") from None
        for path, mode in found:
            if stat.S_ISDIR(mode):
                stack.append(path)
            elif not (stat.S_ISREG(mode) or stat.S_ISLNK(mode)):
                raise InputError(
                    f"{what}: expected only files and folders inside {str(folder)!r}, which "
                    f"the command replaces as a whole, got {str(path)!r}, which is "
                    f"{describe_mode(mode)}; it is not deleted")


def check_output_set(dest: str | os.PathLike[str], kind: Kind, what: str = "--out",
                     entries: Iterable[Entry] = ()) -> Path:
    """:func:`check_output_path` and, for an existing folder, :func:`check_entry` of every
    declared entry.  Returns the destination path; nothing is created."""
    target = check_output_path(dest, kind, what)
    if kind == "dir" and os.path.isdir(target):
        for e in entries:
            check_entry(target, e, what)
    return target


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
            for e in written:
                check_entry(dest, e, what)  # again: the world may have changed meanwhile
            return True, _swap_in(staging, dest, [e.name for e in written])


def _swap_in(staging: Path, dest: Path, names: list[str]) -> Path:
    """Old entries aside, new entries in; every rename undone if one fails."""
    old = Path(tempfile.mkdtemp(prefix=OLD_PREFIX, dir=dest))
    moved_old: list[str] = []
    moved_new: list[str] = []
    try:
        for n in names:
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
