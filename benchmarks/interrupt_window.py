"""When does a Ctrl-C become the command line's one line?  SIGINT at fixed delays after start.

``qsplan modes example_4_1.json`` is started (``python -m qsplan.cli`` and the console script)
and sent SIGINT ``--reps`` times at each delay from 0 to ``--max-ms`` milliseconds.  Each run
is classified: *killed* (the signal's default action, before Python installed its own handler:
exit by signal, nothing printed), *traceback before the project* (Python's
``KeyboardInterrupt`` or a "Fatal Python error" while the interpreter starts -- site imports,
``.pth`` files, the console script's first import -- with no frame in the project's code),
*traceback in the project* (a frame in ``qsplan/``, ``planner/``, ``sim/`` or ``scenarios/``:
must never happen), *one line* (the command line's handler: exit 130 and one line) or
*finished*.  The last delay with a traceback bounds the window no project code can close
(docs/robustness.md, "Interrupts").

    PYTHONPATH=. python benchmarks/interrupt_window.py --reps 5 --max-ms 300 \\
        --out benchmarks/results/interrupt_window.json
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SYSTEM = str(ROOT / "scenarios" / "data" / "example_4_1.json")
PACKAGES = ("qsplan", "planner", "sim", "scenarios")


def classify(argv: list[str], delay: float) -> str:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    if "Traceback" in err or "Fatal Python error" in err:
        frames = [line for line in err.splitlines() if line.strip().startswith("File ")]
        mine = [f for f in frames if any(f"{ROOT}/{pkg}/" in f for pkg in PACKAGES)]
        return "traceback in the project" if mine else "traceback"
    if proc.returncode == -signal.SIGINT:
        return "killed"
    if proc.returncode == 130 and len(err.strip().splitlines()) == 1:
        return "one line"
    if proc.returncode == 0:
        return "finished"
    return f"exit {proc.returncode}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--max-ms", type=int, default=300)
    ap.add_argument("--step-ms", type=int, default=10)
    ap.add_argument("--out")
    args = ap.parse_args()
    entries = {"python -m qsplan.cli": [sys.executable, "-m", "qsplan.cli", "modes", SYSTEM]}
    script = shutil.which("qsplan", path=str(Path(sys.executable).parent))
    if script:
        entries["console script"] = [script, "modes", SYSTEM]
    rows = []
    print("| entry | delay [ms] | killed | traceback before the project | traceback in the "
          "project | one line | finished | other |")
    print("|---|---|---|---|---|---|---|---|")
    for name, argv in entries.items():
        for ms in range(0, args.max_ms + 1, args.step_ms):
            got = Counter(classify(argv, ms / 1000) for _ in range(args.reps))
            known = ("killed", "traceback", "traceback in the project", "one line", "finished")
            other = sum(v for k, v in got.items() if k not in known)
            rows.append({"entry": name, "delay_ms": ms, **got})
            print(f"| {name} | {ms} | {got['killed']} | {got['traceback']} | "
                  f"{got['traceback in the project']} | {got['one line']} | {got['finished']} | "
                  f"{other} |", flush=True)
    last = {n: max((r["delay_ms"] for r in rows if r["entry"] == n and r.get("traceback")),
                   default=None) for n in entries}
    mine = sum(r.get("traceback in the project", 0) for r in rows)
    print(f"\nlast delay with a traceback: {last}; tracebacks in the project: {mine}")
    if args.out:
        from planner.files.atomic import atomic_write_json

        atomic_write_json(args.out, {"rows": rows, "last_traceback_ms": last,
                                     "tracebacks_in_the_project": mine,
                                     "argv": sys.argv[1:]})
    return 0


if __name__ == "__main__":
    sys.exit(main())
