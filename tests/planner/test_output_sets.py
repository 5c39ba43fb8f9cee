"""Output sets with declared entries: checked entirely before any work, committed whole.

``planner.files.outputs.output_set(dest, "dir", entries=(...))``: every declared entry of an
existing folder is checked before the block runs (a file where a folder goes, a symbolic link,
a special file anywhere inside a folder that would be replaced: exit 2 naming it), the commit
is all or nothing (a failing rename undoes the others), special files are never replaced or
deleted, concurrent writers never mix their sets, and paths inside the staging folder map to
their final names."""

from __future__ import annotations

import json
import multiprocessing
import os
import stat

import pytest

import planner.files.outputs as outputs
from planner.errors import InputError
from planner.files.outputs import STAGING_PREFIX, final_path, output_set

ENTRIES = ("summary.json", "mu_0/", "mu_0.1/")


def _tree(root):
    out = {}
    for p in sorted(root.rglob("*")):
        st = os.lstat(p)
        rel = str(p.relative_to(root))
        out[rel] = p.read_bytes() if stat.S_ISREG(st.st_mode) else stat.S_IFMT(st.st_mode)
    return out


def _old_set(dest):
    (dest / "mu_0").mkdir(parents=True)
    (dest / "mu_0" / "summary.json").write_text("old 0")
    (dest / "summary.json").write_text("old")
    (dest / "notes.txt").write_text("mine")


def _fresh(path, make):
    path.unlink()
    make(path)


def _write_new(work):
    (work / "summary.json").write_text("new")
    for name in ("mu_0", "mu_0.1"):
        (work / name).mkdir()
        (work / name / "summary.json").write_text(f"new {name}")


@pytest.mark.parametrize("make,message", [
    (lambda d: (d / "mu_0.1").write_text("a file"),
     "mu_0.1' to be a directory or absent (the command writes it), got a regular file"),
    (lambda d: os.symlink(d / "elsewhere", d / "mu_0.1"), "got a symbolic link to"),
    (lambda d: _fresh(d / "summary.json", lambda p: os.symlink(d / "notes.txt", p)),
     "got a symbolic link to"),
    (lambda d: _fresh(d / "summary.json", os.mkfifo),
     "got a FIFO (named pipe); it is not replaced"),
    (lambda d: _fresh(d / "summary.json", os.mkdir), "to be a regular file or absent"),
    (lambda d: ((d / "mu_0.1" / "deep").mkdir(parents=True),
                os.mkfifo(d / "mu_0.1" / "deep" / "pipe")),
     "mu_0.1/deep/pipe', which is a FIFO (named pipe); it is not deleted"),
])
def test_declared_entries_are_checked_before_any_work(tmp_path, make, message):
    dest = tmp_path / "out"
    _old_set(dest)
    make(dest)
    before = _tree(dest)
    ran = []
    with pytest.raises(InputError, match="--out: expected") as exc:
        with output_set(dest, "dir", entries=ENTRIES):
            ran.append(1)
    assert message in str(exc.value) and not ran
    assert _tree(dest) == before


def test_undeclared_entry_is_a_programming_error(tmp_path):
    with pytest.raises(RuntimeError, match=r"undeclared entries \['timeline.png'\]"):
        with output_set(tmp_path / "out", "dir", entries=("summary.json",)) as work:
            (work / "summary.json").write_text("x")
            (work / "timeline.png").write_text("x")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="expected a new top-level name"):
        with output_set(tmp_path / "out", "dir", entries=("a/b",)):
            pass


def test_a_file_where_a_folder_goes_replaces_nothing_without_declaration(tmp_path):
    """The command that does not declare its entries: checked at the end, every target before
    the first rename -- ``mu_0`` stays old although it comes first."""
    dest = tmp_path / "out"
    _old_set(dest)
    (dest / "mu_0.1").write_text("a file")
    before = _tree(dest)
    with pytest.raises(InputError, match="mu_0.1' to be a directory or absent"):
        with output_set(dest, "dir") as work:
            _write_new(work)
    assert _tree(dest) == before


def test_fifo_inside_a_folder_to_replace_is_never_deleted(tmp_path):
    dest = tmp_path / "out"
    _old_set(dest)
    (dest / "mu_0.1").mkdir()
    os.mkfifo(dest / "mu_0.1" / "pipe")
    with pytest.raises(InputError, match="it is not deleted"):
        with output_set(dest, "dir") as work:
            _write_new(work)
    assert stat.S_ISFIFO(os.lstat(dest / "mu_0.1" / "pipe").st_mode)
    assert (dest / "mu_0" / "summary.json").read_text() == "old 0"


