"""Output paths and output sets: checked before any work, moved into place at the end.

A command that writes several files (a plan and its figures, a mu-space JSON and its PNG, a
validation folder) writes them into a hidden staging folder next to the destination and moves
them into place only when everything was written (:func:`output_set`).  A failed run therefore
leaves the previous outputs whole and no empty folders.  Single files keep the atomic writes of
:mod:`planner.files.atomic`.

Destinations are checked first (:func:`check_output_path`): a path that exists and is neither a
regular file nor a directory (a FIFO, a device, a socket, or a symlink to one) is refused, never
replaced; so is a path of the wrong kind (a file where a folder is wanted and vice versa), a
path below a regular file, and a folder that cannot be written.  Missing parent folders are
created (like ``mkdir -p``), but only when the output set is moved into place.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Literal

from planner.errors import InputError
from planner.files.atomic import current_umask

Kind = Literal["file", "dir"]
STAGING_PREFIX = ".qsplan-staging-"
_OLD_PREFIX = ".qsplan-old-"


def describe_mode(mode: int) -> str:
    """A word for the kind of file ``mode`` (from ``os.stat``) is: "a FIFO", "a socket", ..."""
    for test, word in ((stat.S_ISREG, "a regular file"), (stat.S_ISDIR, "a directory"),
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


def _move_into(src: Path, dest: Path) -> None:
    """Move every entry of the folder ``src`` into the existing folder ``dest``, replacing
    entries of the same name as a whole (a folder by a folder, a file by a file)."""
    entries = sorted(src.iterdir())
    for entry in entries:  # refuse before moving anything
        target = dest / entry.name
        st = _stat(target, str(dest))
        if st is not None and not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)):
            raise InputError(f"output: expected {str(target)!r} to be a regular file, a "
                             f"directory or absent, got {describe_mode(st.st_mode)}; it is "
                             "not replaced")
    for entry in entries:
        target = dest / entry.name
        if target.is_dir() and not target.is_symlink():
            old = Path(tempfile.mkdtemp(prefix=_OLD_PREFIX, dir=dest))
            os.rename(target, old / entry.name)
            os.rename(entry, target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(entry, target)


def _commit(staging: Path, dest: Path, kind: Kind) -> None:
    if kind == "file":
        produced = staging / dest.name
        if produced.exists():
            dest.absolute().parent.mkdir(parents=True, exist_ok=True)
            os.replace(produced, dest)
        return
    if not any(staging.iterdir()):
        return  # nothing written: no empty folder
    if dest.is_dir():
        _move_into(staging, dest)
    else:
        dest.absolute().parent.mkdir(parents=True, exist_ok=True)
        os.rename(staging, dest)


@contextlib.contextmanager
def output_set(dest: str | os.PathLike[str], kind: Kind = "dir",
               what: str = "--out") -> Iterator[Path]:
    """Stage a command's outputs and move them to ``dest`` when the block ends without error.

    ``kind="dir"``: yields a staging folder; write the output set into it.  On success, if
    ``dest`` does not exist the folder is renamed to ``dest``; if it does, each entry replaces
    the entry of the same name in ``dest`` (other files there are left alone).
    ``kind="file"``: yields the path to write the file at; on success it replaces ``dest``.
    On an exception the staging folder is deleted and ``dest`` is untouched.

    The destination is checked (:func:`check_output_path`) and the staging folder created
    before the block runs, so an unusable destination fails before any work.
    """
    target = check_output_path(dest, kind, what)
    home = target if kind == "dir" and target.is_dir() else nearest_existing_ancestor(
        target if kind == "dir" else target.absolute(), what)
    try:
        staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=home))
    except OSError as exc:
        raise InputError(f"{what}: expected a writable location, got {os.fspath(dest)!r} "
                         f"({exc.strerror} in {str(home)!r})") from None
    os.chmod(staging, 0o777 & ~current_umask())  # mkdtemp makes 0700; a plain mkdir would not
    committed = False
    try:
        yield staging / target.name if kind == "file" else staging
        _commit(staging, target, kind)
        committed = True
    finally:
        if not committed or staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
