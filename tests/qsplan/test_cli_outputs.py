"""Output paths and output sets (planner.files.outputs): checked before any work, staged, moved
into place whole; special files refused, never replaced."""

from __future__ import annotations

import os
import stat

import pytest

from planner.errors import InputError
from planner.files.outputs import STAGING_PREFIX, check_output_path, output_set


def _tree(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_new_folder_with_missing_parents_appears_only_at_the_end(tmp_path):
    dest = tmp_path / "a" / "b" / "out"
    with output_set(dest, "dir") as work:
        (work / "x.json").write_text("1")
        (work / "sub").mkdir()
        (work / "sub" / "y.png").write_text("2")
        assert not (tmp_path / "a").exists()  # nothing visible before the set is complete
    assert _tree(dest) == ["sub", "sub/y.png", "x.json"]
    assert not any(p.name.startswith(STAGING_PREFIX) for p in tmp_path.rglob("*"))


def test_existing_folder_entries_replaced_as_a_whole_others_kept(tmp_path):
    dest = tmp_path / "out"
    (dest / "sub").mkdir(parents=True)
    (dest / "sub" / "stale.png").write_text("old")
    (dest / "x.json").write_text("old")
    (dest / "mine.txt").write_text("keep")
    with output_set(dest, "dir") as work:
        (work / "x.json").write_text("new")
        (work / "sub").mkdir()
        (work / "sub" / "fresh.png").write_text("new")
    assert _tree(dest) == ["mine.txt", "sub", "sub/fresh.png", "x.json"]
    assert (dest / "x.json").read_text() == "new" and (dest / "mine.txt").read_text() == "keep"


def test_failure_leaves_old_outputs_and_no_folders(tmp_path):
    dest = tmp_path / "out"
    dest.mkdir()
    (dest / "x.json").write_text("old")
    with pytest.raises(RuntimeError), output_set(dest, "dir") as work:
        (work / "x.json").write_text("new")
        raise RuntimeError("the second file failed")
    assert _tree(tmp_path) == ["out", "out/x.json"] and (dest / "x.json").read_text() == "old"
    new = tmp_path / "n" / "m"
    with pytest.raises(RuntimeError), output_set(new, "dir") as work:
        (work / "x").write_text("1")
        raise RuntimeError("boom")
    assert not (tmp_path / "n").exists()


def test_nothing_written_makes_no_empty_folder(tmp_path):
    with output_set(tmp_path / "empty", "dir"):
        pass
    assert not (tmp_path / "empty").exists()


def test_file_output(tmp_path):
    dest = tmp_path / "d" / "plan.json"
    with output_set(dest, "file") as tmp:
        assert tmp.name == "plan.json" and tmp.parent != dest.parent
        tmp.write_text("new")
    assert dest.read_text() == "new" and _tree(tmp_path) == ["d", "d/plan.json"]


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_staged_folder_gets_the_umask_permissions(tmp_path, mask):
    old = os.umask(mask)
    try:
        (tmp_path / "plain").mkdir()
        with output_set(tmp_path / "staged", "dir") as work:
            (work / "f").write_text("x")
    finally:
        os.umask(old)
    mode = stat.S_IMODE((tmp_path / "staged").stat().st_mode)
    assert mode == stat.S_IMODE((tmp_path / "plain").stat().st_mode) == 0o777 & ~mask


@pytest.mark.parametrize("make,kind,message", [
    (lambda p: os.mkfifo(p), "dir", "which is a FIFO (named pipe); it is not replaced"),
    (lambda p: os.mkfifo(p), "file", "which is a FIFO (named pipe); it is not replaced"),
    (lambda p: p.write_text("x"), "dir", "expected a directory or a new path"),
    (lambda p: p.mkdir(), "file", "expected a regular file or a new path"),
    (lambda p: os.symlink(p.parent / "nowhere", p), "file", "dangling symbolic link"),
])
def test_wrong_kind_and_special_paths_are_refused(tmp_path, make, kind, message):
    target = tmp_path / "t"
    make(target)
    before = os.lstat(target).st_mode
    with pytest.raises(InputError, match="--out: expected") as exc:
        with output_set(target, kind):
            pytest.fail("the block must not run")
    assert message in str(exc.value)
    assert os.lstat(target).st_mode == before


def test_device_and_paths_below_files(tmp_path):
    with pytest.raises(InputError, match="character device"):
        check_output_path("/dev/null", "file")
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="a parent is a regular file"):
        check_output_path(tmp_path / "f" / "x" / "y", "dir")
    with pytest.raises(InputError, match="expected a path, got ''"):
        check_output_path("", "dir")
    with pytest.raises(InputError, match="at most 255 bytes"):
        check_output_path(tmp_path / ("x" * 300), "file")


def test_unwritable_location_is_refused_before_the_block(tmp_path):
    ran = []
    with pytest.raises(InputError, match="expected a writable location"):
        with output_set("/proc/qsplan-test/out", "dir"):
            ran.append(1)
    assert not ran


def test_special_entry_inside_an_existing_folder_is_not_replaced(tmp_path):
    dest = tmp_path / "out"
    dest.mkdir()
    os.mkfifo(dest / "summary.json")
    with pytest.raises(InputError, match="not replaced"):
        with output_set(dest, "dir") as work:
            (work / "summary.json").write_text("{}")
            (work / "other.txt").write_text("x")
    assert stat.S_ISFIFO(os.lstat(dest / "summary.json").st_mode)
    assert _tree(dest) == ["summary.json"]
