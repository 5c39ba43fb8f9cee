"""``qsplan muspace``: friction-space maps (Trinkle & Zeng 1994, Figures 3 and 6)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.files.atomic import atomic_write_json
from planner.files.system_file import load_system
from planner.friction.muspace import muspace_map
from planner.friction.regions import region_words
from qsplan.options import (
    MU_MAX,
    check_budget,
    check_int,
    input_warnings,
    memory_budget,
    parse_numbers,
    parse_range,
)

DESCRIPTION = """\
Decompose a box of friction space (the coefficients mu_i, one per contact) into regions
labelled by the set of feasible contact modes -- one mode (moves), several (ambiguous, Sec.
4.3) or none (jams; "slips" when nothing is driven and no static equilibrium holds; a static
equilibrium of an undriven system "stays") -- as in the paper's Figures 3 and 6.  Vary two
coefficients (--vary 1,2, or friction groups --vary table,finger) and slice a third at given
values (--slice 3=0,0.2,0.4), or vary three (--vary 1,2,3) for a 3-D grid drawn as --panels
slices.  Writes OUT/muspace.json (labelled grids and, for systems
without effort joints, the closed-form 3S/RS inequalities of eqs. 35-36 and 40-41 as
polynomial coefficients in the mu's) and OUT/muspace.png (one panel per slice, boundaries
drawn from the closed-form curves)."""

EPILOG = """\
example:
  qsplan muspace scenarios/data/example_4_1.json --vary 1,2 --slice 3=0,0.2,0.4,0.6 \\
      --range 0:1 --out out/ex41
exit codes: 0 written, 2 bad input."""


MAX_PANELS = 64
OUTPUTS = ("muspace.json", "muspace.png")
"""The entries ``--out`` gets (checked before any work, replaced together)."""
BYTES_PER_POINT_CONTACT = 16
"""Memory of a grid point per contact (the mu vector plus the feasibility columns)."""


def run(args: argparse.Namespace) -> int:
    from planner.files.outputs import output_set

    tokens = [t.strip() for t in str(args.vary).split(",")]
    if len(tokens) not in (2, 3) or len(set(tokens)) != len(tokens):
        raise InputError(f"--vary: expected two or three different contact indices or friction "
                         f"groups, got {args.vary!r}")
    lo, hi = parse_range(args.range, "--range", lo=0.0, hi=MU_MAX)
    slice_key: str | None = None
    values: tuple[float, ...] = ()
    if args.slice is not None:
        if len(tokens) == 3:
            raise InputError("--slice: expected no --slice with three varied coefficients "
                             f"(use --panels), got {args.slice!r}")
        key, eq, vals = args.slice.partition("=")
        if not eq:
            raise InputError(f"--slice: expected INDEX=V1,V2,... or GROUP=V1,V2,..., got "
                             f"{args.slice!r}")
        slice_key = key.strip()
        if slice_key in tokens:
            raise InputError(f"--slice: expected a contact not in --vary, got {slice_key}")
        values = tuple(parse_numbers(vals, "--slice", lo=0.0, hi=MU_MAX))
        if len(values) > MAX_PANELS:
            raise InputError(f"--slice: expected at most {MAX_PANELS} values, got "
                             f"{len(values)}")
    check_int(args.panels, "--panels", 1, MAX_PANELS)
    n = args.n if args.n is not None else (200 if len(tokens) == 2 else 40)
    check_int(n, "--n", 1)
    with output_set(args.out, "dir", entries=OUTPUTS) as work:
        with input_warnings("muspace"):
            system = load_system(args.system)
        n_c = system.n_contacts
        axes = [axis_contacts(t, system, "--vary") for t in tokens]
        flat = [i for a in axes for i in a]
        if len(set(flat)) != len(flat):
            raise InputError(f"--vary: expected different contacts on each axis, got "
                             f"{args.vary!r}")
        cut = None if slice_key is None else axis_contacts(slice_key, system, "--slice")
        if cut is not None and set(cut) & set(flat):
            raise InputError(f"--slice: expected a contact not in --vary, got {slice_key}")
        grouped = any(not t.isdigit() for t in tokens)
        names = tuple(t if not t.isdigit() else f"contact {t}" for t in tokens) if grouped else ()
        vary = [a[0] + 1 for a in axes]
        from planner.model.modes import candidate_count

        points = n ** len(vary) * max(1, len(values))
        need = (points * n_c * BYTES_PER_POINT_CONTACT
                + candidate_count(n_c, system.dof) * (48 * n_c + 64 * system.dof))
        check_budget(need, memory_budget(getattr(args, "memory_gib", None)),
                     f"a grid of {points} friction points", "use a smaller --n")
        m = muspace_map(system, tuple(tuple(a) for a in axes), None, (lo, hi), n,
                        sliced=None if cut is None else tuple(cut), slice_values=values,
                        names=names, slice_name="" if slice_key is None or slice_key.isdigit()
                        else slice_key)
        atomic_write_json(work / "muspace.json", m.to_dict())
        from planner.plots.muspace import plot_slices

        panels, titles = m.panels(args.panels)
        plot_slices(panels, titles, work / "muspace.png", closed_forms=m.closed_forms)
    out = Path(args.out)
    if not getattr(args, "quiet", False):
        print(f"wrote {out / 'muspace.json'} and {out / 'muspace.png'}")
        if getattr(args, "verbose", False):
            for grid, title in zip(m.grids, m.titles):
                print(f"  {title}:")
                for name, frac in sorted(grid.region_fractions().items(), key=lambda x: -x[1]):
                    print(f"    {frac:7.2%}  {region_words(name, grid.driven)}")
    return 0


def axis_contacts(token: str, system: Any, option: str) -> list[int]:
    """0-based contacts of one axis: a 1-based contact index, or a friction group's name."""
    if token.isdigit():
        i = int(token)
        if not 1 <= i <= system.n_contacts:
            raise InputError(f"{option}: expected contact indices in 1..{system.n_contacts}, "
                             f"got {i}")
        return [i - 1]
    groups = dict(system.friction_groups)
    if token not in groups:
        named = (f"one of the file's friction groups {sorted(groups)}" if groups
                 else "a friction group (the file names none)")
        raise InputError(f"{option}: expected a contact index in 1..{system.n_contacts} or "
                         f"{named}, got {token!r}")
    return list(groups[token])


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("muspace", help="friction-space maps of a system file (Figs. 3, 6)",
                       description=DESCRIPTION, epilog=EPILOG)
    p.add_argument("system", help="system file (JSON)")
    p.add_argument("--vary", required=True,
                   help="two or three 1-based contact indices, e.g. 1,2 or 1,2,3, or friction "
                        "groups of the file, e.g. table,finger (a group's contacts share its "
                        "coefficient)")
    p.add_argument("--slice", help="a contact not in --vary and its values, e.g. 3=0,0.2,0.4 "
                                   "(one panel each); the others keep the file's mu")
    p.add_argument("--range", default="0:1", help="LO:HI of the varied coefficients")
    p.add_argument("--n", type=int, default=None,
                   help="grid points per axis (default 200 for 2-D, 40 for 3-D; refused beyond "
                        "the memory budget)")
    p.add_argument("--panels", type=int, default=4,
                   help="slices drawn of a 3-D grid (with --vary of three contacts), "
                        f"1..{MAX_PANELS}")
    p.add_argument("--out", required=True,
                   help="output directory (created; muspace.json and muspace.png in it are "
                        "replaced together, only when both were written)")
    p.set_defaults(func=run)
