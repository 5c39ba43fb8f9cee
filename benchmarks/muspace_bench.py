"""Benchmark: 400 x 400 mu-space map (three contacts) by the general test and by the closed
forms; writes ``benchmarks/results/muspace_bench.json``.

Reports, for Examples 4.1 and 4.3, the best of 3 wall times of
:func:`planner.friction.muspace.mu_grid` (kinematic stage once + one batched force stage over
160 000 friction vectors; target <= 1 s), of evaluating every closed-form region (eqs. 35-36,
40-41) on the same points, their ratio measured in the same run, and the number of grid
points where the two disagree away from a boundary (expected 0).

Run: ``PYTHONPATH=. python benchmarks/muspace_bench.py``
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from planner.files.atomic import atomic_write_json
from planner.files.system_file import load_system
from planner.friction.muspace import closed_form_regions, mu_grid

ROOT = Path(__file__).resolve().parents[1]
N = 400
BASE = [0.2, 0.3, 0.1]


def _best(fn, repeats: int = 3) -> tuple[float, list[float], object]:
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return min(times), times, out


def bench(name: str) -> dict[str, object]:
    system = load_system(ROOT / "scenarios" / "data" / f"{name}.json")
    mu_grid(system, (0, 1), BASE, n=10)  # warm-up
    best, times, grid = _best(lambda: mu_grid(system, (0, 1), BASE, n=N))
    mu = grid.points()
    regions = closed_form_regions(system)
    cf_best, cf_times, inside = _best(
        lambda: np.stack([r.contains(mu) for r in regions], axis=1))
    near = np.zeros(len(mu), bool)
    for r in regions:
        D = r.denominator(mu)
        near |= (np.abs(D) < 1e-9) | np.any(
            np.abs(r.signed_inequalities(mu)) < 1e-9 * (1 + np.abs(D)[:, None]), axis=1)
    labels = [r.label for r in regions]
    disagree = 0
    for j, lab in enumerate(labels):
        general = (grid.feasible[:, grid.labels.index(lab)] if lab in grid.labels
                   else np.zeros(len(mu), bool))
        disagree += int(np.sum((general != inside[:, j]) & ~near))
    return {"example": name, "grid": [N, N], "contacts": system.n_contacts,
            "general_seconds": times, "general_best_seconds": best,
            "closed_form_seconds": cf_times, "closed_form_best_seconds": cf_best,
            "general_over_closed_form": best / cf_best,
            "modes_compared": len(labels), "points_away_from_boundary": int((~near).sum()),
            "disagreements": disagree}


def main() -> None:
    res = {"results": [bench("example_4_1"), bench("example_4_3")]}
    atomic_write_json(ROOT / "benchmarks" / "results" / "muspace_bench.json", res)
    for r in res["results"]:
        print(f"{r['example']}: general {r['general_best_seconds']:.3f} s, closed form "
              f"{r['closed_form_best_seconds']:.3f} s (ratio {r['general_over_closed_form']:.1f}),"
              f" disagreements {r['disagreements']} of {r['points_away_from_boundary']} x "
              f"{r['modes_compared']} modes")


if __name__ == "__main__":
    main()
