"""``qsplan plan HAND --mu 0:0.2 --out plan.json [--figures DIR]``: plan a hand file's segment, or
the whole task to its ``goal`` (docs/planning.md); the plan file format is docs/plan-format.md."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.files.hand_file import MAX_WAYPOINTS
from qsplan.options import MU_MAX, check_int, fmt, parse_number, parse_range
from scenarios.registry import shipped_file

BOUNDS_FIGURES = ("fig10_bounds_mu_lo.png", "fig11_bounds_mu_hi.png",
                  "fig12_rival_bounds_mu_hi.png", "fig13_guaranteed.png")
"""Figures 10-13 of a one-segment plan with one effort joint
(``planner.plots.bounds.plot_bounds``)."""
COST_FIGURE = "uncertainty_cost.png"
"""What each uncertainty costs (``planner.plots.set_cost.COST_FIGURE``): drawn for a plan with a
mass / centre-of-mass set and an effort-controlled joint."""
FIGURES = (*BOUNDS_FIGURES, "regions.png", "task_story.png", "task_regions.png", COST_FIGURE)
"""The entries ``--figures`` may get (:data:`BOUNDS_FIGURES`; ``plot_regions`` for other
segments, ``planner.plots.task`` for a task; :data:`COST_FIGURE`), checked before any work; an
entry of an earlier set that this plan does not draw goes with the old set."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "plan",
        help="plan a hand: joint commands and effort bounds that guarantee each segment's mode",
        description=(
            "Plan the hand file HAND (a path, or a name in scenarios/data such as "
            "two_finger_hand): a file with a 'goal' as a whole task (a chain of guaranteed "
            "segments, docs/planning.md), else its 'segment' section as one segment. Per "
            "segment: integrate the quasistatic motion, choose the control partition (Sec. "
            "3.2; any number of effort-controlled joints), find the efforts that guarantee the "
            "mode and exclude every rival for all friction in --mu (eq. 28, Figs. 10-13), space "
            "the waypoints so the held commands keep the guarantee, and write the plan "
            "(versioned JSON, docs/plan-format.md); with --figures, Figures 10-13 (one effort "
            "joint) or the task's pictures, and with an uncertainty set the guaranteed efforts "
            "as each uncertainty grows. Exit 0 ok, 1 when no control partition can "
            "guarantee the mode or the task stops short of its goal (a partial plan is still "
            "written, with its diagnosis), 2 bad input, 3 internal fault."
        ),
    )
    p.add_argument("scenario", help="hand file or scenario name (e.g. two_finger_hand)")
    p.add_argument("--mu", help="friction interval LO:HI (e.g. 0:0.2), or one LO:HI per contact "
                   "separated by commas; default from the hand file")
    p.add_argument("--model", default=None, choices=("common", "independent"),
                   help="one coefficient for all contacts (paper) or one per contact; default "
                        "common for one interval, independent for one interval per contact "
                        "(--mu or the file's mu.interval); the plan records the model its "
                        "guarantee holds for (independent when a segment has other than one "
                        "effort-controlled joint: checked over the box)")
    p.add_argument("--policy", default="smooth",
                   help="effort choice inside the guaranteed efforts and the hand file's joint "
                        "limits (docs/planning.md, 'Command policies'): smooth (default: the "
                        "smallest largest change between waypoints that keeps the required "
                        "margin), least-effort (least squeeze keeping that margin; "
                        "least-effort:M with margin M), max-margin (= midband: the centre), "
                        "constant, or rival:MODE (negative control); one segment only")
    p.add_argument("--control", default="auto",
                   help="the velocity-controlled joints, comma-separated indices, or auto (every "
                        "partition the utility conditions allow); one segment only")
    p.add_argument("--waypoints", type=int,
                   help=f"waypoints per segment, evenly spaced, 2..{MAX_WAYPOINTS} (default: "
                        "the file's segment.waypoints, else chosen so the held commands keep "
                        "the guarantee, docs/planning.md)")
    p.add_argument("--max-expansions", type=int, default=40,
                   help="task search: nodes expanded at most (1..1000; hand files with a goal)")
    p.add_argument("--margins", action="store_true",
                   help="also find the largest mass (+-kg), centre-of-mass (+-mm) and "
                        "contact-position (+-mm, plans with one effort joint per segment) "
                        "uncertainty the commands tolerate, each axis alone (a bisection on "
                        "the exact guarantee, docs/planning.md 'Uncertainty beyond friction'); "
                        "always done for a hand file with an 'uncertainty' section")
    p.add_argument("--out", default="plan.json", help="plan file to write")
    p.add_argument("--figures", help="folder for the figures (PNG): Figures 10-13 of a segment "
                                     "with one effort joint, the task's pictures for a task; "
                                     "with an uncertainty set, what each uncertainty costs "
                                     f"({COST_FIGURE}); written together with the plan")
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


