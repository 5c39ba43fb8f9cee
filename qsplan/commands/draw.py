"""``qsplan draw FILE [--out PICTURE.png|.svg] [--mode LABEL]``: a picture of a system,
multi-body, hand or plan file before it is run (:mod:`planner.plots.draw`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from planner.errors import InputError
from qsplan.options import input_warnings

DESCRIPTION = """\
Draw a system, multi-body, hand or plan file: the workpieces, surfaces and fingers, the
contacts numbered as every output numbers them with their inward normals and friction cones
(half-angle atan(mu)), the load at the centre of mass, the drive (each contact's manipulator
velocity), chain joints; a hand at its start configuration with its goal pose dashed; a plan's
hand at its first waypoint with the torque command of each effort-controlled joint.  --mode
LABEL overlays a feasible mode's certificate (system files): the contact forces on the
workpiece and the velocity of every workpiece vertex.  The format follows --out's suffix (.png
or .svg; default FILE's name with .png in the current folder).  Exit 0 written, 2 bad input
(including a --mode that is not feasible)."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("draw", help="a picture of a system, hand or plan file (PNG or SVG)",
                       description=DESCRIPTION)
    p.add_argument("file", help="system, multi-body, hand or plan file (JSON)")
    p.add_argument("--out", help="picture to write, .png or .svg (default ./FILE_STEM.png)")
    p.add_argument("--mode", help="a feasible mode's label, e.g. 'S-1 S-2 R3' (system files): "
                                  "draw its contact forces and velocities")
    p.set_defaults(func=run)


def kind_of(data: Any) -> str:
    """``system``, ``hand`` or ``plan`` from a parsed file's ``format`` and keys."""
    if isinstance(data, dict):
        fmt = data.get("format")
        if fmt == "qsplan-plan":
            return "plan"
        if fmt == "qsplan-hand" or "palm" in data:
            return "hand"
    return "system"


def run(args: argparse.Namespace) -> int:
    from planner.files.outputs import output_set
    from planner.files.reader import read_json

    out = Path(args.out) if args.out is not None else Path(Path(args.file).stem + ".png")
    if out.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"--out: expected a .png or .svg file, got {str(out)!r}")
    data = read_json(args.file, "file to draw")
    kind = kind_of(data)
    if args.mode is not None and kind != "system":
        raise InputError(f"--mode: expected a system file (modes are predicted for systems), "
                         f"got a {kind} file")
    with output_set(out, "file", "--out") as tmp:
        fig = figure(args.file, kind, args.mode)
        from planner.plots.draw import save_drawing

        save_drawing(fig, tmp)
    if not getattr(args, "quiet", False):
        print(f"wrote {out} ({kind} file {args.file})")
    return 0


def figure(path: str, kind: str, mode_label: str | None = None) -> Any:
    """The matplotlib figure of a file of ``kind`` (see :func:`kind_of`)."""
    from planner.plots.draw import draw_hand, draw_system, pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    if kind == "system":
        from planner.files.system_file import load_system

        with input_warnings("draw"):
            system = load_system(path)
        mode = None
        if mode_label is not None:
            mode = feasible_mode(system, mode_label)
        draw_system(ax, system, mode)
        title = f"{Path(path).name}: {system.n_contacts} contacts"
    elif kind == "hand":
        from planner.files.hand_file import load_hand_file

        hf = load_hand_file(path)
        mu = [hi for _, hi in hf.mu_interval] if hf.mu_interval else 0.0
        if hf.mu_interval and len(hf.mu_interval) == 1:
            mu = hf.mu_interval[0][1]
        goal = hf.goal.pose if hf.goal is not None and hf.goal.pose is not None else None
        draw_hand(ax, hf.hand, hf.q0, mu, goal=goal)
        title = f"{Path(path).name}: hand at its start" + (", goal dashed" if goal is not None
                                                             else "")
    else:
        title = _draw_plan(ax, path)
    ax.set_title(title + ("\n" + ax.get_title() if ax.get_title() else ""), fontsize=8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    fig.tight_layout()
    return fig


def feasible_mode(system: Any, label: str) -> Any:
    """The feasible mode of ``system`` labelled ``label`` (tokens as printed by ``qsplan
    modes``); :class:`InputError` listing the feasible ones otherwise."""
    from planner.predict.feasibility import feasible_modes

    pred = feasible_modes(system)
    want = " ".join(label.split())
    found = pred.find(want)
    if found is None:
        raise InputError(f"--mode: expected one of the feasible modes {pred.labels} "
                         f"(status {pred.status.value}), got {want!r}")
    return found


def _draw_plan(ax: Any, path: str) -> str:
    """A plan's hand at its first waypoint, its goal, and the torque commands."""
    import numpy as np

    from planner.errors import InputError
    from planner.plan.plan_file import load_plan
    from planner.plots.draw import draw_hand

    plan = load_plan(path)  # any plan version
    if not plan.segments:
        raise InputError(f"{path}: expected a plan with at least one segment to draw, got a "
                         "partial plan that stops before its first")
    seg = plan.segments[0]
    claim = (f"{len(plan.segments)} segment(s), first {seg.claim}" if len(plan.segments) > 1
             else seg.claim)
    setup = seg.hand_model
    w = seg.waypoints[0]
    q = np.array([*w.pose, *w.angles])
    effort = [k for k, c in enumerate(seg.control) if c == "effort"]
    torques = dict(zip(effort, w.torque_commands))
    goal = None
    goal_raw = plan.hand.get("goal")
    if isinstance(goal_raw, dict) and isinstance(goal_raw.get("pose"), list):
        goal = np.asarray(goal_raw["pose"], dtype=float)
    mu = [hi for _, hi in seg.mu_intervals]
    draw_hand(ax, setup.hand, q, mu, goal=goal, torques=torques)
    print_note = f"{Path(path).name}: plan ({claim}) at its first waypoint"
    return print_note + (", goal dashed" if goal is not None else "")

