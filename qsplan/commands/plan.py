"""``qsplan plan SCENARIO --mu 0:0.2 --out plan.json [--figures DIR]``: plan a hand segment."""

from __future__ import annotations

import argparse
import sys
import time

from planner.errors import InputError
from scenarios.registry import shipped_file


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "plan",
        help="plan a hand segment: joint commands and torque bounds that guarantee a mode",
        description=(
            "Integrate the quasistatic segment of the hand file SCENARIO (a path, or a name in "
            "scenarios/data such as two_finger_hand), choose the control partition (Sec. 3.2), "
            "compute the torque band that guarantees the segment's mode and excludes every rival "
            "for all friction in --mu (eq. 28, Figs. 10-13) and write the plan (versioned JSON, "
            "docs/plan-format.md) and, with --figures, Figures 10-13. Exit 0 ok, 2 bad input, "
            "3 when no partition can guarantee the mode."
        ),
    )
    p.add_argument("scenario", help="hand file or scenario name (e.g. two_finger_hand)")
    p.add_argument("--mu", help="friction interval LO:HI (e.g. 0:0.2), or one LO:HI per contact "
                   "separated by commas; default from the hand file")
    p.add_argument("--model", default="common", choices=("common", "independent"),
                   help="one coefficient for all contacts (paper) or one per contact")
    p.add_argument("--policy", default="midband",
                   help="torque choice: midband, constant, or rival:MODE (negative control)")
    p.add_argument("--control", default="auto",
                   help="index of the velocity-controlled joint, or auto (utility conditions)")
    p.add_argument("--waypoints", type=int, help="number of waypoints (default from the file)")
    p.add_argument("--out", default="plan.json", help="plan file to write (default plan.json)")
    p.add_argument("--figures", help="folder for Figures 10-13 (PNG)")
    p.set_defaults(func=run)


def parse_interval(text: str | None) -> tuple[float, float] | list[tuple[float, float]] | None:
    """``"0:0.2"`` -> (0.0, 0.2); a number -> (x, x); ``"0:0.2,0:0.3,..."`` -> one interval per
    contact (used with ``--model independent``)."""
    if text is None:
        return None
    out = []
    for item in text.split(","):
        parts = item.split(":")
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            raise InputError(
                "--mu: expected LO:HI (e.g. 0:0.2), a number, or one LO:HI per contact, "
                f"got {text!r}"
            ) from None
        if len(vals) == 1:
            vals = vals * 2
        if len(vals) != 2:
            raise InputError(f"--mu: expected LO:HI (e.g. 0:0.2) or a number, got {item!r}")
        out.append((vals[0], vals[1]))
    return out[0] if len(out) == 1 else out


def run(args: argparse.Namespace) -> int:
    from planner.errors import DegenerateError
    from planner.plan.plan_file import save_plan
    from planner.plan.segment_planner import plan_hand

    control = args.control if args.control == "auto" else _int(args.control, "--control")
    t0 = time.perf_counter()
    try:
        plan = plan_hand(shipped_file(args.scenario), mu=parse_interval(args.mu), model=args.model,
                         policy=args.policy, control=control, waypoints=args.waypoints)
    except DegenerateError as exc:
        print(f"qsplan plan: cannot guarantee the mode: {exc}", file=sys.stderr)
        return 3
    path = save_plan(plan, args.out)
    figs = []
    if args.figures:
        from planner.plots.bounds import plot_bounds

        figs = plot_bounds(plan, args.figures)
    quiet = getattr(args, "quiet", False)
    if not quiet:
        m = plan.margins()
        print(f"plan: {path}  ({len(plan.waypoints)} waypoints, {time.perf_counter() - t0:.2f} s)")
        ivs = sorted({tuple(iv) for iv in plan.mu_intervals})
        mu_text = " ".join(f"[{a:g}, {b:g}]" for a, b in ivs)
        print(f"  claim {plan.claim}; control {', '.join(plan.control)}; mu {plan.mu_model} "
              f"{mu_text}; policy {plan.policy}")
        print(f"  segment ends at t = {plan.event['t']:.3g} s: {plan.event['kind']} "
              f"({plan.event['detail']}); travel {1e3 * plan.travel():.2f} mm")
        print(f"  smallest torque margin {m.min():.3g} N m; exact bounds: {plan.exact}")
        if getattr(args, "verbose", False):
            for w in plan.waypoints:
                print(f"  t={w.t:7.3f}  tau={w.torque_command:+.5f}  band=[{w.band[0]:+.5f}, "
                      f"{w.band[1]:+.5f}]  {' | '.join(w.predicted)}")
        for f in figs:
            print(f"  figure: {f}")
    return 0


def _int(text: str, name: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"{name}: expected an integer or 'auto', got {text!r}") from None