def parse_control(text: str) -> tuple[int, ...] | None:
    """``"auto"`` -> None; ``"1"`` or ``"0,2"`` -> the velocity-controlled joints."""
    if text == "auto":
        return None
    try:
        joints = tuple(int(x) for x in str(text).split(","))
    except ValueError:
        raise InputError(f"--control: expected comma-separated joint indices (integers) or "
                         f"'auto', got {text!r}") from None
    if any(j < 0 for j in joints) or len(set(joints)) != len(joints):
        raise InputError(f"--control: expected distinct joint indices >= 0, got {text!r}")
    return joints


def run(args: argparse.Namespace) -> int:
    from planner.errors import DegenerateError
    from planner.files.outputs import output_set, uninterruptible
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan

    control = parse_control(args.control)
    mu = parse_interval(args.mu)
    if args.waypoints is not None:
        check_int(args.waypoints, "--waypoints", 2, MAX_WAYPOINTS)
    check_int(args.max_expansions, "--max-expansions", 1, 1000)
    t0 = time.perf_counter()
    path = shipped_file(args.scenario)
    with contextlib.ExitStack() as stack:
        fig_dir = stack.enter_context(output_set(args.figures, "dir", "--figures",
                                                 entries=FIGURES)) \
            if args.figures is not None else None
        plan_tmp = stack.enter_context(output_set(args.out, "file", "--out"))
        try:
            plan = plan_hand(path, mu=mu, model=args.model, policy=args.policy,
                             control=control, waypoints=args.waypoints,
                             max_expansions=args.max_expansions,
                             margins=True if args.margins else None)
        except DegenerateError as exc:
            print(f"qsplan plan: cannot guarantee the mode: {exc}", file=sys.stderr)
            return 1  # a valid request whose answer is "no guaranteed plan": a failed check
        save_plan(plan, plan_tmp)
        figs = _figures(plan, fig_dir, Path(args.figures)) if fig_dir is not None else []
        commits = stack.pop_all()  # the plan and its figures: committed in one step
    with uninterruptible():
        commits.close()
    if not getattr(args, "quiet", False):
        _report(plan, Path(args.out), time.perf_counter() - t0, figs,
                getattr(args, "verbose", False))
    return 0 if plan.reached else 1


def _figures(plan: Any, work: Path, final: Path) -> list[Path]:
    """Figures 10-13 of a one-segment plan with one effort joint, the effort regions of one
    with several (or none), a task's pictures; and what each uncertainty costs
    (:data:`COST_FIGURE`) for a plan with a mass / centre-of-mass set."""
    if not plan.segments:
        return []
    return _plan_figures(plan, work, final) + _cost_figure(plan, work, final)


def _cost_figure(plan: Any, work: Path, final: Path) -> list[Path]:
    """:data:`COST_FIGURE` when the plan has a mass / centre-of-mass set (its hand's
    ``uncertainty`` section, or ``--margins``) and an effort-controlled joint."""
    from planner.plan.load_margins import plan_load_set

    ls = plan_load_set(plan)
    wanted = (ls is not None and not ls.trivial) or "uncertainty" in plan.extra
    if not wanted or not any(s.effort_joints for s in plan.segments):
        return []
    from planner.plots.set_cost import draw_plan_cost

    return [final / draw_plan_cost(plan, work / COST_FIGURE).name]


