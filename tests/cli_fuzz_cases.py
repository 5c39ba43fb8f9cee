"""Cases per subcommand and the contract checks of the command-line fuzz campaign.

A case is an argv for ``qsplan.cli.main`` plus what it must do: ``bad=True`` inputs must exit
2; every input must end without a traceback and without a partial output set
(:func:`run_case`).  Used by ``tests/qsplan/test_fuzz_cli.py`` and ``benchmarks/fuzz_cli.py``.
"""

from __future__ import annotations

import contextlib
import io
import os
import random
import stat
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cli_fuzz_inputs import OLD, SECRET, Fixtures, output_path, write_input

COMMANDS = ("modes", "muspace", "plan", "validate", "simulate", "demo", "scenarios", "sweep",
            "report")


# ---------------------------------------------------------------------------------------------
# Cases per command.
# ---------------------------------------------------------------------------------------------
@dataclass
class Case:
    command: str
    argv: list[str]
    bad: bool | None  # True: must exit 2; False: must not exit 2; None: either
    outputs: tuple[tuple[str, str], ...] = ()  # (path, kind)
    complete: tuple[str, ...] = ()  # files that a successful run must have written


def _opt(rng: random.Random, argv: list[str], name: str, bad: list[str], ok: list[str],
         p_bad: float) -> bool | None:
    """Append ``name VALUE``; returns True when the value is surely bad."""
    if rng.random() < p_bad:
        argv += [name, rng.choice(bad)] if not name.startswith("=") else [rng.choice(bad)]
        return True
    if ok:
        argv += [name, rng.choice(ok)]
    return False


RANGE_BAD = ["nan:1", "1:0", "1e308:1e308", "0,1,2", "0:inf", "-1:1", "::", "x", "", "0:1e999",
             "1e7:2e7"]
NUM_BAD = ["nan", "inf", "-inf", "1e999", "abc", "", "-1", "1e308", "0x1p3", "1,,2", "0.1;0.2"]


def _combine(*flags: bool | None) -> bool | None:
    if any(f is True for f in flags):
        return True
    return None if any(f is None for f in flags) else False


def case_modes(fx: Fixtures, rng: random.Random, p: float) -> Case:
    sys_path, b0 = write_input(fx, rng, fx.system) if rng.random() < p else (str(fx.system),
                                                                               False)
    argv = ["modes", sys_path]
    b1 = _opt(rng, argv, "--mu", ["nan", "-1", "a,b", "1e999", "0.1,nan,0.2", ",", "1e308",
                                  "0.1,0.2", "inf"], ["0.1", "0.2,0.3,0.1", "0"], p / 2)
    b2: bool | None = False
    if rng.random() < 0.3:
        argv.append("--search")
        b2 = _opt(rng, argv, "--workers", ["0", "-1", "2000"], ["1"], p / 2)
    elif rng.random() < 0.1:
        argv += ["--workers", "2"]
        b2 = True
    b3 = _opt(rng, argv, "--memory-gib", ["nan", "-1", "0", "inf", "x"], [], p / 4)
    for flag in ("--json", "--no-indeterminate", "-q"):
        if rng.random() < 0.3:
            argv.append(flag)
    if rng.random() < p / 6:
        argv.append(rng.choice(["--bogus", "--mu"]))
        b3 = True
    return Case("modes", argv, _combine(b0, b1, b2, b3))


