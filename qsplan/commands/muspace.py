"""``qsplan muspace``: friction-space maps (Trinkle & Zeng 1994, Figures 3 and 6)."""

from __future__ import annotations

import argparse
from pathlib import Path

from planner.errors import InputError
from planner.files.atomic import atomic_write_json
from planner.files.system_file import load_system
from planner.friction.muspace import muspace_map

DESCRIPTION = """\
Decompose a box of friction space (the coefficients mu_i, one per contact) into regions
labelled by the set of feasible contact modes -- one mode, several (ambiguous, Sec. 4.3) or
none ("jam") -- as in the paper's Figures 3 and 6.  Vary two coefficients (--vary 1,2) and
slice a third at given values (--slice 3=0,0.2,0.4), or vary three (--vary 1,2,3) for a 3-D
grid drawn as --panels slices.  Writes OUT/muspace.json (labelled grids and, for systems
without effort joints, the closed-form 3S/RS inequalities of eqs. 35-36 and 40-41 as
polynomial coefficients in the mu's) and OUT/muspace.png (one panel per slice, boundaries
drawn from the closed-form curves)."""

EPILOG = """\
example:
  qsplan muspace scenarios/data/example_4_1.json --vary 1,2 --slice 3=0,0.2,0.4,0.6 \\
      --range 0:1 --out out/ex41
exit codes: 0 written, 2 bad input."""


def _floats(text: str, what: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise InputError(f"{what}: expected comma-separated numbers, got {text!r}") from None


def run(args: argparse.Namespace) -> int:
    system = load_system(args.system)
    vary = tuple(int(v) - 1 for v in _floats(args.vary, "--vary"))
    if len(vary) not in (2, 3):
        raise InputError(f"--vary: expected two or three contact indices, got {args.vary!r}")
    lo_hi = _floats(args.range.replace(":", ","), "--range")
    if len(lo_hi) != 2:
        raise InputError(f"--range: expected MIN:MAX, got {args.range!r}")
    sliced, values = None, ()
    if args.slice:
        if len(vary) == 3:
            raise InputError("--slice: expected no --slice with three varied coefficients "
                             f"(use --panels), got {args.slice!r}")
        key, _, vals = args.slice.partition("=")
        try:
            sliced = int(key) - 1
        except ValueError:
            raise InputError(f"--slice: expected INDEX=V1,V2,..., got {args.slice!r}") from None
        if sliced in vary:
            raise InputError(f"--slice: expected a contact not in --vary, got {sliced + 1}")
        values = tuple(_floats(vals, "--slice"))
    if args.panels < 1:
        raise InputError(f"--panels: expected >= 1, got {args.panels}")
    n = args.n if args.n is not None else (200 if len(vary) == 2 else 40)
    m = muspace_map(system, vary, None, (lo_hi[0], lo_hi[1]), n, sliced=sliced,
                    slice_values=values)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "muspace.json", m.to_dict())
    from planner.plots.muspace import plot_slices

    panels, titles = m.panels(args.panels)
    plot_slices(panels, titles, out / "muspace.png", closed_forms=m.closed_forms)
    if not getattr(args, "quiet", False):
        print(f"wrote {out / 'muspace.json'} and {out / 'muspace.png'}")
        if getattr(args, "verbose", False):
            for grid, title in zip(m.grids, m.titles):
                print(f"  {title}:")
                for name, frac in sorted(grid.region_fractions().items(), key=lambda x: -x[1]):
                    print(f"    {frac:7.2%}  {name}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("muspace", help="friction-space maps of a system file (Figs. 3, 6)",
                       description=DESCRIPTION, epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("system", help="system file (JSON)")
    p.add_argument("--vary", required=True,
                   help="two or three 1-based contact indices, e.g. 1,2 or 1,2,3")
    p.add_argument("--slice", help="a contact not in --vary and its values, e.g. 3=0,0.2,0.4 "
                                   "(one panel each); the others keep the file's mu")
    p.add_argument("--range", default="0:1", help="MIN:MAX of the varied coefficients")
    p.add_argument("--n", type=int, default=None,
                   help="grid points per axis (default 200 for 2-D, 40 for 3-D)")
    p.add_argument("--panels", type=int, default=4,
                   help="slices drawn of a 3-D grid (with --vary of three contacts)")
    p.add_argument("--out", required=True, help="output directory")
    p.set_defaults(func=run)
