"""Environment failures -- a full disk, a read-only file system, a permission lost mid-run --
are named as such, with the output's own path (never its staging folder), exit 3, and the
previous outputs stay whole."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SYSTEM = ROOT / "scenarios" / "data" / "example_4_1.json"
MUSPACE = ["muspace", str(SYSTEM), "--vary", "1,2", "--n", "30"]


@pytest.fixture(autouse=True)
def _log_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("QSPLAN_LOG_DIR", str(tmp_path / "logs"))


def _old(out: Path) -> dict[str, bytes]:
    out.mkdir()
    (out / "muspace.json").write_bytes(b"old json")
    (out / "muspace.png").write_bytes(b"old png")
    return {p.name: p.read_bytes() for p in out.iterdir()}


def test_disk_full_while_writing_is_an_environment_failure(tmp_path, monkeypatch, capsys):
    from qsplan.cli import main

    out = tmp_path / "out"
    before = _old(out)

    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    assert main(MUSPACE + ["--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "internal fault" not in err and len(err.strip().splitlines()) == 1
    assert (f"qsplan muspace: environment failure: no space left on the device (ENOSPC) at "
            f"'{out / 'muspace.json'}'; not written: '{out}'") in err, err
    assert ".qsplan-staging" not in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_permission_lost_at_the_commit(tmp_path, monkeypatch, capsys):
    from qsplan.cli import main

    out = tmp_path / "out"
    before = _old(out)
    real = os.rename

    def denied(src, dst):
        if ".qsplan-old-" in str(dst):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(src))
        return real(src, dst)

    monkeypatch.setattr(os, "rename", denied)
    assert main(MUSPACE + ["--out", str(out)]) == 3
    err = capsys.readouterr().err
    assert "environment failure: permission denied (EACCES) at" in err, err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def _unshare_mount() -> list[str] | None:
    """``unshare`` with a private mount namespace (as root, or as a user with user
    namespaces); None where that is not available."""
    tool = shutil.which("unshare")
    if tool is None:
        return None
    for cmd in ([tool, "-m"], [tool, "-rm"]):
        res = subprocess.run(cmd + ["sh", "-c", "mount -t tmpfs -o size=16k tmpfs /mnt"],
                             capture_output=True)
        if res.returncode == 0:
            return cmd
    return None


UNSHARE = _unshare_mount()


@pytest.mark.skipif(UNSHARE is None, reason="no private mount namespace here")
def test_tiny_and_read_only_file_systems(tmp_path):
    """A real 32 KiB tmpfs: the PNG does not fit (ENOSPC, exit 3, the old pair whole); the
    same file system read-only: refused before any work (exit 2)."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg",
           "QSPLAN_LOG_DIR": str(tmp_path / "logs")}
    argv = " ".join([sys.executable, "-m", "qsplan.cli", *MUSPACE, "--n", "120", "--out"])
    script = f"""
        set -e
        mount -t tmpfs -o size=32k tmpfs {mnt}
        mkdir {mnt}/out && printf 'old json' > {mnt}/out/muspace.json
        printf 'old png' > {mnt}/out/muspace.png
        set +e
        {argv} {mnt}/out 2> {tmp_path}/full.err; echo $? > {tmp_path}/full.rc
        cat {mnt}/out/muspace.json {mnt}/out/muspace.png > {tmp_path}/full.after
        ls -a {mnt}/out > {tmp_path}/full.ls
        mount -o remount,ro {mnt}
        {argv} {mnt}/out 2> {tmp_path}/ro.err; echo $? > {tmp_path}/ro.rc
    """
    res = subprocess.run(UNSHARE + ["sh", "-c", script], env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    full = (tmp_path / "full.err").read_text()
    assert (tmp_path / "full.rc").read_text().strip() == "3", full
    assert "environment failure: no space left on the device (ENOSPC) at" in full, full
    assert "staging" not in full and "Traceback" not in full
    assert (tmp_path / "full.after").read_text() == "old jsonold png"
    assert (tmp_path / "full.ls").read_text().split() == [".", "..", "muspace.json",
                                                          "muspace.png"]
    ro = (tmp_path / "ro.err").read_text()
    assert (tmp_path / "ro.rc").read_text().strip() == "2", ro
    assert "--out: expected a writable location" in ro and "is read-only" in ro, ro