def case_muspace(fx: Fixtures, rng: random.Random, p: float) -> Case:
    sys_path, b0 = write_input(fx, rng, fx.system) if rng.random() < p / 2 else (
        str(fx.system), False)
    out, b1 = output_path(fx, rng, "dir", ("muspace.json", "muspace.png")) \
        if rng.random() < p else (str(fx.fresh("out")), False)
    argv = ["muspace", sys_path, "--out", out]
    b2 = _opt(rng, argv, "--vary", ["nan,1", "1", "1,1", "0,1", "1,2,3,4", "a", "", "1,99",
                                    "-1,2"], ["1,2", "2,3"], p / 3)
    b3 = _opt(rng, argv, "--range", RANGE_BAD, ["0:1", "0.1:0.5", "0:0.3"], p / 3)
    b4 = _opt(rng, argv, "--n", ["0", "-1", "x", "nan", "100000", "1e3"], ["2", "3"], p / 3)
    b5 = _opt(rng, argv, "--panels", ["0", "-1", "x", "65", "100000"], ["1", "2"], p / 6)
    b6: bool | None = False
    if rng.random() < 0.3:
        b6 = None if _opt(rng, argv, "--slice", ["3", "3=", "3=nan", "x=1", "3=-1", "3=inf"],
                          ["3=0,0.2", "1=0.1"], p / 2) is False else True
    if "--n" not in argv:
        argv += ["--n", "3"]
    return Case("muspace", argv, _combine(b0, b1, b2, b3, b4, b5, b6), ((out, "dir"),),
                ("muspace.json", "muspace.png"))


def case_plan(fx: Fixtures, rng: random.Random, p: float) -> Case:
    if rng.random() < p / 2:
        hand, b0 = write_input(fx, rng, fx.hand) if rng.random() < 0.8 else (
            rng.choice(["no_such_hand", "", "../../etc/passwd"]), True)
    else:
        hand, b0 = str(fx.hand), False
    out, b1 = output_path(fx, rng, "file") if rng.random() < p / 2 else (
        str(fx.fresh("plan").with_suffix(".json")), False)
    argv = ["plan", hand, "--out", out]
    outputs = [(out, "file")]
    b2: bool | None = False
    if rng.random() < 0.3:
        figs, b2 = output_path(fx, rng, "dir", ("fig10_bounds_mu_lo.png",))
        argv += ["--figures", figs]
        outputs.append((figs, "dir"))
    b3 = _opt(rng, argv, "--mu", ["nan", "0:nan", "1:0", "0:1e308", "-1:1", "x", "0:0.2,", ":",
                                  "0:inf"], ["0:0.2", "0.1", "0:0.1"], p / 3)
    b4 = _opt(rng, argv, "--waypoints", ["0", "1", "-5", "x", "10001", "1e3"], ["2", "3"], p / 3)
    b5 = _opt(rng, argv, "--model", ["foo", ""], ["common"], p / 6)
    b6 = _opt(rng, argv, "--policy", ["foo", "rival:"], ["midband", "constant"], p / 6)
    b7 = _opt(rng, argv, "--control", ["x", "1.5", ""], ["auto", "0", "1"], p / 6)
    if "--waypoints" not in argv:
        argv += ["--waypoints", "3"]
    return Case("plan", argv, _combine(b0, b1, b2, b3, b4, b5, b6, b7), tuple(outputs))


def _likely_bad(make: Callable[[], tuple[str, bool | None]]) -> tuple[str, bool | None]:
    """Up to 20 draws of ``make()`` until one is surely bad; the last draw otherwise."""
    for _ in range(20):
        value, bad = make()
        if bad:
            break
    return value, bad


def case_validate(fx: Fixtures, rng: random.Random, p: float) -> Case:
    """Always with one surely bad part (a good run simulates for many seconds)."""
    parts = rng.sample(["plan", "engine", "mu", "out"], rng.randint(1, 2))
    plan, out, argv_tail = str(fx.plan), str(fx.fresh("val")), ["--no-render"]
    bad: list[bool | None] = []
    if "plan" in parts:
        plan, b = _likely_bad(lambda: write_input(fx, rng, fx.plan))
        bad.append(b)
    if "engine" in parts:
        argv_tail += ["--engine", rng.choice(["bullet", "", "PYMUNK", "nan"])]
        bad.append(True)
    if "mu" in parts:
        argv_tail += ["--mu", rng.choice(NUM_BAD + [",".join(["0.1"] * 200)])]
        bad.append(True)
    if "out" in parts:
        out, b = _likely_bad(lambda: output_path(fx, rng, "dir", ("summary.json",)))
        bad.append(b)
    if not any(b is True for b in bad):  # make sure: a bad engine
        argv_tail += ["--engine", "bullet"]
        bad.append(True)
    return Case("validate", ["validate", plan, "--out", out] + argv_tail, True, ((out, "dir"),))


