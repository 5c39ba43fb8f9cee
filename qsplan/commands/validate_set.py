"""``qsplan validate --set corners,centre[,outside] [--outside STEP]``: the plan also run at points
of its uncertainty set -- mass, centre of mass, contact positions (docs/planning.md, "Validating
at points of the set"; :mod:`scenarios.set_runs`).

Default: the corners and the centre when the plan's hand has an ``uncertainty`` section, none
otherwise.  The axes and the corner count are printed first (:func:`axes_line`); a point whose
contact offsets have no physical geometry is refused before any run.  Each point runs at
every friction value of the validation, in every engine asked;
one line each.  With ``--out`` each run's ``summary.json`` (no pictures) goes to
``set/<point>/`` (``set/<point>/mu_<value>/`` when several friction values), its
``parameters.set_point`` naming the point, whether it is inside the set, and the planner's
prediction there.  A point of the set that does not agree with the plan fails the validation
(exit 1, 3 on a simulator fault); a point outside the set never does.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.model.validation import FrictionValue
from planner.plan.set_points import OUTSIDE_STEP, POINT_KINDS, SetAxis, SetPoint, corner_count

SET_FOLDER = "set"
"""The folder of ``--out`` that holds the runs at the set's points."""


def add_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--set", dest="set_points", default=None,
                   help=f"points of the plan's uncertainty set (mass, centre of mass, contact "
                        f"positions) to run it at too: "
                        f"comma-separated {', '.join(POINT_KINDS)}, 'all' or 'none' (default: "
                        f"corners,centre when the plan has an uncertainty set, else none); "
                        f"outside points may fail")
    p.add_argument("--outside", default=None,
                   help=f"how far past the set an outside point lies, in half-widths of its "
                        f"axis (default {OUTSIDE_STEP})")


def chosen_points(args: argparse.Namespace, plan: Any
                  ) -> tuple[tuple[SetAxis, ...], tuple[SetPoint, ...]]:
    """The axes and points ``--set`` / ``--outside`` ask for (module docstring); bad input is
    an :class:`InputError` naming the option."""
    from planner.plan.contact_moves import moves, offset_values
    from planner.plan.load_margins import plan_load_set
    from planner.plan.set_points import parse_kinds, plan_axes, set_points
    from qsplan.options import parse_number

    step = (OUTSIDE_STEP if args.outside is None
            else parse_number(args.outside, "--outside", lo=0.0, hi=math.inf))
    if not step > 0:
        raise InputError(f"--outside: expected a number > 0 (half-widths past the set), got "
                         f"{args.outside!r}")
    ls = plan_load_set(plan)
    axes = plan_axes(plan)
    has = any(a.hi > a.lo for a in axes)
    kinds: tuple[str, ...]
    if args.set_points is None:
        kinds = ("corners", "centre") if has else ()
    else:
        kinds = parse_kinds(args.set_points)
        if kinds and not has:
            raise InputError("--set: expected a plan whose hand has an 'uncertainty' section "
                             "(a mass interval, centre-of-mass box or contact positions wider "
                             "than a point), got a plan without one")
    if args.outside is not None and "outside" not in kinds:
        raise InputError(f"--outside: expected with --set including 'outside', got --set "
                         f"{args.set_points or 'default'}")
    if not kinds or ls is None:
        return (), ()
    points = set_points(axes, kinds, step)
    for point in points:  # a point with no physical geometry: refused before any simulation
        try:
            moves(plan, offset_values([a.key for a in axes], point.values))
        except InputError as exc:
            raise InputError(f"--set: at point {point.name}: {exc} (--set none runs the "
                             "nominal plan only)") from None
    return axes, points


def axes_line(axes: tuple[SetAxis, ...], points: tuple[SetPoint, ...]) -> str:
    """``set: 6 axes (m 0.4..0.6 kg, ..., s3 contact 3 position (finger tip on edge 2) +-2
    mm); 64 corners; 77 points per engine and friction value``."""
    def span(a: SetAxis) -> str:
        if a.unit == "m" and a.nominal == 0.0 and a.lo == -a.hi:
            return f"{a.key} {a.name} +-{1000 * a.hi:.4g} mm"
        if a.unit == "m":
            return f"{a.key} {a.name} {1000 * a.lo:.4g}..{1000 * a.hi:.4g} mm"
        return f"{a.key} {a.name} {a.lo:.4g}..{a.hi:.4g} {a.unit}"

    wide = [a for a in axes if a.hi > a.lo]
    return (f"set: {len(wide)} axes ({', '.join(span(a) for a in wide)}); "
            f"{corner_count(axes)} corners (the product of the axes' ends); {len(points)} "
            f"points per engine and friction value")


def entries(points: tuple[SetPoint, ...]) -> tuple[str, ...]:
    """The ``--out`` entry the set's runs take."""
    return (f"{SET_FOLDER}/",) if points else ()


def run_points(engine: str, plan: Any, path: Path, mus: list[FrictionValue],
               axes: tuple[SetAxis, ...], points: tuple[SetPoint, ...], work: Path | None,
               mu_text: Any, mu_folder: Any) -> tuple[list[str], list[Any]]:
    """Every point at every friction value in ``engine``: the lines to print and the runs
    (:class:`scenarios.set_runs.SetRun`); summaries written under ``work/set/``."""
    from planner.files.atomic import atomic_write_json
    from scenarios.set_runs import point_line, run_at_point

    lines, runs = [f"{engine} {axes_line(axes, points)}"], []
    for point in points:
        for mu in mus:
            run = run_at_point(plan, axes, point, engine, mu,
                               name=f"validate {path.name} set {point.name} mu={mu_text(mu)}",
                               source=str(path))
            runs.append(run)
            lines.append(point_line(run, axes, engine, mu_text(mu)))
            if work is not None:
                out = work / SET_FOLDER / point.name
                out = out if len(mus) == 1 else out / mu_folder(mu)
                out.mkdir(parents=True, exist_ok=True)
                atomic_write_json(out / "summary.json", run.result.summary.to_dict())
    return lines, runs


def exit_code(runs: list[Any]) -> int:
    """3 when a run at a point of the set faulted, 1 when one failed the plan, else 0."""
    from sim.verdict import Outcome

    inside = [r for r in runs if r.point.inside]
    if any(r.result.verdict.outcome is Outcome.FAULT for r in inside):
        return 3
    return 1 if any(r.failed for r in inside) else 0


def summary_line(runs: list[Any]) -> str:
    """``set: 9 of 9 runs inside the set as planned; outside: 2 of 4 as predicted``."""
    inside = [r for r in runs if r.point.inside]
    outside = [r for r in runs if not r.point.inside]
    text = f"set: {sum(not r.failed for r in inside)} of {len(inside)} runs inside the set " \
           f"as planned"
    if outside:
        text += (f"; outside: {sum(r.matched for r in outside)} of {len(outside)} as the "
                 f"planner predicts there (allowed to fail)")
    return text
