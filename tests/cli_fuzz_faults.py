"""Process-level faults of the command-line fuzz campaign: real signals at random times, closed
pipes, concurrent writers, tiny, read-only and revoked file systems.

Each fault runs real ``python -m qsplan.cli`` processes on a :class:`Job` (a command with its
outputs) in a folder of its own that holds an old output set (old entries, a file of the
user's, a FIFO in a folder the command does not write).  The contract checked on every run
(:func:`check_run`): no traceback, the exit code the fault allows (the command's own result,
``128 + n`` after signal ``n``, 2 for an unusable output, 3 with "environment failure" for a
full or revoked file system), one stderr line for an interrupt, the process gone within
:data:`EXIT_S` seconds of a signal with no child left, every output set either the old one or a
complete new one (never a mix), no staging folder left (unless the message names it: a file
system that refuses deletions), special files never replaced or deleted.  Used by
``tests/qsplan/test_fuzz_faults.py`` (a seeded handful) and ``benchmarks/fuzz_cli.py --faults``.
"""

from __future__ import annotations

import hashlib
import os
import random
import shutil
import signal
import stat
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from cli_fuzz_inputs import DATA, OLD, ROOT

EXIT_S = 1.0
"""Seconds a command may take to end after a signal."""
T_MIN = 0.15
"""Earliest signal time [s]: before it the Python interpreter itself starts (site imports), where
no code of the project runs yet (docs/robustness.md, "Interrupts")."""
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
EX41 = str(DATA / "example_4_1.json")


@dataclass(frozen=True)
class Job:
    """A command, the outputs it writes (relative to its folder: path, "file" or "dir") and the
    entries a complete set of each folder output has."""

    name: str
    argv: tuple[str, ...]
    outputs: tuple[tuple[str, str], ...] = ()
    entries: dict[str, tuple[str, ...]] = field(default_factory=dict)


def jobs(plan_file: Path, run_dir: Path) -> dict[str, Job]:
    from qsplan.commands.muspace import OUTPUTS
    from qsplan.commands.plan import BOUNDS_FIGURES

    return {j.name: j for j in (
        Job("modes", ("modes", str(DATA / "example_4_3.json"), "--search")),
        Job("muspace", ("muspace", EX41, "--vary", "1,2", "--n", "60", "--out", "out"),
            (("out", "dir"),), {"out": OUTPUTS}),
        Job("plan", ("plan", "two_finger_hand", "--mu", "0:0.2", "--waypoints", "6", "--out",
                     "plan.json", "--figures", "figs"),
            (("plan.json", "file"), ("figs", "dir")), {"figs": BOUNDS_FIGURES}),
        Job("sweep scenes", ("sweep", "scenes", "--contacts", "9", "--count", "30",
                             "--workers", "2", "--out", "s.json"), (("s.json", "file"),)),
        Job("sweep mu", ("sweep", "mu", EX41, "--grid", "14", "--workers", "2", "--out",
                         "m.json"), (("m.json", "file"),)),
        Job("report", ("report", str(run_dir), "--out", "r.html"), (("r.html", "file"),)),
        Job("simulate", ("simulate", EX41, "--judge-mu", "1,1,1", "--no-render", "--out",
                         "sim"), (("sim", "dir"),), {"sim": ("summary.json",)}),
        Job("scenarios", ("scenarios", "run", "ex41_3s", "--no-render", "--out", "scn"),
            (("scn", "dir"),), {"scn": ("summary.json",)}),
        Job("validate", ("validate", str(plan_file), "--mu", "0.1", "--no-render", "--out",
                         "val"), (("val", "dir"),), {"val": ("summary.json",)}),
    )}


def env(log_dir: Path) -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg",
            "QSPLAN_LOG_DIR": str(log_dir), "PYTHONUNBUFFERED": ""}


def command(job: Job, extra: tuple[str, ...] = ()) -> list[str]:
    return [sys.executable, "-m", "qsplan.cli", *job.argv, *extra]