def case_simulate(fx: Fixtures, rng: random.Random, p: float) -> Case:
    """Always with one surely bad part (a good run simulates for a second or more)."""
    parts = rng.sample(["system", "engine", "mu", "judge", "duration", "out"], rng.randint(1, 3))
    system, out, argv_tail = str(fx.system), str(fx.fresh("sim")), ["--no-render"]
    bad: list[bool | None] = []
    if "system" in parts:
        system, b = _likely_bad(lambda: write_input(fx, rng, fx.system))
        bad.append(b)
    if "engine" in parts:
        argv_tail += ["--engine", rng.choice(["bullet", "", "PYMUNK", "nan"])]
        bad.append(True)
    if "mu" in parts:
        argv_tail += [rng.choice(["--mu", "--mu-kinetic"]),
                      rng.choice(NUM_BAD + [",".join(["0.1"] * 200)])]
        bad.append(True)
    if "judge" in parts:
        argv_tail += ["--judge-mu", rng.choice(NUM_BAD)]
        bad.append(True)
    if "duration" in parts:
        argv_tail += [rng.choice(["--duration", "--speed"]),
                      rng.choice(["0", "-1", "nan", "inf", "1e308", "x", ""])]
        bad.append(True)
    if "out" in parts:
        out, b = _likely_bad(lambda: output_path(fx, rng, "dir", ("summary.json",)))
        bad.append(b)
    if not any(b is True for b in bad):  # make sure: a bad engine
        argv_tail += ["--engine", "bullet"]
        bad.append(True)
    return Case("simulate", ["simulate", system, "--out", out] + argv_tail, True,
                ((out, "dir"),))


def case_demo(fx: Fixtures, rng: random.Random, p: float) -> Case:
    """Always with one surely bad part (a good demo runs for minutes)."""
    out, b_out = output_path(fx, rng, "dir", ("checks.json", "REPORT.md"))
    argv = ["demo", "--out", out, "--no-render", "--quick"]
    what = rng.choice(["engines", "jobs", "scenario", "out"])
    if what == "engines":
        argv += ["--engines", rng.choice(["bullet", "", ",", "pymunk,bullet", "nan"])]
    elif what == "jobs":
        argv += ["--jobs", rng.choice(["0", "-1", "x", "65", "1e3"])]
    elif what == "scenario":
        hand, b = _likely_bad(lambda: write_input(fx, rng, fx.hand))
        argv += ["--scenario", rng.choice([hand, "no_such_hand"])]
    elif not b_out:
        argv += ["--engines", "bullet"]
    return Case("demo", argv, True, ((out, "dir"),))


def case_scenarios(fx: Fixtures, rng: random.Random, p: float) -> Case:
    if rng.random() < 0.15:
        return Case("scenarios", ["scenarios", "list"], False)
    out, b_out = output_path(fx, rng, "dir", ("summary.json",))
    what = rng.choice(["name", "engine", "out", "action"])
    if what == "action":
        return Case("scenarios", ["scenarios", rng.choice(["", "bla", "run"])], True)
    name = rng.choice(["nosuch", "", "../x", "ex41_3s "]) if what == "name" or not b_out \
        else rng.choice(["ex41_3s", "ruler_single_mu"])
    engine = rng.choice(["bullet", "", "mujoco2"]) if what == "engine" else "pymunk"
    return Case("scenarios", ["scenarios", "run", name, "--engine", engine, "--out", out,
                              "--no-render"], True, ((out, "dir"),))


