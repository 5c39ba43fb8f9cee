"""Pictures of a problem before it is run: system, multi-body, hand and plan files
(``qsplan draw``; matplotlib imported lazily, Agg backend).

What is drawn (world frame, metres; docs/file-formats.md, "Drawing a file"):

* workpieces (filled polygons, vertices numbered from 0 in grey), fixed and moving surfaces
  (thick lines), fingers (a dot at a tip, a line for a flat face), a hand's palm and finger
  links (capsules) at the start configuration, its goal pose dashed;
* contacts numbered from 1 as every output numbers them, each with its inward normal ``n_i``
  (arrow) and friction cone (half-angle ``atan(mu_i)`` about ``n_i``: wide for a rough
  contact, a line for a frictionless one);
* the load ``g_obj`` of each workpiece as a force arrow at its centre of mass (the moment about
  the centre of mass in the legend), the drive: each contact's manipulator velocity
  ``J_i thetadot = v_n n_i + v_t t_i`` (eq. 5) as an arrow, chain joints as circles, a plan's
  effort-controlled joints with their torque commands;
* with a mode (``--mode LABEL``), its certificate: the contact forces ``c_i`` on the workpiece
  (arrows, eq. 26) and the velocity ``qdot`` of every workpiece vertex (arrows).

Every element carries a matplotlib ``gid`` (``contact-points``, ``normal-<i>``, ``cone-<i>``,
``load-<a>``, ``drive-<i>``, ``force-<i>``, ``vertex-velocity-<a>-<k>``, ``workpiece-<a>``,
``surface-<name>``, ``goal``) so that tests read the drawn geometry back from the figure.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import save_figure
from planner.model.geometry import rot90
from planner.model.hand_parts import rotation
from planner.model.joints import JointControl

#: Arrow and cone lengths as fractions of the scene size.
NORMAL_LEN, CONE_LEN, LOAD_LEN, DRIVE_LEN, FORCE_LEN = 0.15, 0.12, 0.3, 0.25, 0.3


def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _arrow(ax: Any, start: Any, vec: Any, gid: str, colour: str, label: str = "") -> None:
    s = np.asarray(start, dtype=float)
    e = s + np.asarray(vec, dtype=float)
    ann = ax.annotate("", xy=tuple(e), xytext=tuple(s),
                      arrowprops={"arrowstyle": "-|>", "color": colour, "lw": 1.6,
                                  "shrinkA": 0, "shrinkB": 0})
    ann.set_gid(gid)
    if label:
        ax.annotate(label, tuple(e), fontsize=7, color=colour, xytext=(3, 3),
                    textcoords="offset points")


def scene_size(points: np.ndarray, polygons: list[np.ndarray]) -> float:
    allp = np.vstack([points, *polygons]) if polygons else points
    size = float(np.ptp(allp, axis=0).max()) if len(allp) > 1 else 0.0
    return size if size > 0 else 1.0


def draw_contacts(ax: Any, points: np.ndarray, normals: np.ndarray, mu: np.ndarray, L: float,
                  colour: str = "tab:red") -> None:
    """Contact points numbered from 1, inward normals and friction cones (module docstring)."""
    ln, = ax.plot(points[:, 0], points[:, 1], "o", color=colour, ms=5, zorder=5)
    ln.set_gid("contact-points")
    for i, (p, n, m) in enumerate(zip(points, normals, mu)):
        t = rot90(n)
        _arrow(ax, p, NORMAL_LEN * L * n, f"normal-{i + 1}", colour)
        half = math.atan(float(m))
        c, s = math.cos(half), math.sin(half)
        a = p + CONE_LEN * L * (c * n + s * t)
        b = p + CONE_LEN * L * (c * n - s * t)
        from matplotlib.patches import Polygon

        cone = Polygon(np.array([p, a, b]), closed=True, alpha=0.25, color="tab:orange",
                       zorder=3)
        cone.set_gid(f"cone-{i + 1}")
        ax.add_patch(cone)
        ax.annotate(str(i + 1), tuple(p), xytext=(-9, -11), textcoords="offset points",
                    fontsize=9, color=colour, weight="bold")


def draw_polygon(ax: Any, V: np.ndarray, gid: str, colour: str = "tab:blue", *,
                 dashed: bool = False, numbers: bool = True) -> None:
    closed = np.vstack([V, V[:1]])
    ln, = ax.plot(closed[:, 0], closed[:, 1], color=colour, lw=1.5, ls="--" if dashed else "-")
    ln.set_gid(gid)
    if not dashed:
        ax.fill(V[:, 0], V[:, 1], color=colour, alpha=0.2)
    if numbers:
        for k, v in enumerate(V):
            ax.annotate(str(k), tuple(v), xytext=(3, 3), textcoords="offset points",
                        fontsize=6, color="0.4")


def draw_system(ax: Any, system: Any, mode: Any = None) -> None:
    """A :class:`planner.model.system.System` (module docstring); ``mode``: a feasible mode
    (:class:`planner.predict.stages.FeasibleMode`) whose certificate is overlaid."""
    wps = list(system.workpieces) or ([system.workpiece] if system.workpiece is not None else [])
    polys = [np.asarray(w.polygon) for w in wps]
    L = scene_size(system.points, polys)
    for a, V in enumerate(polys):
        draw_polygon(ax, V, f"workpiece-{a}", ("tab:blue", "tab:green", "tab:purple")[a % 3])
    layout = system.layout
    if layout is not None:
        for s in layout.surfaces:
            if s.edge is not None:
                E = np.asarray(s.edge)
                d = (E[1] - E[0]) / np.linalg.norm(E[1] - E[0])
                near = np.vstack([system.points, *polys]) - E[0]
                lo, hi = float((near @ d).min()) - 0.3 * L, float((near @ d).max()) + 0.3 * L
                ext = np.array([E[0] + lo * d, E[0] + hi * d])  # the part of the line in view
                ln, = ax.plot(ext[:, 0], ext[:, 1], color="0.25" if s.kind == "surface"
                              else "tab:brown", lw=3, solid_capstyle="butt")
                ln.set_gid(f"surface-{s.name}")
                ax.annotate(f"{s.name}" + (" (moving)" if s.motion.moving else ""),
                            tuple(ext[1]), fontsize=7, color="0.25")
    draw_contacts(ax, system.points, system.normals, system.mu, L)
    for a in range(system.n_bodies):
        g = system.g_obj[3 * a:3 * a + 3]
        f = g[:2]
        c = np.asarray(wps[a].com) if a < len(wps) else np.zeros(2)
        m_c = float(g[2] - (c[0] * f[1] - c[1] * f[0]))
        if np.any(g != 0):
            size = float(np.hypot(*f))
            vec = LOAD_LEN * L * f / size if size > 0 else np.zeros(2)
            _arrow(ax, c, vec, f"load-{a}", "k",
                   f"load {size:.3g} N" + (f", {m_c:+.3g} N m" if abs(m_c) > 1e-12 else ""))
        ax.plot([c[0]], [c[1]], "+", color="k", ms=9)
    _draw_drive(ax, system, L)
    if mode is not None:
        _draw_certificate(ax, system, mode, polys, L)
    ax.set_aspect("equal")
    ax.autoscale_view()


def _draw_drive(ax: Any, system: Any, L: float) -> None:
    """Manipulator velocity at each driven contact (world frame), chain joints as circles."""
    if system.virtual_joints:
        v = system.joint_inputs.reshape(-1, 2)
    else:
        velocity = np.asarray([c == JointControl.VELOCITY for c in system.control])
        thetadot = np.where(velocity, system.joint_inputs, 0.0)
        v = (system.J @ thetadot).reshape(-1, 2)
    speeds = np.hypot(v[:, 0], v[:, 1])
    top = float(speeds.max()) if len(speeds) else 0.0
    for i, (p, n, vi) in enumerate(zip(system.points, system.normals, v)):
        if speeds[i] > 0:
            u = vi[0] * n + vi[1] * rot90(n)
            _arrow(ax, p, DRIVE_LEN * L * u / top, f"drive-{i + 1}", "tab:green",
                   f"{speeds[i]:.3g} m/s")
    if system.chain is not None:
        frames, _ = system.chain.chain.frames(system.chain.q)
        for k, o in enumerate(frames[:, :2, 2]):
            ax.plot([o[0]], [o[1]], "o", mfc="none", color="tab:green", ms=8)
            ax.annotate(f"joint {k + 1}", tuple(o), fontsize=7, color="tab:green")


def _draw_certificate(ax: Any, system: Any, mode: Any, polys: list[np.ndarray],
                      L: float) -> None:
    """A feasible mode's contact forces (on the workpiece) and vertex velocities."""
    c = np.asarray(mode.contact_forces)
    size = np.hypot(c[:, 0], c[:, 1])
    top = float(size.max()) if len(size) else 0.0
    for i, (p, n, ci) in enumerate(zip(system.points, system.normals, c)):
        if top > 0 and size[i] > 0:
            f = ci[0] * n + ci[1] * rot90(n)
            _arrow(ax, p, FORCE_LEN * L * f / top, f"force-{i + 1}", "tab:purple",
                   f"{size[i]:.3g} N")
    q = np.asarray(mode.qdot)
    vel = []
    for a, V in enumerate(polys):
        qa = q[3 * a:3 * a + 3]
        vel.append([(qa[0] - qa[2] * v[1], qa[1] + qa[2] * v[0]) for v in V])
    top_v = max((float(np.hypot(*u)) for us in vel for u in us), default=0.0)
    for a, (V, us) in enumerate(zip(polys, vel)):
        for k, (v, u) in enumerate(zip(V, us)):
            if top_v > 0:
                _arrow(ax, v, DRIVE_LEN * L * np.asarray(u) / top_v,
                       f"vertex-velocity-{a}-{k}", "tab:cyan")
    ax.set_title(f"mode {mode.label}: forces on the workpiece (purple), vertex velocities "
                 "(cyan)", fontsize=8)