def prepare(job: Job, folder: Path) -> None:
    """An old output set in ``folder``: old entries, a file of the user's and a FIFO in a
    folder the command does not write."""
    folder.mkdir(parents=True, exist_ok=True)
    for rel, kind in job.outputs:
        p = folder / rel
        if kind == "file":
            p.write_bytes(OLD)
        else:
            p.mkdir()
            for name in job.entries.get(rel, ()):
                (p / name).write_bytes(OLD)
            (p / "notes.txt").write_bytes(b"mine\n")
            (p / "mine").mkdir()
            os.mkfifo(p / "mine" / "pipe")


def snapshot(root: Path) -> dict[str, object]:
    out: dict[str, object] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = os.lstat(p)
            out[str(p.relative_to(root))] = (hashlib.sha256(p.read_bytes()).hexdigest()
                                             if stat.S_ISREG(st.st_mode)
                                             else stat.S_IFMT(st.st_mode))
    return out


OLD_HASH = hashlib.sha256(OLD).hexdigest()


def output_state(job: Job, snap: dict[str, object]) -> dict[str, str]:
    """Per output: "old" (as prepared), "new" (a complete new set), or what is wrong."""
    state = {}
    for rel, kind in job.outputs:
        names = [rel] if kind == "file" else [f"{rel}/{n}" for n in job.entries.get(rel, ())]
        values = [snap.get(n) for n in names]
        if all(v == OLD_HASH for v in values):
            state[rel] = "old"
        elif all(isinstance(v, str) and v != OLD_HASH for v in values):
            state[rel] = "new"
        else:
            state[rel] = "partial: " + ", ".join(
                f"{n}={'old' if v == OLD_HASH else 'missing' if v is None else 'new'}"
                for n, v in zip(names, values))
        if kind == "dir" and snap.get(f"{rel}/notes.txt") != hashlib.sha256(
                b"mine\n").hexdigest():
            state[rel] = "the user's file in it changed"
    return state


@dataclass
class Run:
    """One faulted run and what its checks found."""

    fault: str
    job: str
    detail: str
    code: int
    stderr: str
    exit_s: float | None = None
    problems: list[str] = field(default_factory=list)


def check_run(run: Run, job: Job, before: dict[str, object], after: dict[str, object],
              allowed: set[int], kids_left: list[int] = ()) -> Run:
    """The campaign's contract on one run (module docstring)."""
    err = run.stderr
    p = run.problems
    if "Traceback" in err or "Exception ignored" in err:
        p.append("traceback")
    if "internal fault" in err:
        p.append("internal fault")
    if run.code not in allowed:
        p.append(f"exit {run.code}, expected one of {sorted(allowed)}")
    if run.code == 3 and "environment failure" not in err and "simulator" not in err:
        p.append("exit 3 without 'environment failure'")
    if run.code > 128 and len(err.strip().splitlines()) != 1:
        p.append("interrupt message not one line")
    if run.exit_s is not None and run.exit_s > EXIT_S:
        p.append(f"ended {run.exit_s:.2f} s after the signal")
    if kids_left:
        p.append(f"child processes left: {kids_left}")
    refused = "refused to delete the staging folder" in err
    staging = [k for k in after if ".qsplan-staging-" in k or ".qsplan-old-" in k]
    if staging and not refused:
        p.append(f"staging left: {staging[:2]}")
    for key, kind in before.items():
        if isinstance(kind, int) and not stat.S_ISDIR(kind) and after.get(key) != kind:
            p.append(f"special file {key} replaced or deleted")
    states = output_state(job, after)
    bad = {k: v for k, v in states.items() if v not in ("old", "new")}
    if bad:
        p.append(f"partial output set: {bad}")
    elif len(set(states.values())) > 1:
        p.append(f"outputs of one command half written: {states}")
    elif run.code in (0, 1) and "old" in states.values() and job.outputs:
        p.append("finished but outputs not written")
    elif run.code not in (0, 1) and "new" in states.values() and "outputs written" not in err:
        p.append("outputs changed by a run that did not finish")
    return run


def descendants(pid: int) -> list[int]:
    parent_of = {}
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                text = Path(f"/proc/{name}/stat").read_text()
            except OSError:
                continue
            parent_of[int(name)] = int(text.rsplit(")", 1)[1].split()[1])
    found, frontier = [], [pid]
    while frontier:
        q = frontier.pop()
        kids = [c for c, pp in parent_of.items() if pp == q]
        found += kids
        frontier += kids
    return found


