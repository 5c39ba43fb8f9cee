"""``qsplan sweep``: large sweeps through the executor (local processes, or ``--dask ADDR``).

    qsplan sweep mu SYSTEM.json --grid 11 --out map.json [--dask tcp://host:8786]
    qsplan sweep scenes --contacts 12 --count 100 --out scenes.json [--check]

``mu``: the feasible modes at every point of a regular grid over ``[mu_lo, mu_hi]^n_c`` (a
mu-space map, Sec. 4.1 / Fig. 3).  ``scenes``: all feasible modes of many seeded random scenes
(``planner.sweeps.random_systems``) with the pruned search (``--check`` also runs exhaustive
enumeration).  Output is JSON; the same sweep gives the same file locally and through Dask.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from planner.errors import InputError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep",
        help="mu-space maps and random-scene batches through local processes or Dask",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("kind", choices=["mu", "scenes"], help="what to sweep")
    p.add_argument("system", nargs="?", help="system file (for 'mu')")
    p.add_argument("--grid", type=int, default=11, help="grid points per friction axis (mu)")
    p.add_argument("--mu-range", default="0,1", help="friction range lo,hi (mu)")
    p.add_argument("--contacts", type=int, default=8, help="n_c of the random scenes (scenes)")
    p.add_argument("--count", type=int, default=20, help="number of scenes (seeds 0..count-1)")
    p.add_argument("--check", action="store_true", help="also run exhaustive enumeration")
    p.add_argument("--out", required=True, help="output JSON file (written atomically)")
    p.add_argument("--dask", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    p.add_argument("--workers", type=int, default=None, help="local worker processes")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from planner.files.atomic import atomic_write_json
    from planner.sweeps.executor import make_executor, mu_sweep, scene_sweep

    progress = not args.no_progress
    if args.kind == "mu":
        if not args.system:
            raise InputError("sweep mu: expected a SYSTEM.json argument, got none")
        from planner.files.system_file import load_system

        system = load_system(args.system)
        try:
            lo, hi = (float(x) for x in args.mu_range.split(","))
        except ValueError as exc:
            raise InputError(f"--mu-range: expected 'lo,hi', got {args.mu_range!r}") from exc
        if not (0.0 <= lo <= hi) or args.grid < 1:
            raise InputError(
                f"--mu-range/--grid: expected 0 <= lo <= hi and grid >= 1, got "
                f"{args.mu_range!r}, {args.grid}"
            )
        axis = np.linspace(lo, hi, args.grid)
        points = np.array(list(itertools.product(axis, repeat=system.n_contacts)))
        executor = make_executor(args.dask, args.workers)
        try:
            labels = mu_sweep(system, points, executor, progress=progress)
        finally:
            executor.close()
        atomic_write_json(args.out, {
            "kind": "mu", "system": str(args.system), "mu": points.tolist(), "modes": labels,
        })
    else:
        if args.count < 1:
            raise InputError(f"--count: expected >= 1, got {args.count}")
        executor = make_executor(args.dask, args.workers)
        try:
            rows = scene_sweep(range(args.count), args.contacts, executor, check=args.check,
                               progress=progress)
        finally:
            executor.close()
        atomic_write_json(args.out, {"kind": "scenes", "rows": rows})
        if args.check and any(r["modes"] != r["exhaustive_modes"] for r in rows):
            return 1
    return 0
