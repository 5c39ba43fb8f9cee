"""``qsplan plan SCENARIO --mu 0:0.2 --out plan.json [--figures DIR]``: plan a hand segment, or
the whole task to the hand file's ``goal`` (a version-2 plan, docs/planning.md)."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

from planner.errors import InputError
from qsplan.options import MU_MAX, check_int, fmt, parse_number, parse_range
from scenarios.registry import shipped_file

MAX_WAYPOINTS = 10_000
FIGURES = ("fig10_bounds_mu_lo.png", "fig11_bounds_mu_hi.png", "fig12_rival_bounds_mu_hi.png",
           "fig13_guaranteed.png")
"""The entries ``--figures`` gets (``planner.plots.bounds.plot_bounds``), checked before any
work."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "plan",
        help="plan a hand segment: joint commands and torque bounds that guarantee a mode",
        description=(
            "Integrate the quasistatic segment of the hand file SCENARIO (a path, or a name in "
            "scenarios/data such as two_finger_hand), choose the control partition (Sec. 3.2), "
            "compute the torque band that guarantees the segment's mode and excludes every rival "
            "for all friction in --mu (eq. 28, Figs. 10-13) and write the plan (versioned JSON, "
            "docs/plan-format.md) and, with --figures, Figures 10-13. A hand file with a 'goal' "
            "is planned as a whole task (a chain of guaranteed segments, docs/planning.md); a "
            "hand other than one velocity- and one effort-controlled joint is planned over every "
            "control partition; both write a version-2 plan (segments). Exit 0 ok, 1 when no "
            "control partition can guarantee the mode or the task stops short of its goal (a "
            "partial plan is still written, with its diagnosis), 2 bad input, 3 internal fault."
        ),
    )
    p.add_argument("scenario", help="hand file or scenario name (e.g. two_finger_hand)")
    p.add_argument("--mu", help="friction interval LO:HI (e.g. 0:0.2), or one LO:HI per contact "
                   "separated by commas; default from the hand file")
    p.add_argument("--model", default=None, choices=("common", "independent"),
                   help="one coefficient for all contacts (paper) or one per contact; default "
                        "common, or independent when the intervals differ per contact")
    p.add_argument("--policy", default="midband",
                   help="torque choice: midband, constant, or rival:MODE (negative control)")
    p.add_argument("--control", default="auto",
                   help="index of the velocity-controlled joint, or auto (utility conditions)")
    p.add_argument("--waypoints", type=int,
                   help=f"number of waypoints, 2..{MAX_WAYPOINTS} (default from the file)")
    p.add_argument("--max-expansions", type=int, default=40,
                   help="task search: nodes expanded at most (1..1000; hand files with a goal)")
    p.add_argument("--out", default="plan.json", help="plan file to write")
    p.add_argument("--figures", help="folder for Figures 10-13 (PNG); written together with the "
                                     "plan, only when both succeed")
    p.set_defaults(func=run)


def parse_interval(text: str | None) -> tuple[float, float] | list[tuple[float, float]] | None:
    """``"0:0.2"`` -> (0.0, 0.2); a number -> (x, x); ``"0:0.2,0:0.3,..."`` -> one interval per
    contact (used with ``--model independent``).  Finite, ``0 <= LO <= HI``."""
    if text is None:
        return None
    out = []
    for item in str(text).split(","):
        if ":" in item:
            out.append(parse_range(item, "--mu", lo=0.0, hi=MU_MAX))
        else:
            x = parse_number(item, "--mu", lo=0.0, hi=MU_MAX)
            out.append((x, x))
    return out[0] if len(out) == 1 else out


