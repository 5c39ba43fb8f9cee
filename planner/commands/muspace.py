"""``qsplan muspace``: friction-space maps (Trinkle & Zeng 1994, Figures 3 and 6)."""

from __future__ import annotations

import argparse
from pathlib import Path

from planner.errors import InputError
from planner.fileio import atomic_write_json
from planner.io import load_system
from planner.muspace import mu_grid


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"{what}: expected comma-separated numbers, got {text!r}") from None


def run(args: argparse.Namespace) -> int:
    system = load_system(args.system)
    n_c = system.n_contacts
    vary = tuple(int(v) - 1 for v in _floats(args.vary, "--vary"))
    if len(vary) != 2:
        raise InputError(f"--vary: expected two contact indices, got {args.vary!r}")
    lo_hi = _floats(args.range.replace(":", ","), "--range")
    if len(lo_hi) != 2:
        raise InputError(f"--range: expected MIN:MAX, got {args.range!r}")
    base = list(system.mu)
    sliced, values = None, [None]
    if args.slice:
        key, _, vals = args.slice.partition("=")
        sliced = int(key) - 1
        if not 0 <= sliced < n_c:
            raise InputError(f"--slice: expected contact index in 1..{n_c}, got {sliced + 1}")
        if sliced in vary:
            raise InputError(f"--slice: expected a contact not in --vary, got {sliced + 1}")
        values = _floats(vals, "--slice")
        if any(v < 0 for v in values):
            raise InputError(f"--slice: expected mu >= 0, got {values}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    grids, titles = [], []
    for v in values:
        mu = list(base)
        if sliced is not None:
            mu[sliced] = v
        grids.append(mu_grid(system, vary, mu, (lo_hi[0], lo_hi[1]), n=args.n))
        titles.append(f"mu_{sliced + 1}={v}" if sliced is not None else "")
    atomic_write_json(out / "muspace.json", {"slices": [g.to_dict() for g in grids]})
    from planner.plot_muspace import plot_slices

    plot_slices(grids, titles, out / "muspace.png")
    print(f"wrote {out / 'muspace.json'} and {out / 'muspace.png'}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("muspace", help="friction-space maps of a system file (Figs. 3, 6)")
    p.add_argument("system", help="system file (JSON)")
    p.add_argument("--vary", required=True, help="two 1-based contact indices, e.g. 1,2")
    p.add_argument("--slice", help="third coefficient and its values, e.g. 3=0,0.2,0.4")
    p.add_argument("--range", default="0:1", help="MIN:MAX of the varied coefficients")
    p.add_argument("--n", type=int, default=200, help="grid points per axis")
    p.add_argument("--out", required=True, help="output directory")
    p.set_defaults(func=run)