def case_sweep(fx: Fixtures, rng: random.Random, p: float) -> Case:
    out, b0 = output_path(fx, rng, "file") if rng.random() < p / 2 else (
        str(fx.fresh("sweep").with_suffix(".json")), False)
    if rng.random() < 0.6:
        sys_path, b1 = write_input(fx, rng, fx.system) if rng.random() < p / 2 else (
            str(fx.system), False)
        argv = ["sweep", "mu", sys_path, "--out", out, "--workers", "1", "--no-progress"]
        b2 = _opt(rng, argv, "--grid", ["0", "-1", "x", "1000", "1e2"], ["1", "2"], p / 3)
        b3 = _opt(rng, argv, "--mu-range", RANGE_BAD, ["0:1", "0,1", "0.1:0.3"], p / 3)
        if rng.random() < 0.05:
            argv.remove(sys_path)
            b3 = True
        if "--grid" not in argv:
            argv += ["--grid", "2"]
    else:
        argv = ["sweep", "scenes", "--out", out, "--no-progress"]
        b1 = _opt(rng, argv, "--contacts", ["2", "41", "x", "-1", "1e9"], ["3", "4"], p / 3)
        b2 = _opt(rng, argv, "--count", ["0", "-1", "x", "10000000000"], ["1", "2"], p / 3)
        b3 = _opt(rng, argv, "--workers", ["0", "-5", "2000"], ["1"], p / 4)
        if "--workers" not in argv:
            argv += ["--workers", "1"]
        if "--contacts" not in argv:
            argv += ["--contacts", "3"]
        if "--count" not in argv:
            argv += ["--count", "1"]
        if rng.random() < 0.2:
            argv.append("--check")
        if rng.random() < p / 8:
            argv += ["--dask", rng.choice(["", "not a url", "tcp://", "tcp://host:notaport"])]
            b3 = True
    return Case("sweep", argv, _combine(b0, b1, b2, b3), ((out, "file"),))


def case_report(fx: Fixtures, rng: random.Random, p: float) -> Case:
    roll = rng.random()
    if roll < p / 2:
        run_dir, b0 = rng.choice([str(fx.root / "missing"), str(fx.root / "afile"),
                                  str(fx.root / "fifo"), "", str(fx.root / "dangling")]), True
    else:
        run_dir, b0 = str(fx.run_dir), False
    argv = ["report", run_dir]
    outputs: tuple[tuple[str, str], ...] = ((str(fx.run_dir / "report.html"), "file"),)
    b1: bool | None = False
    if rng.random() < 0.8:
        out, b1 = output_path(fx, rng, "file") if rng.random() < p else (
            str(fx.fresh("rep").with_suffix(".html")), False)
        argv += ["--out", out]
        outputs = ((out, "file"),)
    return Case("report", argv, _combine(b0, b1), outputs)


GENERATORS = {"modes": case_modes, "muspace": case_muspace, "plan": case_plan,
              "validate": case_validate, "simulate": case_simulate, "demo": case_demo,
              "scenarios": case_scenarios, "sweep": case_sweep, "report": case_report}


def generate(fx: Fixtures, seed: int, per_command: int, p_bad: float = 0.6,
             commands: tuple[str, ...] = COMMANDS) -> list[Case]:
    rng = random.Random(seed)
    return [GENERATORS[c](fx, rng, p_bad) for c in commands for _ in range(per_command)]


# ---------------------------------------------------------------------------------------------
# Running a case and checking the contract.
# ---------------------------------------------------------------------------------------------
SPECIAL_KINDS = (stat.S_IFIFO, stat.S_IFSOCK, stat.S_IFCHR, stat.S_IFBLK, stat.S_IFLNK)


def snapshot(root: Path) -> dict[str, object]:
    """Every entry under ``root``: regular files by content, folders, special files by kind."""
    out: dict[str, object] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            st = os.lstat(p)
            if stat.S_ISREG(st.st_mode):
                out[rel] = p.read_bytes() if st.st_size < 1_000_000 else st.st_size
            else:
                out[rel] = stat.S_IFMT(st.st_mode)
    return out


@dataclass
class Outcome:
    case: Case
    code: int
    stderr: str
    traceback: bool
    bad_not_2: bool
    partial: str  # empty when fine, else what is wrong
    lacking_message: bool
    seconds: float


