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
import sys

import numpy as np

from planner.errors import InputError
from qsplan.options import MU_MAX, check_budget, check_int, memory_budget, parse_range

DESCRIPTION = """\
Large sweeps through local processes or a Dask scheduler (--dask ADDR). 'mu': the feasible
modes at every point of a regular grid over [LO, HI]^n_c (a mu-space map, Sec. 4.1 / Fig. 3).
'scenes': all feasible modes of many seeded random scenes with the pruned search (--check also
runs exhaustive enumeration). Output is JSON; the same sweep gives the same file locally and
through Dask. Exit 0 ok, 1 --check found a difference, 2 bad input, 3 internal fault."""
BYTES_PER_MU_POINT_CONTACT = 200
"""Memory of one grid point per contact: the point, its Python list in the result and JSON."""
BYTES_PER_SCENE_CONTACT = 4096
"""Memory of one scene's result row per contact (modes, labels, statistics)."""
MAX_WORKERS = 1024


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep",
        help="mu-space maps and random-scene batches through local processes or Dask",
        description=DESCRIPTION,
    )
    p.add_argument("kind", choices=["mu", "scenes"], help="what to sweep")
    p.add_argument("system", nargs="?", help="system file (for 'mu')")
    p.add_argument("--grid", type=int, default=11, help="grid points per friction axis (mu)")
    p.add_argument("--mu-range", default="0:1",
                   help="friction range LO:HI (mu); LO,HI is accepted too")
    p.add_argument("--contacts", type=int, default=8,
                   help="n_c of the random scenes, 3..40 (scenes)")
    p.add_argument("--count", type=int, default=20, help="number of scenes (seeds 0..COUNT-1)")
    p.add_argument("--check", action="store_true", help="also run exhaustive enumeration")
    p.add_argument("--out", required=True, help="output JSON file (written atomically)")
    p.add_argument("--dask", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    p.add_argument("--workers", type=int, default=None, help="local worker processes")
    p.add_argument("--no-progress", action="store_true",
                   help="no progress bar (there is none anyway unless stderr is a terminal)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from planner.files.atomic import atomic_write_json
    from planner.files.outputs import output_set
    from planner.sweeps.executor import make_executor, mu_sweep, scene_sweep

    progress = not args.no_progress and sys.stderr.isatty()
    budget = memory_budget(getattr(args, "memory_gib", None))
    if args.workers is not None:
        check_int(args.workers, "--workers", 1, MAX_WORKERS)
    if args.kind == "mu":
        if not args.system:
            raise InputError("sweep mu: expected a SYSTEM.json argument, got none")
        lo, hi = parse_range(args.mu_range, "--mu-range", lo=0.0, hi=MU_MAX, legacy_comma=True)
        check_int(args.grid, "--grid", 1)
        with output_set(args.out, "file") as tmp:
            from planner.files.system_file import load_system

            system = load_system(args.system)
            n_points = args.grid ** system.n_contacts
            check_budget(n_points * system.n_contacts * BYTES_PER_MU_POINT_CONTACT, budget,
                         f"a grid of {args.grid}^{system.n_contacts} = {n_points} friction points",
                         "use a smaller --grid")
            axis = np.linspace(lo, hi, args.grid)
            points = np.array(list(itertools.product(axis, repeat=system.n_contacts)))
            executor = make_executor(args.dask, args.workers)
            try:
                labels = mu_sweep(system, points, executor, progress=progress)
            finally:
                executor.close()
            atomic_write_json(tmp, {
                "kind": "mu", "system": str(args.system), "mu": points.tolist(), "modes": labels,
            })
        return 0
    from planner.sweeps.random_systems import MAX_CONTACTS

    check_int(args.count, "--count", 1)
    check_int(args.contacts, "--contacts", 3, MAX_CONTACTS)
    check_budget(args.count * max(args.contacts, 1) * BYTES_PER_SCENE_CONTACT, budget,
                 f"{args.count} scenes of {args.contacts} contacts", "use a smaller --count")
    with output_set(args.out, "file") as tmp:
        executor = make_executor(args.dask, args.workers)
        try:
            rows = scene_sweep(range(args.count), args.contacts, executor, check=args.check,
                               progress=progress)
        finally:
            executor.close()
        atomic_write_json(tmp, {"kind": "scenes", "rows": rows})
    if args.check and any(r["modes"] != r["exhaustive_modes"] for r in rows):
        return 1
    return 0