def run(args: argparse.Namespace) -> int:
    from planner.errors import DegenerateError
    from planner.files.outputs import output_set, uninterruptible
    from planner.plan.plan_file import save_plan
    from planner.plan.segment_planner import plan_hand

    control = args.control if args.control == "auto" else _int(args.control, "--control")
    mu = parse_interval(args.mu)
    if args.waypoints is not None:
        check_int(args.waypoints, "--waypoints", 2, MAX_WAYPOINTS)
    t0 = time.perf_counter()
    if args.model is None:
        args.model = _default_model(mu, shipped_file(args.scenario))
    if _is_task(shipped_file(args.scenario)):
        return _run_task(args, mu, t0)
    with contextlib.ExitStack() as stack:
        fig_dir = stack.enter_context(output_set(args.figures, "dir", "--figures",
                                                 entries=FIGURES)) \
            if args.figures is not None else None
        plan_tmp = stack.enter_context(output_set(args.out, "file", "--out"))
        try:
            plan = plan_hand(shipped_file(args.scenario), mu=mu, model=args.model,
                             policy=args.policy, control=control, waypoints=args.waypoints)
        except DegenerateError as exc:
            print(f"qsplan plan: cannot guarantee the mode: {exc}", file=sys.stderr)
            return 1  # a valid request whose answer is "no guaranteed plan": a failed check
        save_plan(plan, plan_tmp)
        figs = []
        if fig_dir is not None:
            from planner.plots.bounds import plot_bounds

            figs = [Path(args.figures) / f.name for f in plot_bounds(plan, fig_dir)]
        commits = stack.pop_all()  # the plan and its figures: committed in one step
    with uninterruptible():
        commits.close()
    path = Path(args.out)
    quiet = getattr(args, "quiet", False)
    if not quiet:
        m = plan.margins()
        print(f"plan: {path}  ({len(plan.waypoints)} waypoints, {time.perf_counter() - t0:.2f} s)")
        ivs = [tuple(iv) for iv in plan.mu_intervals]  # per contact, in contact order
        mu_text = " ".join(f"[{fmt(a)}, {fmt(b)}]" for a, b in (ivs if len(set(ivs)) > 1
                                                              else ivs[:1]))
        print(f"  claim {plan.claim}; control {', '.join(plan.control)}; mu {plan.mu_model} "
              f"{mu_text}; policy {plan.policy}")
        print(f"  segment ends at t = {fmt(plan.event['t'], '.3g')} s: {plan.event['kind']} "
              f"({plan.event['detail']}); travel {fmt(1e3 * plan.travel(), '.2f')} mm")
        print(f"  smallest torque margin {fmt(m.min(), '.3g')} N m; exact bounds: {plan.exact}")
        if getattr(args, "verbose", False):
            for w in plan.waypoints:
                print(f"  t={w.t:7.3f}  tau={fmt(w.torque_command, '+.5f')}  "
                      f"band=[{fmt(w.band[0], '+.5f')}, {fmt(w.band[1], '+.5f')}]  "
                      f"{' | '.join(w.predicted)}")
        for f in figs:
            print(f"  figure: {f}")
    return 0


def _int(text: str, name: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise InputError(f"{name}: expected an integer or 'auto', got {text!r}") from None


def _default_model(mu: object, path: Path) -> str:
    """``common`` unless the friction intervals (``--mu``, else the hand file's) differ per
    contact: then one coefficient per contact (``independent``) is what the file describes."""
    from planner.files.hand_file import load_hand_file

    if mu is None:
        intervals = [tuple(p) for p in load_hand_file(path).mu_interval or ()]
    elif isinstance(mu, list):
        intervals = [tuple(p) for p in mu]
    else:
        intervals = [tuple(mu)]  # type: ignore[arg-type]
    return "independent" if len(set(intervals)) > 1 else "common"


def _is_task(path: Path) -> bool:
    """True when the hand file is planned as a version-2 plan: it has a goal, or is not the
    one-velocity-one-effort shape of version 1."""
    from planner.files.hand_file import load_hand_file

    hf = load_hand_file(path)
    seg = hf.segment
    return hf.goal is not None or hf.hand.n_joints != 2 or (
        seg is not None and len(seg.drives) != 1)


def _run_task(args: argparse.Namespace, mu: object, t0: float) -> int:
    from planner.files.outputs import output_set
    from planner.plan.task_file import plan_hand_task, save_task_plan

    if args.policy != "midband" or args.control != "auto" or args.figures is not None:
        raise InputError("--policy, --control and --figures: expected their defaults for a "
                         "whole-task or any-hand plan (version 2: Chebyshev centres of the "
                         "torque regions), got "
                         f"{args.policy!r}, {args.control!r}, {args.figures!r}")
    from planner.errors import DegenerateError

    check_int(args.max_expansions, "--max-expansions", 1, 1000)
    with output_set(args.out, "file", "--out") as tmp:
        try:
            plan = plan_hand_task(shipped_file(args.scenario), mu=mu, model=args.model,
                                  max_expansions=args.max_expansions, waypoints=args.waypoints)
        except DegenerateError as exc:
            print(f"qsplan plan: cannot guarantee the mode: {exc}", file=sys.stderr)
            return 1
        save_task_plan(plan, tmp)
    if not getattr(args, "quiet", False):
        print(f"plan: {args.out}  (version 2, {len(plan.segments)} segment(s), "
              f"{time.perf_counter() - t0:.2f} s); goal reached: {plan.reached}")
        for k, (seg, start) in enumerate(zip(plan.segments, plan.start_times())):
            m = min(w.margin for w in seg.waypoints)
            print(f"  {k + 1}. t = {fmt(start, '.3g')} s: {seg.claim}; control "
                  f"{', '.join(seg.control)}; ends {seg.event['kind']} ({seg.event['detail']}); "
                  f"smallest margin {fmt(m, '.3g')}")
        if plan.diagnosis is not None:
            failed = plan.diagnosis.get("failed") or {}
            print(f"  stops short of the goal: {failed.get('what', '')}: {failed.get('why', '')}")
            if failed.get("widest_mu") is not None:
                print(f"  widest friction interval that would work there: "
                      f"{failed['widest_mu']}")
    return 0 if plan.reached else 1
