"""Checks of output paths and output sets, before any work (:mod:`planner.files.outputs`).

:func:`check_output_path`: the destination itself -- a path that exists and is neither a
regular file nor a directory (a FIFO, a device, a socket, or a symlink to one) is refused,
never replaced; so is a path of the wrong kind (a file where a folder is wanted and vice
versa), a path below a regular file, and a folder that cannot be written.
:func:`check_entry`: an entry a command declares it writes in an existing folder -- absent, or
of the declared kind, never a symbolic link or a special file; a folder entry (replaced as a
whole) holds nothing that cannot be deleted (special files, mount points).  Every problem is an
:class:`planner.errors.InputError` naming the path, what was expected and what is there.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from planner.errors import InputError

Kind = Literal["file", "dir"]


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
        raise InputError(f"{what}: expected a writable location, got {str(path)!r} "
                         f"({unwritable(parent)})")
    return parent


def unwritable(folder: Path | str) -> str:
    """Why ``folder`` cannot be written: its file system is read-only, or no permission."""
    try:
        if os.statvfs(folder).f_flag & getattr(os, "ST_RDONLY", 1):
            return f"the file system of {str(folder)!r} is read-only"
    except OSError:
        pass
    return f"no permission to write in {str(folder)!r}"


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
            raise InputError(f"{what}: expected a writable location, got {text!r} "
                             f"({unwritable(folder)})")
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
            if not os.path.lexists(d):  # moved away meanwhile (another writer): nothing to check
                continue
            raise InputError(f"{what}: expected a writable folder {str(d)!r} inside "
                             f"{str(folder)!r}, which the command replaces as a whole, got "
                             f"{unwritable(d)}")
        try:
            with os.scandir(d) as it:
                found = [(Path(e.path), e.stat(follow_symlinks=False).st_mode) for e in it]
        except FileNotFoundError:  # moved away meanwhile (another writer)
            continue
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