def test_a_failing_rename_undoes_the_whole_commit(tmp_path, monkeypatch):
    dest = tmp_path / "out"
    _old_set(dest)
    before = _tree(dest)
    real = os.rename
    calls = []

    def flaky(src, dst):
        calls.append(dst)
        if str(dst).endswith("mu_0.1") and STAGING_PREFIX not in str(dst):
            raise OSError(28, "No space left on device", str(dst))
        return real(src, dst)

    monkeypatch.setattr(os, "rename", flaky)
    with pytest.raises(OSError, match="No space left"):
        with output_set(dest, "dir", entries=ENTRIES) as work:
            _write_new(work)
    monkeypatch.undo()
    assert len(calls) > 3  # old entries moved aside, new ones in, then undone
    assert _tree(dest) == before
    with output_set(dest, "dir", entries=ENTRIES) as work:
        _write_new(work)
    after = _tree(dest)
    assert after["summary.json"] == b"new" and after["notes.txt"] == b"mine"
    assert after["mu_0/summary.json"] == b"new mu_0" and "mu_0.1/summary.json" in after
    assert not any(".qsplan-" in k for k in after)


def test_a_declared_entry_not_written_goes_with_the_old_set(tmp_path):
    """``plan --figures`` declares every picture it may draw; a plan that draws Figures 10-13
    into a folder holding a task's pictures from before must not leave them beside the new
    figures (a set half old, half new). Files the command does not declare stay."""
    dest = tmp_path / "figs"
    dest.mkdir()
    for name in ("fig10.png", "task_story.png", "notes.txt"):
        (dest / name).write_text("old")
    with output_set(dest, "dir", entries=("fig10.png", "task_story.png")) as work:
        (work / "fig10.png").write_text("new")
    assert sorted(p.name for p in dest.iterdir()) == ["fig10.png", "notes.txt"]
    assert (dest / "fig10.png").read_text() == "new"
    assert (dest / "notes.txt").read_text() == "old"


def test_a_new_destination_is_one_rename(tmp_path, monkeypatch):
    renames = []
    real = os.rename
    monkeypatch.setattr(os, "rename", lambda a, b: (renames.append((a, b)), real(a, b)))
    dest = tmp_path / "a" / "out"
    with output_set(dest, "dir", entries=ENTRIES) as work:
        _write_new(work)
    assert len(renames) == 1 and str(renames[0][1]) == str(dest)
    assert sorted(_tree(dest)) == ["mu_0", "mu_0.1", "mu_0.1/summary.json", "mu_0/summary.json",
                                   "summary.json"]


def test_final_path_names_the_destination(tmp_path):
    dest = tmp_path / "out"
    with output_set(dest, "dir", entries=ENTRIES) as work:
        assert STAGING_PREFIX in str(work)
        assert final_path(work / "mu_0" / "timeline.png") == dest / "mu_0" / "timeline.png"
        assert final_path(work) == dest
        assert final_path(tmp_path / "x") == tmp_path / "x"
        (work / "summary.json").write_text("x")
    with output_set(tmp_path / "p.json", "file") as tmp:
        assert final_path(tmp) == tmp_path / "p.json"
    assert final_path(work / "summary.json") == dest / "summary.json"  # also afterwards


def _writer(dest, tag, rounds):
    for k in range(rounds):
        with output_set(dest, "dir", entries=ENTRIES) as work:
            (work / "summary.json").write_text(json.dumps([tag, k]))
            for name in ("mu_0", "mu_0.1"):
                (work / name).mkdir()
                (work / name / "summary.json").write_text(json.dumps([tag, k]))


def test_concurrent_writers_never_mix_their_sets(tmp_path):
    dest = tmp_path / "out"
    ctx = multiprocessing.get_context("fork")
    procs = [ctx.Process(target=_writer, args=(dest, tag, 25)) for tag in ("a", "b", "c")]
    for p in procs:
        p.start()
    seen = set()
    while any(p.is_alive() for p in procs):
        try:
            files = [dest / "summary.json", dest / "mu_0" / "summary.json",
                     dest / "mu_0.1" / "summary.json"]
            values = {f.read_text() for f in files}
        except (FileNotFoundError, NotADirectoryError):
            continue
        seen.add(len(values))
    for p in procs:
        p.join()
        assert p.exitcode == 0
    final = {json.loads((dest / f).read_text())[0] for f in
             ("summary.json", "mu_0/summary.json", "mu_0.1/summary.json")}
    assert len(final) == 1
    assert sorted(p.name for p in dest.iterdir()) == ["mu_0", "mu_0.1", "summary.json"]
    assert outputs.STAGING_PREFIX not in " ".join(str(p) for p in tmp_path.rglob("*"))
