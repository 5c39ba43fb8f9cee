"""Interrupts and closed pipes end a command cleanly (real processes).

SIGINT, SIGTERM and SIGHUP end any command with exit ``128 + n`` and one line naming the
command, the signal and what became of its outputs; previous outputs stay whole, no staging
folder and no child process is left -- also when Python is still importing, when the signal
comes during the commit, and when the main thread is stuck in compiled code (the watchdog).
A closed stdout never changes the exit code and never costs the outputs.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_fuzz_faults import alive

ROOT = Path(__file__).resolve().parents[2]
DRIVER = Path(__file__).parents[1] / "cli_driver.py"
DATA = ROOT / "scenarios" / "data"
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}


def _old_set(out: Path) -> dict[str, bytes]:
    (out / "mu_0").mkdir(parents=True)
    (out / "summary.json").write_bytes(b"old\n")
    (out / "mu_0" / "summary.json").write_bytes(b"old 0\n")
    (out / "notes.txt").write_bytes(b"mine\n")
    return _files(out.parent)


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _children(pid: int) -> list[int]:
    kids = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                stat = Path(f"/proc/{name}/stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(name))
    return kids


def _reap(pids: list[int]) -> None:
    """Kill what a failed test left running (the test's own children's children)."""
    for pid in alive(pids):
        os.kill(pid, signal.SIGKILL)


def _driver(script: str, out: Path, sig: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(DRIVER), script, str(out), sig], env=ENV,
                          cwd=out.parent, capture_output=True, text=True, timeout=90, **kw)


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_signal_inside_an_output_set(tmp_path, sig):
    out = tmp_path / "out"
    before = _old_set(out)
    res = _driver("signal_in_set", out, sig)
    signum = getattr(signal, sig)
    assert res.returncode == 128 + signum, res.stderr
    line = res.stderr.strip()
    assert len(line.splitlines()) == 1 and "Traceback" not in line
    assert line.startswith(f"qsplan modes: interrupted by {sig}")
    assert f"not written: '{out}' (previous contents left as they were)" in line
    assert _files(tmp_path) == before  # previous outputs whole, no staging folder
    assert sorted(p.name for p in out.iterdir()) == ["mu_0", "notes.txt", "summary.json"]


def test_signal_during_the_commit_waits_for_it(tmp_path):
    out = tmp_path / "out"
    _old_set(out)
    res = _driver("signal_in_commit", out, "SIGTERM")
    assert res.returncode == 143, res.stderr
    assert f"outputs written: '{out}'" in res.stderr
    assert (out / "summary.json").read_bytes() == b"new\n"
    assert (out / "mu_0" / "summary.json").read_bytes() == b"new 0\n"
    assert sorted(p.name for p in out.iterdir()) == ["mu_0", "notes.txt", "summary.json"]


def test_watchdog_ends_a_process_stuck_in_compiled_code(tmp_path):
    """The signal arrives while LAPACK runs for a minute: Python's handler cannot run, the
    watchdog deletes the staging folder and ends the process (a timeout here means it did
    not)."""
    out = tmp_path / "out"
    before = _old_set(out)
    res = _driver("stuck_in_c", out, "SIGINT")
    assert res.returncode == 130, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and "interrupted by SIGINT" in res.stderr
    assert _files(tmp_path) == before


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_pool_workers_are_killed(tmp_path, sig):
    out = tmp_path / "out"
    before = _old_set(out)
    proc = subprocess.Popen([sys.executable, str(DRIVER), "pool", str(out), sig], env=ENV,
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    assert proc.stdout.readline().strip() == "pool started"
    deadline = time.monotonic() + 30
    while len(_children(proc.pid)) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    kids = _children(proc.pid)
    try:
        assert len(kids) >= 2
        proc.send_signal(getattr(signal, sig))
        _, err = proc.communicate(timeout=60)  # 8 tasks of 30 s queued: no waiting for them
        assert proc.returncode == 128 + getattr(signal, sig), err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        time.sleep(0.2)
        assert alive(kids) == []
        assert _files(tmp_path) == before
    finally:
        _reap(kids + [proc.pid])


def test_sweep_workers_end_with_the_command(tmp_path):
    """``qsplan sweep scenes --workers 2``: SIGTERM to the command (not to its process group)
    ends it and both workers; its queued tasks would take about a minute."""
    out = tmp_path / "s.json"
    out.write_bytes(b"old\n")
    proc = subprocess.Popen([sys.executable, "-m", "qsplan.cli", "sweep", "scenes",
                             "--contacts", "14", "--count", "300", "--workers", "2",
                             "--out", str(out)], env=ENV, cwd=tmp_path,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(_children(proc.pid)) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    kids = _children(proc.pid)
    try:
        assert len(kids) >= 2 and proc.poll() is None
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 143, err
        assert err.strip().splitlines() == [err.strip()] and "interrupted by SIGTERM" in err
        time.sleep(0.2)
        assert alive(kids) == []
        assert out.read_bytes() == b"old\n" and sorted(p.name for p in tmp_path.iterdir()) == [
            "s.json"]
    finally:
        _reap(kids + [proc.pid])


def test_signal_while_python_exits_keeps_the_result(tmp_path):
    """The command finished (outputs written, exit 0) and Python collects its objects: a
    signal then is ignored, not the end of the process without a word (exit by the signal)."""
    out = tmp_path / "out"
    _old_set(out)
    proc = subprocess.Popen([sys.executable, str(DRIVER), "slow_exit", str(out), "SIGINT"],
                            env=ENV, cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "done"
    time.sleep(1.0)  # main has returned; the finaliser runs for 3 s
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "Traceback" not in err and (out / "summary.json").read_bytes() == b"new\n"


def test_ctrl_c_while_python_imports_is_one_line(tmp_path):
    """The signal arrives while the command line still imports numpy and the commands (before
    any command runs): one line, exit 130, never a traceback."""
    proc = subprocess.Popen([sys.executable, "-m", "qsplan.cli", "modes",
                             str(DATA / "example_4_1.json")], env=ENV, cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:  # numpy loaded: Python runs qsplan's imports now
        try:
            if "_multiarray_umath" in Path(f"/proc/{proc.pid}/maps").read_text():
                break
        except OSError:
            pass
        time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "interrupted by SIGINT (Ctrl-C)" in err


@pytest.mark.parametrize("unbuffered", ["", "1"])
def test_closed_stdout_keeps_the_result_and_the_outputs(tmp_path, unbuffered):
    """A reader that is gone before the command prints (``| true``): the command's exit code
    (1: a failed check) and its outputs, whether the write fails inside the command
    (unbuffered) or at exit."""
    out = tmp_path / "out"
    _old_set(out)
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        res = subprocess.run([sys.executable, str(DRIVER), "print_in_set", str(out)],
                             env={**ENV, "PYTHONUNBUFFERED": unbuffered}, cwd=tmp_path,
                             stdout=write_end, stderr=subprocess.PIPE, text=True, timeout=90)
    finally:
        os.close(write_end)
    assert res.returncode == 1, res.stderr
    assert res.stderr == ""
    assert (out / "mu_0.1" / "summary.json").read_bytes() == b"new 0.1\n"
    assert (out / "notes.txt").read_bytes() == b"mine\n"


def test_closed_stdout_of_a_real_simulation(tmp_path):
    """``qsplan simulate ... --judge-mu 1,1,1 | true``: the negative control disagrees (exit 1)
    and its summary is written."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        res = subprocess.run([sys.executable, "-m", "qsplan.cli", "simulate",
                              str(DATA / "example_4_1.json"), "--judge-mu", "1,1,1", "--out",
                              "o", "--no-render"], env={**ENV, "PYTHONUNBUFFERED": "1"},
                             cwd=tmp_path, stdout=write_end, stderr=subprocess.PIPE,
                             text=True, timeout=300)
    finally:
        os.close(write_end)
    assert res.returncode == 1, res.stderr
    assert (tmp_path / "o" / "summary.json").is_file()


def test_a_signal_while_the_outputs_module_is_imported(monkeypatch):
    """A signal can arrive while ``planner.files.outputs`` is still being imported (the module
    is in ``sys.modules`` without its functions yet): the status line says no outputs were
    written instead of raising AttributeError (the fuzz campaign's case: a SIGTERM 0.74 s
    into ``qsplan plan``)."""
    import types

    from qsplan import interrupts

    monkeypatch.setitem(sys.modules, "planner.files.outputs",
                        types.ModuleType("planner.files.outputs"))
    assert interrupts.outputs_status() == "no outputs written"
