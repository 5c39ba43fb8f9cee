"""Output safety: files are replaced atomically, never left half-written, and loaders
never execute content.

* every writer (``planner.files.atomic`` and the savers built on it: ``save_plan``, ``save_system``,
  ``save_figure``) leaves the previous file intact when serialising, writing, syncing or the
  final rename fails, and leaves no temporary file behind;
* a writer killed with SIGKILL at random moments leaves the target either the old or the new
  complete content (a reader in another process never sees a partial file);
* no module of ``planner/``, ``sim/`` or ``scenarios/`` writes files except through
  ``planner.files.atomic``, and none uses ``pickle``/``eval``/``exec``/``yaml`` on loaded content.
"""

from __future__ import annotations

import ast
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import planner.files.atomic as fileio
from planner.errors import QsplanError
from planner.files.atomic import (
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    save_figure,
)
from planner.files.system_file import load_system, save_system

ROOT = Path(__file__).resolve().parents[2]


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def _writers(tmp_path):
    """(name, target, write-new-content callable, check-old-content callable)."""
    system = load_system(ROOT / "scenarios" / "data" / "example_4_1.json")

    def fig():
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        f, ax = plt.subplots(figsize=(1, 1))
        ax.plot([0, 1], [0, 1])
        return f

    return [
        ("text", lambda p: atomic_write_text(p, "new content\n")),
        ("bytes", lambda p: atomic_write_bytes(p, b"\x00new")),
        ("json", lambda p: atomic_write_json(p, {"a": np.arange(3), "b": float("nan")})),
        ("system", lambda p: save_system(system, p)),
        ("figure", lambda p: save_figure(fig(), p)),
    ]


WRITER_NAMES = ["text", "bytes", "json", "system", "figure"]


