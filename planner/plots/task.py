"""Figures of a whole-task plan (matplotlib, Agg, imported lazily).

* :func:`plot_task_story` -- the hand at the start, at the end of every segment and at the goal:
  palm, finger links (capsules), workpiece, the contacts each segment keeps closed (dots) and
  the goal pose (dashed), one panel each;
* :func:`plot_task_regions` -- per segment, the commanded torque of each effort-controlled joint
  and the guaranteed ball around it (``torque -+ margin``: the region's Chebyshev ball; with one
  effort joint the hold interval) against the task's clock.

Lengths in mm in the pictures, torques in N m, time in s.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import save_figure
from planner.model.hand import Hand


def _draw_hand(ax: Any, hand: Hand, q: np.ndarray, *, colour: str = "tab:blue",
               goal: np.ndarray | None = None) -> None:
    s = 1e3
    a, b = np.asarray(hand.palm) * s
    ax.plot([a[0], b[0]], [a[1], b[1]], color="k", lw=3)
    for k, f in enumerate(hand.fingers):
        for (start, d), link in zip(hand.links_at(q, k), f.chain_links):
            end = start + link.length * d
            ax.plot([start[0] * s, end[0] * s], [start[1] * s, end[1] * s], color="0.45",
                    lw=max(1.0, link.width * s), solid_capstyle="round", alpha=0.8)
    V = hand.world_vertices(q) * s
    ax.fill(V[:, 0], V[:, 1], color=colour, alpha=0.35)
    ax.plot(*np.vstack([V, V[:1]]).T, color=colour, lw=1.5)
    for v, p in enumerate(V):
        ax.annotate(str(v), p, fontsize=7, color=colour)
    if goal is not None:
        G = hand.world_vertices(goal) * s
        ax.plot(*np.vstack([G, G[:1]]).T, color="tab:green", lw=1.2, ls="--")
    pts, _, _ = hand.contact_geometry(q)
    ax.plot(pts[:, 0] * s, pts[:, 1] * s, "o", color="tab:red", ms=4)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)


def plot_task_story(plan: Any, out_dir: str | Path, goal_pose: Any = None) -> Path:
    """Write ``task_story.png``: start, the end of each segment, the goal (module docstring).
    ``plan``: a :class:`planner.plan.model.Plan`; ``goal_pose`` ``(3,)`` (m, m,
    rad) drawn dashed when given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    segs = plan.segments
    n = len(segs) + 1
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n, 3.6), squeeze=False)
    starts = plan.start_times()
    for j in range(n):
        ax = axes[0, j]
        seg = segs[min(j, len(segs) - 1)]
        hand = seg.hand_model.hand
        w = seg.waypoints[0] if j < len(segs) else seg.waypoints[-1]
        q = np.array([*w.pose, *w.angles])
        goal = None
        if goal_pose is not None and j == n - 1:
            goal = q.copy()
            goal[:3] = np.asarray(goal_pose, dtype=float)
        _draw_hand(ax, hand, q, goal=goal)
        if j == 0:
            title = "start"
        elif j < len(segs):
            title = f"after segment {j}"
        else:
            title = "goal reached" if plan.reached else "end (goal not reached)"
        t = starts[j] if j < len(segs) else plan.duration()
        if j < len(segs):
            title += f"\nsegment {j + 1}: {seg.claim}\n{seg.event.kind}"
        ax.set_title(f"{title}\nt = {t:.1f} s", fontsize=8)
    fig.suptitle("the task: contacts kept closed (red), goal pose (green, dashed); mm",
                 fontsize=9)
    fig.tight_layout()
    path = save_figure(fig, Path(out_dir) / "task_story.png", dpi=110)
    plt.close(fig)
    return path


def plot_task_regions(plan: Any, out_dir: str | Path) -> Path:
    """Write ``task_regions.png``: per segment, each effort joint's commanded torque and its
    guaranteed ball against the task's clock (module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    segs = plan.segments
    fig, axes = plt.subplots(1, len(segs), figsize=(3.6 * len(segs), 3.2), squeeze=False,
                             sharey=True)
    for j, (seg, t0) in enumerate(zip(segs, plan.start_times())):
        ax = axes[0, j]
        t = t0 + np.array([w.t for w in seg.waypoints])
        names = seg.hand_model.hand.joint_names()
        effort = [k for k, c in enumerate(seg.control) if c == "effort"]
        for i, k in enumerate(effort):
            tau = np.array([w.torque_commands[i] for w in seg.waypoints])
            m = np.array([w.margin for w in seg.waypoints])
            ax.fill_between(t, tau - m, tau + m, step="post", alpha=0.25,
                            label=f"{names[k]}: guaranteed")
            ax.step(t, tau, where="post", lw=1.2, label=f"{names[k]}: command")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"segment {j + 1}: {seg.claim}", fontsize=8)
        ax.set_xlabel("t [s]", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6)
    axes[0, 0].set_ylabel("torque [N m]", fontsize=8)
    fig.tight_layout()
    path = save_figure(fig, Path(out_dir) / "task_regions.png", dpi=110)
    plt.close(fig)
    return path