def _plan_figures(plan: Any, work: Path, final: Path) -> list[Path]:
    if len(plan.segments) == 1 and "goal" not in plan.hand:
        from planner.plots.bounds import plot_bounds, plot_regions

        seg = plan.segments[0]
        if "curves" in seg.extra:
            return [final / f.name for f in plot_bounds(seg, work)]
        return [final / f.name for f in plot_regions(seg, work,
                                                     seg.hand_model.hand.joint_names())]
    from planner.files.hand_file import hand_file_from_dict
    from planner.plots.task import plot_task_regions, plot_task_story

    goal = hand_file_from_dict(dict(plan.hand), "plan.hand").goal
    pose = None if goal is None else goal.pose
    return [final / plot_task_story(plan, work, pose).name,
            final / plot_task_regions(plan, work).name]


def _report(plan: Any, out: Path, seconds: float, figs: list[Path], verbose: bool) -> None:
    """What was planned, in plain words: per segment its mode, control, motion and end."""
    from planner.plan.wording import effort_unit, motion_words

    n_wp = sum(len(s.waypoints) for s in plan.segments)
    task = "goal" in plan.hand
    print(f"plan: {out}  ({len(plan.segments)} segment(s), {n_wp} waypoints, "
          f"{seconds:.2f} s)" + (f"; goal reached: {plan.reached}" if task else ""))
    ivs = [tuple(iv) for iv in plan.mu_intervals]
    mu_text = " ".join(f"[{fmt(a)}, {fmt(b)}]" for a, b in ivs)
    if plan.segments:
        print(f"  mu {plan.mu_model} {mu_text}; policy {plan.policy}; exact bounds: "
              f"{plan.exact}")
    unc = plan.extra.get("uncertainty") if isinstance(plan.extra, dict) else None
    if unc:
        print("  " + uncertainty_words(unc))
    for k, (seg, start) in enumerate(zip(plan.segments, plan.start_times())):
        hand = seg.hand_model.hand
        first, last = seg.waypoints[0], seg.waypoints[-1]
        moves = motion_words(first.q, last.q, hand.length_scale)
        unit = effort_unit(hand, seg.effort_joints)
        print(f"  {k + 1}. t = {fmt(start, '.3g')} s: claim {seg.claim}; control "
              f"{', '.join(seg.control)}; the workpiece {moves}; ends at t = "
              f"{fmt(seg.duration(), '.3g')} s ({seg.event.kind}): {seg.event.detail}; "
              f"{len(seg.waypoints)} waypoints; smallest margin {fmt(seg.margins().min(), '.3g')}"
              + (f" {unit}" if unit else ""))
        line = commands_line(seg.extra.get("commands"))
        if line:
            print(f"     {line}")
        unresolved = seg.extra.get("spacing", {}).get("unresolved_s", [])
        if unresolved:
            print(f"     warning: over {len(unresolved)} hold interval(s) the guaranteed "
                  "efforts move by more than half their size or jump, or the rates change faster "
                  "than the spacing holds, "
                  + ", ".join(f"{fmt(a, '.3g')}-{fmt(b, '.3g')} s" for a, b in unresolved[:4])
                  + ("" if seg.extra["spacing"]["rule"] == "adaptive" else
                     "; drop --waypoints (or the file's segment.waypoints) to let the planner "
                     "space the waypoints"))
        if verbose:
            for w in seg.waypoints:
                print(f"     t={w.t:7.3f}  rates={[fmt(x, '+.5f') for x in w.velocity_commands]}"
                      f"  efforts={[fmt(x, '+.5f') for x in w.torque_commands]}  bands="
                      f"{[[fmt(a, '+.5f'), fmt(b, '+.5f')] for a, b in w.bands]}  "
                      f"{' | '.join(w.predicted)}")
    if plan.diagnosis is not None:
        for line in diagnosis_lines(plan.diagnosis):
            print(f"  {line}")
    for f in figs:
        print(f"  figure: {f}")


