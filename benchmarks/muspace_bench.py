"""Benchmark: 400 x 400 mu-space map of Example 4.1 (three contacts); writes results JSON."""

from __future__ import annotations

import time
from pathlib import Path

from planner.fileio import atomic_write_json
from planner.io import load_system
from planner.muspace import mu_grid

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    system = load_system(ROOT / "scenarios" / "data" / "example_4_1.json")
    mu_grid(system, (0, 1), [0.2, 0.3, 0.1], n=10)  # warm-up
    times = []
    for _ in range(3):
        t = time.perf_counter()
        mu_grid(system, (0, 1), [0.2, 0.3, 0.1], n=400)
        times.append(time.perf_counter() - t)
    res = {"grid": [400, 400], "contacts": 3, "seconds": times, "best_seconds": min(times)}
    atomic_write_json(ROOT / "benchmarks" / "results" / "muspace_bench.json", res)
    print(res)


if __name__ == "__main__":
    main()