def draw_hand(ax: Any, hand: Any, q: np.ndarray, mu: Any, *, goal: Any = None,
              torques: dict[int, float] | None = None) -> None:
    """A hand at configuration ``q``: palm, surfaces, finger links, workpiece, contacts with
    normals and cones (``mu`` per contact), the goal pose ``(x, y, phi)`` dashed, and the
    torque command of effort-controlled joints (``torques``: joint index -> N m)."""
    V = hand.world_vertices(q)
    pts, nrm, _ = hand.contact_geometry(q)
    L = scene_size(pts, [V, np.asarray(hand.palm)])
    palm = np.asarray(hand.palm)
    ln, = ax.plot(palm[:, 0], palm[:, 1], color="0.25", lw=3)
    ln.set_gid("surface-palm")
    for name, ends in hand.environment:
        ln, = ax.plot(ends[:, 0], ends[:, 1], color="0.25", lw=3)
        ln.set_gid(f"surface-{name}")
    for k, f in enumerate(hand.fingers):
        for j, ((start, d), link) in enumerate(zip(hand.links_at(q, k), f.chain_links)):
            end = start + link.length * d
            ax.plot([start[0], end[0]], [start[1], end[1]], color="0.5", lw=4,
                    solid_capstyle="round", alpha=0.8)
            ax.plot([start[0]], [start[1]], "o", mfc="none", color="tab:green", ms=7)
            joint = hand.joint_index(k, j) - 3
            if torques and joint in torques:
                ax.annotate(f"tau {torques[joint]:+.3g} N m", tuple(start), fontsize=7,
                            color="tab:purple", xytext=(4, -10), textcoords="offset points")
        ax.annotate(f.name, tuple(hand.tip_centre(q, k)), fontsize=7, color="0.35")
    draw_polygon(ax, V, "workpiece-0")
    if goal is not None:
        qg = np.array(q, dtype=float)
        qg[:3] = goal
        draw_polygon(ax, hand.world_vertices(qg), "goal", "tab:green", dashed=True,
                     numbers=False)
    mu_arr = np.broadcast_to(np.asarray(mu, dtype=float), (hand.n_contacts,))
    draw_contacts(ax, pts, nrm, mu_arr, L)
    c = rotation(q[2]) @ hand.com + q[:2]
    f = hand.load_force
    if np.any(f != 0):
        _arrow(ax, c, LOAD_LEN * L * f / np.hypot(*f), "load-0", "k",
               f"load {np.hypot(*f):.3g} N")
    ax.set_aspect("equal")
    ax.autoscale_view()


def save_drawing(fig: Any, path: str | Path) -> Path:
    """Write the figure (PNG or SVG, by the suffix) atomically."""
    out = save_figure(fig, path, dpi=120)
    pyplot().close(fig)
    return out
