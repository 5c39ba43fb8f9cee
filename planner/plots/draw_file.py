"""A picture of a file: system, multi-body, hand or plan (``qsplan draw``, and the problem
drawing of a run folder that ``qsplan report`` shows, :func:`scenarios.runs.write_run`).

:func:`draw_file` loads the file with the project's one reader and loaders, draws it with
:mod:`planner.plots.draw` and returns the matplotlib figure (Agg backend, imported lazily).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError

__all__ = ["PROBLEM_PICTURE", "draw_file", "feasible_mode", "kind_of"]

#: The drawing of the file a run came from, written into the run folder by
#: :func:`scenarios.runs.write_run`; ``qsplan report`` shows it first.
PROBLEM_PICTURE = "problem.png"


def kind_of(data: Any) -> str:
    """``system``, ``hand`` or ``plan`` from a parsed file's ``format`` and keys."""
    if isinstance(data, dict):
        fmt = data.get("format")
        if fmt == "qsplan-plan":
            return "plan"
        if fmt == "qsplan-hand" or "palm" in data:
            return "hand"
    return "system"


def draw_file(path: str | Path, kind: str | None = None, mode_label: str | None = None) -> Any:
    """The matplotlib figure of the file at ``path`` (``kind``: see :func:`kind_of`, read from
    the file when None): a system with its contacts, normals, cones, load and drive (with
    ``mode_label``, a feasible mode's certificate), a hand at its start configuration (goal
    pose dashed), a plan's hand at its first waypoint with its torque commands.  Raises
    :class:`InputError` (FileFormatError included) for a file that cannot be drawn."""
    from planner.plots.draw import draw_hand, draw_system, pyplot

    path = str(path)
    if kind is None:
        from planner.files.reader import read_json

        kind = kind_of(read_json(path, "file to draw"))
    if mode_label is not None and kind != "system":
        raise InputError(f"--mode: expected a system file (modes are predicted for systems), "
                         f"got a {kind} file")
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    try:
        if kind == "system":
            from planner.files.system_file import load_system

            system = load_system(path)
            mode = None if mode_label is None else feasible_mode(system, mode_label)
            draw_system(ax, system, mode)
            title = f"{Path(path).name}: {system.n_contacts} contacts"
        elif kind == "hand":
            from planner.files.hand_file import load_hand_file

            hf = load_hand_file(path)
            mu: Any = [hi for _, hi in hf.mu_interval] if hf.mu_interval else 0.0
            if hf.mu_interval and len(hf.mu_interval) == 1:
                mu = hf.mu_interval[0][1]
            goal = hf.goal.pose if hf.goal is not None and hf.goal.pose is not None else None
            draw_hand(ax, hf.hand, hf.q0, mu, goal=goal)
            title = f"{Path(path).name}: hand at its start" + (
                ", goal dashed" if goal is not None else "")
        else:
            title = _draw_plan(ax, path)
    except BaseException:
        plt.close(fig)
        raise
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
    note = f"{Path(path).name}: plan ({claim}) at its first waypoint"
    return note + (", goal dashed" if goal is not None else "")