def run_case(case: Case, fx: Fixtures) -> Outcome:
    """Run one case in-process (cwd = the fixture folder) and check the contract."""
    from qsplan.cli import main

    before = snapshot(fx.root)
    err, out = io.StringIO(), io.StringIO()
    escaped = False
    cwd = os.getcwd()
    t0 = time.perf_counter()
    try:
        os.chdir(fx.root)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(list(case.argv))
    except SystemExit as exc:  # argparse usage errors (exit 2) and --help
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException as exc:  # noqa: BLE001 - an escaped exception is what we count
        escaped, code = True, -1
        err.write(f"escaped: {type(exc).__name__}: {exc}")
    finally:
        os.chdir(cwd)
    seconds = time.perf_counter() - t0
    text = err.getvalue()
    after = snapshot(fx.root)
    partial = partial_output(case, code, before, after, fx.root)
    return Outcome(case, code, text, escaped or "Traceback (most recent call last)" in text,
                   case.bad is True and code != 2, partial,
                   code == 2 and not says_expected_and_got(text), seconds)


def says_expected_and_got(message: str) -> bool:
    """The message names what was expected and what came ("got", a digest that "hashes to"
    another value, or the "unknown key" it found)."""
    return "expected" in message and any(w in message for w in ("got", "hashes to",
                                                                  "unknown key"))


def partial_output(case: Case, code: int, before: dict[str, object], after: dict[str, object],
             root: Path) -> str:
    staging = [k for k in after if ".qsplan-staging-" in k or ".qsplan-old-" in k]
    if staging:
        return f"staging left: {staging[:2]}"
    for key, kind in before.items():  # FIFOs, sockets, devices, symbolic links: never touched
        if kind in SPECIAL_KINDS and after.get(key) != kind:
            return f"special file {key} replaced or deleted"
    if code not in (0, 1):
        changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
        return f"failed run changed {changed[:3]}" if changed else ""
    if code == 0:
        for path, kind in case.outputs:
            p = Path(path) if Path(path).is_absolute() else root / path
            if kind == "file" and p.is_file() and SECRET in p.read_bytes():
                return f"{path} holds the bytes of a file outside its inputs"
            if kind == "dir" and case.complete:
                p = Path(path) if Path(path).is_absolute() else root / path
                missing = [n for n in case.complete if not (p / n).is_file()
                           or (p / n).read_bytes() == OLD]
                if missing:
                    return f"incomplete output set: {missing} not written in {path}"
    return ""


def summarize(outcomes: list[Outcome]) -> dict[str, dict[str, int]]:
    table: dict[str, dict[str, int]] = {}
    for o in outcomes:
        row = table.setdefault(o.case.command, {"inputs": 0, "exit 0": 0, "exit 1": 0,
                                                "exit 2": 0, "exit 3": 0, "other": 0,
                                                "tracebacks": 0, "bad input not exit 2": 0,
                                                "partial output sets": 0,
                                                "internal faults": 0,
                                                "exit 2 lacking expected/got": 0})
        row["inputs"] += 1
        key = f"exit {o.code}" if o.code in (0, 1, 2, 3) else "other"
        row[key] += 1
        row["tracebacks"] += o.traceback
        row["bad input not exit 2"] += o.bad_not_2
        row["partial output sets"] += bool(o.partial)
        row["internal faults"] += "internal fault:" in o.stderr
        row["exit 2 lacking expected/got"] += o.lacking_message
    return table


def problems(outcomes: list[Outcome]) -> list[str]:
    """Every broken promise: a traceback, bad input not exit 2, a partial output set, an
    exit-2 message without expected and got, an unknown exit code."""
    return [f"{o.case.argv}: exit {o.code}; {o.partial or ''} {o.stderr.strip()[-300:]}"
            for o in outcomes if o.traceback or o.bad_not_2 or o.partial
            or o.lacking_message
            or o.code not in (0, 1, 2, 3)]