def alive(pids: list[int]) -> list[int]:
    out = []
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            out.append(pid)
    return out


@dataclass
class Reference:
    code: int
    seconds: float


def reference(job: Job, folder: Path, log_dir: Path) -> Reference:
    """The job run once without a fault (its exit code and duration)."""
    prepare(job, folder)
    t0 = time.monotonic()
    res = subprocess.run(command(job), cwd=folder, env=env(log_dir), capture_output=True,
                         text=True, timeout=900)
    assert res.returncode in (0, 1), (job.argv, res.stderr[-2000:])
    return Reference(res.returncode, time.monotonic() - t0)


def signal_fault(job: Job, ref: Reference, folder: Path, log_dir: Path,
                 rng: random.Random) -> Run:
    """A real signal at a random time of the run."""
    prepare(job, folder)
    before = snapshot(folder)
    sig = rng.choice(SIGNALS)
    at = rng.uniform(T_MIN, max(T_MIN, 1.1 * ref.seconds))
    proc = subprocess.Popen(command(job), cwd=folder, env=env(log_dir), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    kids: list[int] = []
    exit_s = None
    sent = False
    try:
        while time.monotonic() - t0 < at and proc.poll() is None:
            time.sleep(0.01)
        if proc.poll() is None:
            sent = True
            kids = descendants(proc.pid)
            proc.send_signal(sig)
            t_sig = time.monotonic()
            _, err = proc.communicate(timeout=120)
            exit_s = time.monotonic() - t_sig
            allowed = {128 + sig, ref.code}  # the command may finish as the signal comes
        else:
            err = proc.stderr.read() if proc.stderr else ""
            allowed = {ref.code}
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    time.sleep(0.2)
    left = alive(kids)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    run = Run("signal", job.name, f"{signal.Signals(sig).name} at {at:.2f} s", proc.returncode,
              err, exit_s if sent else None)
    if not sent:
        run.detail += " (finished first)"
    elif proc.returncode != 128 + sig:
        run.detail += " (came as the command finished)"
    return check_run(run, job, before, snapshot(folder), allowed, left)


def pipe_fault(job: Job, ref: Reference, folder: Path, log_dir: Path,
               rng: random.Random) -> Run:
    """stdout closed before the command writes, after its first line (``| head -1``), or
    unbuffered (the write fails inside the command)."""
    prepare(job, folder)
    before = snapshot(folder)
    how = rng.choice(["closed", "closed unbuffered", "head -1"])
    e = env(log_dir)
    if how == "closed unbuffered":
        e["PYTHONUNBUFFERED"] = "1"
    read_end, write_end = os.pipe()
    if how.startswith("closed"):
        os.close(read_end)
    proc = subprocess.Popen(command(job), cwd=folder, env=e, stdout=write_end,
                            stderr=subprocess.PIPE, text=True)
    os.close(write_end)
    if how == "head -1":
        with os.fdopen(read_end, "rb") as reader:
            reader.readline()
    _, err = proc.communicate(timeout=900)
    run = Run("closed stdout", job.name, how, proc.returncode, err)
    return check_run(run, job, before, snapshot(folder), {ref.code})


def concurrent_fault(job: Job, variants: list[tuple[str, ...]], folder: Path,
                     log_dir: Path) -> Run:
    """Several processes write the same outputs at once (one variant of the arguments each):
    all succeed and the final set is one variant's whole set."""
    refs = {}
    for k, extra in enumerate(variants):
        alone = folder.parent / f"{folder.name}-alone{k}"
        prepare(job, alone)
        subprocess.run(command(job, extra), cwd=alone, env=env(log_dir), capture_output=True,
                       timeout=900)
        refs[k] = {key: v for key, v in snapshot(alone).items() if isinstance(v, str)}
        shutil.rmtree(alone)
    prepare(job, folder)
    before = snapshot(folder)
    procs = [subprocess.Popen(command(job, extra), cwd=folder, env=env(log_dir),
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for extra in variants]
    errs = [p.communicate(timeout=900)[1] for p in procs]
    run = Run("concurrent writers", job.name, f"{len(variants)} writers",
              max(p.returncode for p in procs), "".join(errs))
    check_run(run, job, before, snapshot(folder), {0})
    after = {k: v for k, v in snapshot(folder).items() if isinstance(v, str)
             and any(k == rel or k.startswith(rel + "/") for rel, _ in job.outputs)
             and "/mine/" not in k and not k.endswith("notes.txt")}
    owners = [k for k, ref in refs.items() if all(ref.get(key) == v for key, v in after.items())]
    if not owners:
        run.problems.append("the final outputs mix the writers' sets")
    return run


_UNSHARE: list[list[str] | None] = []


def unshare_prefix() -> list[str] | None:
    """``unshare`` with a private mount namespace (as root, or with user namespaces); None
    where mounting a tmpfs is not possible here."""
    if not _UNSHARE:
        tool = shutil.which("unshare")
        found = None
        for cmd in ([tool, "-m"], [tool, "-rm"]) if tool else ():
            res = subprocess.run(cmd + ["sh", "-c", "mount -t tmpfs -o size=16k tmpfs /mnt"],
                                 capture_output=True)
            if res.returncode == 0:
                found = cmd
                break
        _UNSHARE.append(found)
    return _UNSHARE[0]


FS_FAULTS = ("tiny", "read-only", "read-only mid-run", "permission lost mid-run")
#: root without the capabilities that ignore file permissions: chmod then takes effect
NO_DAC = ["setpriv", "--bounding-set", "-dac_override,-dac_read_search,-fowner", "--"]


def fs_fault(job: Job, ref: Reference, folder: Path, log_dir: Path, rng: random.Random,
             kind: str) -> Run:
    """The job with its outputs on a file system of its own (a tmpfs in a private mount
    namespace): ``tiny`` (16 KiB to 1 MiB), ``read-only`` from the start, made read-only at a
    random time, or with the permission to write taken away at a random time."""
    prefix = unshare_prefix()
    assert prefix is not None
    seed, mnt, after = folder / "seed", folder / "mnt", folder / "after"
    prepare(job, seed)
    mnt.mkdir()
    before = snapshot(seed)
    size = rng.choice(["16k", "48k", "160k", "1m"]) if kind == "tiny" else "64m"
    at = rng.uniform(T_MIN, max(T_MIN, ref.seconds))
    launcher = " ".join(NO_DAC) + " " if kind.startswith("permission") and shutil.which(
        "setpriv") else ""
    argv = " ".join(f"'{a}'" for a in command(job))
    fault = {"read-only mid-run": f"sleep {at:.3f}; mount -o remount,ro {mnt}",
             "permission lost mid-run": f"sleep {at:.3f}; find {mnt} -type d -exec chmod a-w "
                                        "{} +"}.get(kind, "")
    script = f"""
        set -e
        mount -t tmpfs -o size={size} tmpfs {mnt}
        cp -a {seed}/. {mnt}/
        {"mount -o remount,ro " + str(mnt) if kind == "read-only" else ""}
        cd {mnt}
        set +e
        {launcher}{argv} > /dev/null 2> {folder}/err &
        pid=$!
        {fault}
        wait $pid
        echo $? > {folder}/rc
        mkdir {after}
        cp -a {mnt}/. {after}/
    """
    res = subprocess.run(prefix + ["sh", "-c", script], env=env(log_dir), capture_output=True,
                         text=True, timeout=900)
    assert res.returncode == 0 and (folder / "rc").exists(), res.stderr
    err = (folder / "err").read_text()
    code = int((folder / "rc").read_text())
    allowed = {ref.code, 3}
    if kind != "read-only" and job.outputs:
        allowed.add(2)  # no room for the staging folder, or the fault came before the check
    if kind == "read-only":
        allowed = {2} if job.outputs else {ref.code}
    detail = f"{size}" if kind == "tiny" else f"at {at:.2f} s" if "mid-run" in kind else ""
    run = Run(f"file system: {kind}", job.name, detail, code, err)
    check_run(run, job, before, snapshot(after), allowed)
    if code == 2 and not any(w in err for w in ("No space left", "read-only",
                                                "no permission to write")):
        run.problems.append("exit 2 without naming the file system's state")
    return run