def commands_line(c: Any) -> str:
    """The largest change of a segment's effort commands between waypoints against the smooth
    policy's bound (a segment's ``extra["commands"]``, docs/plan-format.md); "" without one."""
    if not isinstance(c, dict) or c.get("joint") is None:
        return ""
    unit = c.get("unit") or ""
    a, b = c.get("between_s") or (0.0, 0.0)
    head = (f"commands ({c.get('policy')}): largest change between waypoints "
            f"{fmt(float(c.get('largest_change') or 0.0), '.3g')} {unit} ({c.get('joint')}, t = "
            f"{fmt(a, '.4g')}-{fmt(b, '.4g')} s)")
    bound = c.get("bound")
    if bound is None:
        return head
    words = (f"; bound {fmt(bound, '.3g')} {unit} (the smallest largest change of any commands "
             "that keep the required margin")
    if c.get("policy") == "smooth":
        return head + words + ")"
    return head + words + (", kept)" if c.get("within_bound") else
                           "; this policy exceeds it: the default 'smooth' keeps it)")


def diagnosis_lines(d: Any) -> list[str]:
    """A partial plan's diagnosis in plain words; fields that are absent are not printed."""
    why = "; ".join(str(n) for n in d.get("notes") or [] if n)
    head = f"stops short of the goal after {d.get('after_segments', 0)} segment(s)"
    if why:
        head += f" ({why})"
    dist = d.get("distance_to_goal")
    if isinstance(dist, (int, float)):
        head += (f"; distance to the goal {fmt(dist, '.3g')} (position error over the "
                 "workpiece size + angle error over 90 deg + missing goal contacts)")
    lines = [head]
    failed = d.get("failed")
    if not failed:
        lines.append("no segment could be tried there: none can start from this contact set")
        return lines
    if failed.get("what"):
        lines.append(f"furthest try: {failed['what']}")
    if failed.get("why"):
        at = failed.get("t")
        lines.append("its guarantee fails" + (f" at t = {fmt(at, '.3g')} s"
                                              if isinstance(at, (int, float)) else "")
                     + f": {failed['why']}")
    for remedy in failed.get("remedies") or []:
        lines.append(f"what would make it work: {remedy}")
    widest = failed.get("widest_mu")
    if widest:
        lo, hi = widest
        lines.append("widest friction interval that would work there: "
                     + (f"[{fmt(lo[0])}, {fmt(hi[0], '.4g')}]" if len(set(lo)) == 1
                        and len(set(hi)) == 1 else f"{widest}"))
    return lines


def uncertainty_words(unc: Any) -> str:
    """The plan's uncertainty set (mass, centre of mass, contact positions) and what its
    commands tolerate, in plain words."""
    st, tol = unc.get("set"), unc.get("tolerated") or {}
    def iv(pair: Any, scale: float = 1.0) -> str:
        return f"[{scale * pair[0]:.4g}, {scale * pair[1]:.4g}]"
    where = (f"over mass {iv(st['mass'])} kg, centre of mass x {iv(st['com'][0], 1000)} mm, "
             f"y {iv(st['com'][1], 1000)} mm" if st else "at the nominal mass and centre of mass")
    pos = st.get("contacts") if st else None
    if isinstance(pos, dict):
        where += ", contact positions " + ", ".join(
            f"{'other bodies' if k == '*' else k} +-{1000 * v:.3g} mm" for k, v in pos.items())
    elif pos:
        where += f", every contact position +-{1000 * pos:.3g} mm"
    m, c = tol.get("mass_kg"), tol.get("com_m")
    m_txt = "the whole mass" if m is None else f"+-{m:.4g} kg"
    c_txt = "the workpiece's size" if c is None else f"+-{1000 * c:.3g} mm"
    p = tol.get("contacts_m")
    p_txt = ("" if not tol.get("contacts_computed") else
             ", contact positions the workpiece's size" if p is None else
             f", contact positions +-{1000 * p:.3g} mm")
    return (f"guaranteed {where}; the commands tolerate mass {m_txt}, centre of mass {c_txt}"
            f"{p_txt} (each axis alone, the others as planned; bisection on the exact "
            "guarantee)")
