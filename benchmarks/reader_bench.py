"""Benchmark: the one JSON reader (planner/files/reader.py) against plain ``json.loads``.

The reader checks more (regular file, size cap, duplicate keys through an object hook, NaN /
Infinity constants, infinite floats and nesting depth in one walk of the parsed tree); this
measures what that costs, as ratios in the same run: a written plan (41 waypoints) and a large
file of floats. Also ``load_plan`` end to end (reader, field checks, digest, embedded hand).

    PYTHONPATH=. python3 benchmarks/reader_bench.py [--repeats 5] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from planner.files.atomic import atomic_write_json
from planner.files.reader import read_json
from planner.plan.hand_planner import plan_hand
from planner.plan.plan_file import load_plan, save_plan
from scenarios.registry import DATA_DIR


def best(fn: Callable[[], object], repeats: int) -> float:
    """Fastest of ``repeats`` runs [s]."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", type=Path, default=None, help="write the results as JSON here")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="qsplan-reader-") as tmp:
        plan = save_plan(plan_hand(DATA_DIR / "two_finger_hand.json"), Path(tmp) / "plan.json")
        floats = Path(tmp) / "floats.json"
        floats.write_text(json.dumps({"rows": [[i * 1e-3 + 0.5 for i in range(1000)]
                                               for _ in range(2000)]}))
        for name, path, n in (("plan, 41 waypoints", plan, 20 * args.repeats),
                              ("2e6 floats", floats, args.repeats)):
            plain = best(lambda p=path: json.loads(p.read_text()), n)
            strict = best(lambda p=path: read_json(p, "file"), n)
            rows.append({"file": name, "bytes": path.stat().st_size, "json_loads_s": plain,
                         "read_json_s": strict, "ratio": strict / plain})
            print(f"{name}: {path.stat().st_size / 1e6:.2f} MB, json.loads {plain * 1e3:.1f} ms, "
                  f"read_json {strict * 1e3:.1f} ms, ratio {strict / plain:.2f}")
        full = best(lambda: load_plan(plan), 10 * args.repeats)
        print(f"load_plan end to end: {full * 1e3:.1f} ms")
    if args.out is not None:
        atomic_write_json(args.out, {"benchmark": "reader_bench", "rows": rows,
                                     "load_plan_s": full, "python": platform.python_version()})


if __name__ == "__main__":
    main()
