"""The command-line fuzz campaign, long form: every subcommand and format, hostile inputs and
process-level faults, two tables.

Inputs (in-process through ``qsplan.cli.main``, plus ``--subprocess K`` per command through a
real ``python -m qsplan.cli``): the generator and contract checks of ``tests/cli_fuzz_cases.py``
(broken JSON, wrong types, NaN/Infinity, huge numbers, missing and unknown keys in system, hand
and plan files; NaN/inf/absurd option values; unwritable, special and wrong-kind output paths)
and of ``tests/cli_fuzz_formats.py`` (``--formats K`` per command: geometry, chain and
multi-body system files, hand files with a goal, version-2 plans, ``scenarios run --set``,
hostile run folders, special files inside output sets).  Per command: inputs, exit-code
counts, tracebacks, bad input not exit 2, partial output sets, internal faults, exit-2 messages
lacking expected/got, the slowest exit 2 (an unusable output must be refused before any work).

Faults (``tests/cli_fuzz_faults.py``; real processes): ``--signals N`` SIGINT/SIGTERM/SIGHUP at
random times over nine commands, ``--pipes N`` closed stdouts, ``--concurrent N`` groups of
writers on one output set, ``--fs N`` tiny, read-only and revoked file systems (a tmpfs in a
private mount namespace; skipped where none can be made).  Per fault kind: runs, exit codes,
and every broken promise (tracebacks, a wrong exit code, an exit more than 1 s after a signal,
children left, staging left, partial output sets, special files touched, internal faults).

    PYTHONPATH=. python benchmarks/fuzz_cli.py --per-command 80 --subprocess 3 --formats 40 \
        --signals 60 --pipes 20 --concurrent 3 --fs 16 --seed 0 \
        --out benchmarks/results/fuzz_cli.json

Validate, simulate, demo, scenarios and goal-hand plan inputs always carry one surely bad part
(an accepted run would simulate or plan for seconds to minutes); their good paths run under the
faults.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from cli_fuzz_cases import (  # noqa: E402
    COMMANDS,
    Outcome,
    generate,
    problems,
    run_case,
    says_expected_and_got,
    snapshot,
    summarize,
)
from cli_fuzz_formats import FORMAT_GENERATORS, generate_formats, make_formats  # noqa: E402
from cli_fuzz_inputs import make_fixtures  # noqa: E402

COLUMNS = ("inputs", "exit 0", "exit 1", "exit 2", "exit 3", "tracebacks",
           "bad input not exit 2", "partial output sets", "internal faults",
           "exit 2 lacking expected/got")


def run_subprocess(case, fx) -> Outcome:  # type: ignore[no-untyped-def]
    """The same case in a real process (the console path)."""
    from cli_fuzz_cases import partial_output

    before = snapshot(fx.root)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "qsplan.cli", *case.argv], cwd=fx.root, env=env,
                         capture_output=True, text=True, timeout=600)
    seconds = time.perf_counter() - t0
    partial = partial_output(case, res.returncode, before, snapshot(fx.root), fx.root)
    return Outcome(case, res.returncode, res.stderr, "Traceback (most recent" in res.stderr,
                   case.bad is True and res.returncode != 2, partial,
                   res.returncode == 2 and not says_expected_and_got(res.stderr), seconds)


def refusal_seconds(fx) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """Per command: wall time (in-process) of a valid run whose output is /dev/null -- the
    refusal must come before any work (planning, simulation, a grid)."""
    from cli_fuzz_cases import Case

    argvs = {
        "muspace": ["muspace", str(fx.system), "--vary", "1,2", "--out", "/dev/null"],
        "plan": ["plan", str(fx.hand), "--out", "/dev/null"],
        "validate": ["validate", str(fx.plan), "--out", "/dev/null"],
        "simulate": ["simulate", str(fx.system), "--out", "/dev/null"],
        "demo": ["demo", "--out", "/dev/null"],
        "scenarios": ["scenarios", "run", "ex41_3s", "--out", "/dev/null"],
        "sweep": ["sweep", "mu", str(fx.system), "--out", "/dev/null"],
        "report": ["report", str(fx.run_dir), "--out", "/dev/null"],
    }
    out = {}
    for cmd, argv in argvs.items():
        o = run_case(Case(cmd, argv, True), fx)
        assert o.code == 2 and not o.partial, (argv, o.code, o.stderr)
        out[cmd] = o.seconds
    return out


def markdown(table: dict[str, dict[str, float]]) -> str:
    head = ("| command | " + " | ".join(COLUMNS)
            + " | slowest exit 2 in-process [s] | --out /dev/null refused in [s] |")
    lines = [head, "|" + "---|" * (len(COLUMNS) + 3)]
    total = {c: 0.0 for c in COLUMNS}
    for cmd, row in table.items():
        lines.append(f"| {cmd} | " + " | ".join(str(int(row[c])) for c in COLUMNS)
                     + f" | {row['slowest exit 2 [s]']:.2f} | "
                     + (f"{row['refusal [s]']:.3f} |" if "refusal [s]" in row else "- |"))
        for c in COLUMNS:
            total[c] += row[c]
    lines.append("| **total** | " + " | ".join(str(int(total[c])) for c in COLUMNS) + " | | |")
    return "\n".join(lines)


FAULT_COLUMNS = ("runs", "exit 0", "exit 1", "exit 2", "exit 3", "exit 128+n",
                 "finished first", "signal as it finished", "tracebacks", "wrong exit code",
                 "ended > 1 s after signal", "children left", "staging left",
                 "partial output sets", "special files touched", "internal faults")


def fault_campaign(fx, tmp: Path, args: argparse.Namespace) -> list:  # type: ignore[no-untyped-def]
    """The process-level faults (module docstring), seeded."""
    import random

    from cli_fuzz_faults import (
        FS_FAULTS,
        concurrent_fault,
        fs_fault,
        jobs,
        pipe_fault,
        reference,
        signal_fault,
        unshare_prefix,
    )

    rng = random.Random(args.seed)
    table = jobs(fx.plan, fx.run_dir)
    logs = tmp / "fault-logs"
    refs = {}
    for name, job in table.items():
        refs[name] = reference(job, tmp / f"ref-{len(refs)}", logs)
        print(f"reference {name}: exit {refs[name].code}, {refs[name].seconds:.1f} s",
              file=sys.stderr)
    runs = []
    names = list(table)
    for k in range(args.signals):
        name = names[k % len(names)]
        runs.append(signal_fault(table[name], refs[name], tmp / f"sig{k}", logs, rng))
    outputs = [n for n in names if table[n].outputs]
    for k in range(args.pipes):
        name = names[k % len(names)]
        runs.append(pipe_fault(table[name], refs[name], tmp / f"pipe{k}", logs, rng))
    variants = {"muspace": [("--range", a) for a in ("0:1", "0:0.5", "0.2:0.9")],
                "sweep mu": [("--grid", g) for g in ("3", "4", "5")],
                "plan": [("--waypoints", w) for w in ("3", "4", "5")]}
    for k in range(args.concurrent):
        name = list(variants)[k % len(variants)]
        runs.append(concurrent_fault(table[name], variants[name], tmp / f"conc{k}", logs))
    if args.fs and unshare_prefix() is not None:
        for k in range(args.fs):
            name = outputs[k % len(outputs)] if k % 4 else "modes"
            runs.append(fs_fault(table[name], refs[name], tmp / f"fs{k}", logs, rng,
                                 FS_FAULTS[k % len(FS_FAULTS)]))
    elif args.fs:
        print("no private mount namespace: file-system faults skipped", file=sys.stderr)
    return runs


def fault_table(runs: list) -> dict[str, dict[str, float]]:  # type: ignore[type-arg]
    table: dict[str, dict[str, float]] = {}
    for r in runs:
        row = table.setdefault(r.fault, dict.fromkeys(FAULT_COLUMNS, 0))
        row["runs"] += 1
        key = f"exit {r.code}" if r.code in (0, 1, 2, 3) else "exit 128+n"
        row[key] += 1
        row["finished first"] += "finished first" in r.detail
        row["signal as it finished"] += "came as the command finished" in r.detail
        text = " ".join(r.problems)
        row["tracebacks"] += "traceback" in text
        row["wrong exit code"] += "expected one of" in text
        row["ended > 1 s after signal"] += "after the signal" in text
        row["children left"] += "child processes left" in text
        row["staging left"] += "staging left" in text
        row["partial output sets"] += "partial" in text or "half written" in text or \
            "mix" in text
        row["special files touched"] += "special file" in text
        row["internal faults"] += "internal fault" in text
        row["slowest exit after a signal [s]"] = max(
            row.get("slowest exit after a signal [s]", 0.0), r.exit_s or 0.0)
    return table


def fault_markdown(table: dict[str, dict[str, float]]) -> str:
    lines = ["| fault | " + " | ".join(FAULT_COLUMNS) + " | slowest exit after a signal [s] |",
             "|" + "---|" * (len(FAULT_COLUMNS) + 2)]
    total = dict.fromkeys(FAULT_COLUMNS, 0.0)
    for kind, row in table.items():
        lines.append(f"| {kind} | " + " | ".join(str(int(row[c])) for c in FAULT_COLUMNS)
                     + f" | {row.get('slowest exit after a signal [s]', 0.0):.2f} |")
        for c in FAULT_COLUMNS:
            total[c] += row[c]
    lines.append("| **total** | " + " | ".join(str(int(total[c])) for c in FAULT_COLUMNS)
                 + " | |")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-command", type=int, default=80, help="in-process inputs per command")
    ap.add_argument("--subprocess", type=int, default=3,
                    help="extra inputs per command run as a real process")
    ap.add_argument("--formats", type=int, default=40,
                    help="in-process inputs per command of the newer formats")
    ap.add_argument("--signals", type=int, default=60, help="signals at random times")
    ap.add_argument("--pipes", type=int, default=20, help="runs with a closed stdout")
    ap.add_argument("--concurrent", type=int, default=3, help="groups of concurrent writers")
    ap.add_argument("--fs", type=int, default=16, help="file-system faults")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", help="JSON file for the table and every problem found")
    args = ap.parse_args()
    os.environ.setdefault("QSPLAN_LOG_DIR", tempfile.mkdtemp(prefix="qsplan-fuzz-logs-"))
    t0 = time.perf_counter()
    outcomes: list[Outcome] = []
    in_process: set[int] = set()
    with tempfile.TemporaryDirectory(prefix="qsplan-fuzz-cli-") as tmp:
        fx = make_fixtures(Path(tmp) / "fx")
        refusal = refusal_seconds(fx)
        for i, cmd in enumerate(COMMANDS):
            cases = generate(fx, args.seed * 100 + i, args.per_command + args.subprocess,
                             commands=(cmd,))
            here = [run_case(c, fx) for c in cases[:args.per_command]]
            in_process |= {id(o) for o in here}
            outcomes += here
            outcomes += [run_subprocess(c, fx) for c in cases[args.per_command:]]
            print(f"{cmd}: {len(cases)} inputs, {time.perf_counter() - t0:.0f} s",
                  file=sys.stderr)
        if args.formats:
            ff = make_formats(fx)
            for i, cmd in enumerate(sorted(FORMAT_GENERATORS)):
                here = [run_case(c, fx) for c in generate_formats(
                    fx, ff, args.seed * 100 + 50 + i, args.formats, commands=(cmd,))]
                in_process |= {id(o) for o in here}
                outcomes += here
                print(f"{cmd} (newer formats): {len(here)} inputs, "
                      f"{time.perf_counter() - t0:.0f} s", file=sys.stderr)
        runs = fault_campaign(fx, Path(tmp), args) if (args.signals or args.pipes
                                                        or args.concurrent or args.fs) else []
    table: dict[str, dict[str, float]] = {k: dict(v) for k, v in summarize(outcomes).items()}
    for cmd in table:
        twos = [o.seconds for o in outcomes if o.case.command == cmd and o.code == 2
                and id(o) in in_process]
        table[cmd]["slowest exit 2 [s]"] = max(twos, default=0.0)
        if cmd in refusal:
            table[cmd]["refusal [s]"] = refusal[cmd]
    found = problems(outcomes)
    text = markdown(table)
    print(text)
    fault_rows = fault_table(runs)
    fault_text = fault_markdown(fault_rows)
    print("\n" + fault_text)
    found += [f"{r.fault} {r.job} {r.detail}: exit {r.code}; {r.problems}; "
              f"{r.stderr.strip()[-300:]}" for r in runs if r.problems]
    print(f"\n{len(outcomes)} inputs and {len(runs)} faults in "
          f"{time.perf_counter() - t0:.0f} s; {len(found)} broken promises")
    for p in found[:20]:
        print("  " + p[:400])
    for o in outcomes:
        if "internal fault:" in o.stderr:
            print(f"  internal fault: {o.case.argv}: {o.stderr.strip()[:300]}")
    if args.out:
        from planner.files.atomic import atomic_write_json

        atomic_write_json(args.out, {"argv": sys.argv[1:], "seed": args.seed, "table": table,
                                     "faults": fault_rows, "problems": found,
                                     "markdown": text, "faults_markdown": fault_text,
                                     "fault_runs": [vars(r) for r in runs]})
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