@pytest.mark.parametrize("name", WRITER_NAMES)
@pytest.mark.parametrize("failing", ["replace", "fsync", "write"])
def test_failed_write_keeps_the_old_file(tmp_path, monkeypatch, name, failing):
    target = tmp_path / ("out.png" if name == "figure" else "out.json")
    target.write_bytes(b"OLD CONTENT")
    write = dict(_writers(tmp_path))[name]

    def boom(*args, **kwargs):
        raise OSError(f"simulated {failing} failure")

    if failing == "replace":
        monkeypatch.setattr(fileio.os, "replace", boom)
    elif failing == "fsync":
        monkeypatch.setattr(fileio.os, "fsync", boom)
    else:
        real_fdopen = os.fdopen

        class HalfWriter:
            def __init__(self, fh):
                self.fh = fh

            def __enter__(self):
                return self

            def __exit__(self, *exc):
                self.fh.close()
                return False

            def write(self, data):
                self.fh.write(data[: len(data) // 2])  # half the bytes reach the disk
                raise OSError("simulated disk full")

        monkeypatch.setattr(fileio.os, "fdopen", lambda fd, mode: HalfWriter(real_fdopen(fd, mode)))
    with pytest.raises(OSError, match=f"simulated {'disk full' if failing == 'write' else failing}"):
        write(target)
    assert target.read_bytes() == b"OLD CONTENT"
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("name", WRITER_NAMES)
def test_successful_write_replaces_and_cleans_up(tmp_path, name):
    target = tmp_path / "sub" / ("out.png" if name == "figure" else "out.json")
    dict(_writers(tmp_path))[name](target)
    assert target.stat().st_size > 0 and target.read_bytes() != b"OLD CONTENT"
    assert _leftovers(target.parent) == []


def test_unserialisable_json_leaves_target_untouched(tmp_path):
    target = tmp_path / "out.json"
    target.write_text('{"ok": true}')
    with pytest.raises(TypeError):
        atomic_write_json(target, {"bad": {1, 2}})
    assert json.loads(target.read_text()) == {"ok": True}
    assert _leftovers(tmp_path) == []


def test_json_writer_encodes_non_finite_numbers(tmp_path):
    target = atomic_write_json(tmp_path / "x.json", {"v": [np.nan, np.inf, -np.inf, 1.0]})
    assert json.loads(target.read_text()) == {"v": [None, "inf", "-inf", 1.0]}


def test_failed_plan_save_keeps_the_old_plan(tmp_path, monkeypatch):
    from test_fuzz_plan import _base_plan

    from planner.plan.plan_file import load_plan, plans_equal, save_plan

    plan = _base_plan()
    path = save_plan(plan, tmp_path / "plan.json")
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("simulated crash before rename")

    monkeypatch.setattr(fileio.os, "replace", boom)
    with pytest.raises(OSError, match="simulated crash"):
        save_plan(plan, path)
    assert path.read_bytes() == before and plans_equal(load_plan(path), plan)
    assert _leftovers(tmp_path) == []


_WRITER_SCRIPT = textwrap.dedent("""
    import sys
    from planner.files.atomic import atomic_write_text
    target, a, b = sys.argv[1], sys.argv[2], sys.argv[3]
    texts = [open(a).read(), open(b).read()]
    print("ready", flush=True)
    k = 0
    while True:
        atomic_write_text(target, texts[k % 2])
        k += 1
""")


@pytest.mark.long
def test_sigkill_never_leaves_a_partial_file(tmp_path):
    """A writer process killed at random moments: the target is always old or new, complete."""
    big = {"waypoints": [{"t": i, "pose": [i * 1e-3, 0.0, 0.0]} for i in range(20_000)]}
    a = json.dumps(big)
    b = json.dumps({**big, "claim": "R1 S-2 B3"})
    (tmp_path / "a.json").write_text(a)
    (tmp_path / "b.json").write_text(b)
    target = tmp_path / "plan.json"
    target.write_text(a)
    rng = np.random.default_rng(0)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    seen = set()
    for _ in range(6):
        proc = subprocess.Popen(
            [sys.executable, "-c", _WRITER_SCRIPT, str(target), str(tmp_path / "a.json"),
             str(tmp_path / "b.json")], env=env, stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        deadline = time.monotonic() + float(rng.uniform(0.05, 0.3))
        while time.monotonic() < deadline:  # a concurrent reader
            text = target.read_text()
            assert text in (a, b)
            seen.add(text == b)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
        assert target.read_text() in (a, b)
    assert seen == {False, True}  # the reader saw both versions: writes really happened


# ---------------------------------------------------------------------------------------------
# Static checks over the library source.
# ---------------------------------------------------------------------------------------------
LIBRARY = [p for d in ("planner", "sim", "scenarios") for p in (ROOT / d).rglob("*.py")]
WRITE_METHODS = {"write_text", "write_bytes", "tofile", "savefig", "save", "savez",
                 "savez_compressed", "savetxt"}
UNSAFE_MODULES = {"pickle", "marshal", "shelve", "yaml", "dill", "cloudpickle"}


def _is_std_stream(node: ast.AST) -> bool:
    return (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
            and node.value.id == "sys" and node.attr in ("stdout", "stderr"))


def direct_writes(source: str) -> list[int]:
    """Lines that write a file without ``planner.files.atomic`` (AST scan)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        f, args = node.func, node.args
        if isinstance(f, ast.Attribute) and f.attr in WRITE_METHODS:
            target = args[0] if args else None
            in_memory = isinstance(target, ast.Name) and "buf" in target.id.lower()
            if f.attr == "save" and not (isinstance(f.value, ast.Name) and f.value.id == "np"):
                in_memory = in_memory or target is None or (isinstance(target, ast.Name) and
                                                            "buf" in target.id.lower())
            if not in_memory:
                lines.append(node.lineno)
        elif isinstance(f, ast.Name) and f.id == "open":
            mode = args[1] if len(args) > 1 else next(
                (k.value for k in node.keywords if k.arg == "mode"), None)
            if isinstance(mode, ast.Constant) and set(str(mode.value)) & set("wax+"):
                lines.append(node.lineno)
        elif isinstance(f, ast.Attribute) and f.attr == "dump" and isinstance(
                f.value, ast.Name) and f.value.id == "json":
            if not (len(args) > 1 and _is_std_stream(args[1])):
                lines.append(node.lineno)
    return sorted(lines)


def unsafe_loads(source: str) -> list[int]:
    """Lines that import a code-executing deserialiser or call eval/exec/__import__."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import) and any(
                a.name.split(".")[0] in UNSAFE_MODULES for a in node.names):
            lines.append(node.lineno)
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] in \
                UNSAFE_MODULES:
            lines.append(node.lineno)
        elif isinstance(node, ast.Call):
            if isinstance(node.func, ast.Name) and node.func.id in ("eval", "exec", "__import__"):
                lines.append(node.lineno)
            if any(k.arg == "allow_pickle" and not (isinstance(k.value, ast.Constant)
                                                    and k.value.value is False)
                   for k in node.keywords):
                lines.append(node.lineno)
    return sorted(lines)


def test_library_writes_only_through_fileio():
    offenders = [f"{p.relative_to(ROOT)}:{no}" for p in LIBRARY if p.name != "fileio.py"
                 for no in direct_writes(p.read_text())]
    assert offenders == [], "write through planner.files.atomic (atomic): " + ", ".join(offenders)


@pytest.mark.parametrize("code,found", [
    ('Path(x).write_text("a")', True),
    ("with open(path, 'w') as fh:\n    pass", True),
    ("with open(path, mode='ab') as fh:\n    pass", True),
    ("open(path).read()", False),
    ("fig.savefig(path, dpi=100)", True),
    ("fig.savefig(buf, format='png')", False),
    ("json.dump(d, sys.stdout, indent=2)", False),
    ("json.dump(d.to_dict(), fh)", True),
    ("np.save(path, a)", True),
    ("images[0].save(buf, format='GIF')", False),
])
def test_static_write_check_itself(code, found):
    assert bool(direct_writes(code)) is found


def test_library_never_executes_loaded_content():
    offenders = [f"{p.relative_to(ROOT)}:{no}" for p in LIBRARY
                 for no in unsafe_loads(p.read_text())]
    assert offenders == [], ", ".join(offenders)


@pytest.mark.parametrize("code,found", [
    ("import pickle", True), ("from yaml import load", True), ("eval(text)", True),
    ("np.load(p, allow_pickle=True)", True), ("np.load(p, allow_pickle=False)", False),
    ("json.loads(text)", False), ("x = 'no pickle, no eval('", False),
])
def test_static_load_check_itself(code, found):
    assert bool(unsafe_loads(code)) is found


def test_system_loader_ignores_code_in_extra_keys(tmp_path, data_dir):
    marker = tmp_path / "executed"
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d["name"] = f"__import__('pathlib').Path({str(marker)!r}).touch()"
    (tmp_path / "s.json").write_text(json.dumps(d))
    s = load_system(tmp_path / "s.json")
    assert s.n_contacts == 3 and not marker.exists()
    d["__reduce__"] = "os.system"  # an unknown key is refused by name, never interpreted
    (tmp_path / "s.json").write_text(json.dumps(d))
    with pytest.raises(QsplanError, match="unknown key '__reduce__'"):
        load_system(tmp_path / "s.json")
    assert not marker.exists()


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_written_files_follow_the_umask(tmp_path, mask):
    """mkstemp creates 0600; atomically written plans, reports and figures must still get
    the permissions a plain write would (a report served to a group must be readable)."""
    old = os.umask(mask)
    try:
        plain = tmp_path / "plain.txt"
        plain.write_text("x")
        atomic = atomic_write_text(tmp_path / "atomic.txt", "x")
    finally:
        os.umask(old)
    assert (atomic.stat().st_mode & 0o777) == (plain.stat().st_mode & 0o777) == 0o666 & ~mask


@pytest.mark.parametrize("kind", ["fifo", "dir", "link_to_fifo"])
def test_writer_refuses_to_replace_what_is_not_a_regular_file(tmp_path, kind):
    """A rename over a FIFO, a folder or a device would replace it (as root even /dev/null)."""
    from planner.errors import InputError

    target = tmp_path / "target"
    if kind == "dir":
        target.mkdir()
    else:
        os.mkfifo(tmp_path / "fifo")
        if kind == "fifo":
            target = tmp_path / "fifo"
        else:
            os.symlink(tmp_path / "fifo", target)
    before = os.lstat(target).st_mode
    with pytest.raises(InputError, match="it is not replaced"):
        atomic_write_text(target, "x")
    assert os.lstat(target).st_mode == before and _leftovers(tmp_path) == []
    with pytest.raises(InputError, match="a special file"):
        atomic_write_text("/dev/null", "x")
