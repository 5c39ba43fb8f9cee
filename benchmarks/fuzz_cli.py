"""The command-line fuzz campaign, long form: every subcommand, hostile inputs, one table.

Uses the generator and the contract checks of ``tests/cli_fuzz_cases.py`` (broken JSON, wrong
types, NaN/Infinity, huge numbers, missing and unknown keys in system, hand and plan files;
NaN/inf/absurd option values; unwritable, special and wrong-kind output paths), runs every case
through ``qsplan.cli.main`` in-process, plus ``--subprocess K`` cases per command through a
real ``python -m qsplan.cli`` process, and prints per command: inputs, exit-code counts,
tracebacks (must be 0), bad input not exit 2 (must be 0), partial output sets (must be 0),
exit-2 messages lacking expected/got, and the slowest exit 2 (an unusable output path must be
refused before any work).

    PYTHONPATH=. python benchmarks/fuzz_cli.py --per-command 80 --seed 0 \
        --out benchmarks/results/fuzz_cli.json

Validate, demo and scenarios cases always carry one surely bad part (an accepted run would
simulate for seconds to minutes); the other commands also get valid inputs.
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


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-command", type=int, default=80, help="in-process inputs per command")
    ap.add_argument("--subprocess", type=int, default=3,
                    help="extra inputs per command run as a real process")
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
    print(f"\n{len(outcomes)} inputs in {time.perf_counter() - t0:.0f} s; "
          f"{len(found)} broken promises")
    for p in found[:20]:
        print("  " + p[:400])
    for o in outcomes:
        if "internal fault:" in o.stderr:
            print(f"  internal fault: {o.case.argv}: {o.stderr.strip()[:300]}")
    if args.out:
        from planner.files.atomic import atomic_write_json

        atomic_write_json(args.out, {"per_command": args.per_command, "seed": args.seed,
                                     "subprocess": args.subprocess, "table": table,
                                     "problems": found, "markdown": text})
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
