"""Drawing of recorded runs (matplotlib, imported lazily with the Agg backend).

``timeline_plot``: per contact, predicted tokens vs observed tokens over time.
``animation_gif``: the workpiece polygon and fingertips from recorded poses, contacts coloured
by observed mode (R green, S+ orange, S- red, B grey, JAM black).
``hand_timeline`` / ``hand_animation``: the same for a hand plan run (predicted modes per
waypoint interval; palm, finger links and the predicted workpiece outline).

Physics never imports this module; it is imported lazily by the scenarios and plan runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import atomic_write_bytes, save_figure
from planner.model.hand import Hand
from sim.run import Recording
from sim.verdict import ObservedMode

COLOURS = {"R": "tab:green", "S+": "tab:orange", "S-": "tab:red", "B": "0.6", "JAM": "black"}
ORDER = ["B", "R", "S-", "S+", "JAM"]


def pyplot() -> Any:
    """``matplotlib.pyplot`` with the Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def tokens(mode: ObservedMode, n: int) -> list[str]:
    """Per-contact tokens (``R``, ``S+``, ``S-``, ``B``) of ``mode``; ``JAM`` ``n`` times for a
    jam, all ``B`` when ``mode`` does not have ``n`` contacts."""
    if isinstance(mode, str):
        return [mode] * n
    return list(mode.tokens) if len(mode.tokens) == n else ["B"] * n


def timeline_plot(rec: Recording, observed: Sequence[ObservedMode],
                  predicted: Sequence[ObservedMode], path: Path) -> Path:
    """Save a per-contact timeline (observed tokens as points, predicted sets as bands)."""
    plt = pyplot()
    P = len(rec.pair_names)
    fig, axes = plt.subplots(P, 1, figsize=(7, 1.6 * P + 0.6), sharex=True, squeeze=False)
    obs = np.array([tokens(o, P) for o in observed]) if len(observed) else np.zeros((0, P))
    for j, ax in enumerate(axes[:, 0]):
        for label in predicted:
            tok = tokens(label, P)[j]
            ax.axhspan(ORDER.index(tok) - 0.4, ORDER.index(tok) + 0.4, color=COLOURS[tok],
                       alpha=0.2)
        if len(obs):
            y = [ORDER.index(t) for t in obs[:, j]]
            ax.scatter(rec.times[: len(y)], y, s=2, c=[COLOURS[t] for t in obs[:, j]])
        ax.set_yticks(range(len(ORDER)), ORDER)
        ax.set_ylabel(rec.pair_names[j])
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(f"{rec.engine}: predicted (bands) vs observed (dots)")
    fig.tight_layout()
    out = save_figure(fig, path, dpi=80)
    plt.close(fig)
    return out


def animation_gif(rec: Recording, observed: Sequence[ObservedMode], polygon: np.ndarray,
                  path: Path,
                  frames: int = 30, finger_radius: float = 0.0) -> Path:
    """Save a GIF drawn from recorded workpiece and fingertip poses and contact points."""
    plt = pyplot()
    from PIL import Image

    P = len(rec.pair_names)
    iw = rec.body_names.index("workpiece")
    poly = np.asarray(polygon, dtype=float)
    idx = np.linspace(0, len(rec.times) - 1, min(frames, len(rec.times))).astype(int)
    span = float(np.max(np.abs(poly))) * 1.3
    images = []
    for k in idx:
        x, y, th = rec.poses[k, iw]
        c, s = np.cos(th), np.sin(th)
        pw = poly @ np.array([[c, s], [-s, c]]) + np.array([x, y])
        fig, ax = plt.subplots(figsize=(3, 3))
        ax.fill(pw[:, 0], pw[:, 1], color="0.85", edgecolor="k")
        for name in rec.body_names:
            if name.startswith("finger") and finger_radius > 0:
                fx, fy, _ = rec.poses[k, rec.body_names.index(name)]
                ax.add_patch(plt.Circle((fx, fy), finger_radius, color="0.4"))
        toks = tokens(observed[k], P) if len(observed) else ["B"] * P
        for j in range(P):
            if rec.present[k, j]:
                ax.plot(*rec.points[k, j], "o", color=COLOURS[toks[j]], ms=6)
        ax.set_xlim(-span, span)
        ax.set_ylim(-span, span)
        ax.set_aspect("equal")
        ax.set_title(f"{rec.engine} t={rec.times[k]:.2f} s", fontsize=8)
        fig.canvas.draw()
        images.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3]))
        plt.close(fig)
    import io

    buf = io.BytesIO()
    images[0].save(buf, format="GIF", save_all=True, append_images=images[1:], duration=100,
                   loop=0)
    return atomic_write_bytes(path, buf.getvalue())


def hand_timeline(rec: Recording, observed: Sequence[ObservedMode], times: np.ndarray,
                  predicted: Sequence[frozenset[ObservedMode]], claim: ObservedMode,
                  path: Path) -> Path:
    """Per contact: the plan's predicted tokens per waypoint interval (bands, ``times`` (n,) [s];
    hatched where the prediction differs from the ``claim``) and the observed tokens (dots)."""
    plt = pyplot()
    P = len(rec.pair_names)
    fig, axes = plt.subplots(P, 1, figsize=(8, 1.3 * P + 0.9), sharex=True, squeeze=False)
    t = np.asarray(times, dtype=float)
    claim_tok = tokens(claim, P)
    step = max(1, len(rec.times) // 2000)
    obs = np.array([tokens(o, P) for o in observed[::step]]) if len(observed) else None
    for j, ax in enumerate(axes[:, 0]):
        for k in range(len(t) - 1):
            for mode in sorted(predicted[k], key=str):
                tok = tokens(mode, P)[j]
                y = ORDER.index(tok)
                ax.fill_between([t[k], t[k + 1]], y - 0.4, y + 0.4, color=COLOURS[tok],
                                alpha=0.25, lw=0, hatch="//" if tok != claim_tok[j] else None)
        if obs is not None:
            ys = [ORDER.index(tok) for tok in obs[:, j]]
            ax.scatter(rec.times[::step][: len(ys)], ys, s=3,
                       c=[COLOURS[tok] for tok in obs[:, j]])
        ax.set_yticks(range(len(ORDER)), ORDER)
        ax.set_ylim(-0.6, len(ORDER) - 0.4)
        ax.set_ylabel(f"contact {j + 1}")
    axes[-1, 0].set_xlabel("time [s]")
    axes[0, 0].set_title(f"{rec.engine}: predicted per waypoint (bands) vs observed (dots); "
                         f"claim {claim}", fontsize=9)
    fig.tight_layout()
    out = save_figure(fig, path, dpi=80)
    plt.close(fig)
    return out


def hand_animation(rec: Recording, observed: Sequence[ObservedMode], hand: Hand,
                   angles: np.ndarray, times: np.ndarray, poses: np.ndarray, path: Path,
                   frames: int = 30) -> Path:
    """GIF of a hand run: palm, finger links (``angles`` (T, F) [rad] recorded joint angles) and
    workpiece from the recorded poses, the predicted workpiece outline (dashed; ``times`` (n,)
    [s] and ``poses`` (n, 3) of the plan's waypoints), contact points coloured by observed
    token."""
    import io

    from PIL import Image

    plt = pyplot()
    P = len(rec.pair_names)
    iw = rec.body_names.index("workpiece")
    ang = np.asarray(angles, dtype=float)
    t = np.asarray(times, dtype=float)
    poses = np.asarray(poses, dtype=float)
    V = np.asarray(hand.vertices)
    lo = np.min(np.vstack([hand.palm, V + poses[0, :2], V + poses[-1, :2]]), axis=0)
    hi = np.max(np.vstack([hand.palm, V + poses[0, :2], V + poses[-1, :2]]), axis=0)
    pad = 0.1 * float(np.max(hi - lo))
    idx = np.linspace(0, len(rec.times) - 1, min(frames, len(rec.times))).astype(int)
    fig, ax = plt.subplots(figsize=(4, 3.4))
    ax.plot(*np.asarray(hand.palm).T, color="k", lw=3)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    (body,) = ax.fill(V[:, 0], V[:, 1], color="0.85", edgecolor="k")
    (outline,) = ax.plot([], [], "--", color="tab:blue", lw=1)
    width_pt = 72 * 3.4 * 0.9 / (float(np.max(hi - lo)) + 2 * pad)
    links = [ax.plot([], [], color="0.4", lw=f.width * width_pt, solid_capstyle="round")[0]
             for f in hand.fingers]
    dots = [ax.plot([], [], "o", ms=6)[0] for _ in range(P)]
    title = ax.set_title("", fontsize=7)
    images = []
    for k in idx:
        pw = hand.world_vertices(np.concatenate([rec.poses[k, iw], ang[k]]))
        body.set_xy(pw)
        pp = np.array([np.interp(rec.times[k], t, poses[:, c]) for c in range(3)])
        qp = hand.world_vertices(np.concatenate([pp, ang[k]]))
        outline.set_data(*np.vstack([qp, qp[:1]]).T)
        for f_i, f in enumerate(hand.fingers):
            a = np.asarray(f.pivot)
            b = a + f.length * np.array([np.cos(ang[k, f_i]), np.sin(ang[k, f_i])])
            links[f_i].set_data([a[0], b[0]], [a[1], b[1]])
        toks = tokens(observed[k], P) if len(observed) else ["B"] * P
        for j in range(P):
            if rec.present[k, j]:
                dots[j].set_data([rec.points[k, j, 0]], [rec.points[k, j, 1]])
                dots[j].set_color(COLOURS[toks[j]])
            else:
                dots[j].set_data([], [])
        title.set_text(f"{rec.engine} t={rec.times[k]:.2f} s  "
                       f"{observed[k] if len(observed) else ''}")
        fig.canvas.draw()
        images.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3]))
    plt.close(fig)
    buf = io.BytesIO()
    images[0].save(buf, format="GIF", save_all=True, append_images=images[1:], duration=120,
                   loop=0)
    return atomic_write_bytes(path, buf.getvalue())


def draw_run(result: Any, out_dir: Path, *, animation: bool = True) -> dict[str, Path]:
    """The pictures of an executed job (:class:`sim.jobs.RunResult`) written into ``out_dir``:
    ``timeline.png`` (observed against predicted tokens per contact) and, with
    ``animation``, ``animation.gif`` of a system of one workpiece or a one-segment plan (a
    whole task's per-segment verdicts are in its summary). Returns ``{name: path}``."""
    from sim.expectation import ModeSet, PlanSchedule, Switches

    rec = result.recording
    if not len(rec.times):
        return {}
    exp = result.job.expectation
    observed = result.judgement.observed
    out: dict[str, Path] = {}
    if isinstance(exp, ModeSet):
        predicted: list[ObservedMode] = [m.mode for m in exp.modes] or ["JAM"]
        out["timeline"] = timeline_plot(rec, observed, predicted, out_dir / "timeline.png")
        meta = result.job.scene.meta
        if animation and len(exp.bodies) == 1 and "polygons" in meta:
            out["animation"] = animation_gif(
                rec, observed, np.asarray(meta["polygons"][0]), out_dir / "animation.gif",
                finger_radius=float(meta["finger_radius"]))
    elif isinstance(exp, PlanSchedule) and len(exp.segments) == 1:
        from sim.scenes.hand import finger_angles

        seg = exp.segments[0]
        hand = result.job.scene.meta["hand"]
        out["timeline"] = hand_timeline(rec, observed, seg.times, seg.predicted, seg.claim,
                                        out_dir / "timeline.png")
        if animation:
            out["animation"] = hand_animation(rec, observed, hand, finger_angles(rec, hand),
                                              seg.times, seg.poses, out_dir / "animation.gif")
    elif isinstance(exp, Switches):
        from sim.classify import mode_of

        out["timeline"] = timeline_plot(rec, observed, [mode_of(("S+", "R")),
                                                        mode_of(("R", "S-"))],
                                        out_dir / "timeline.png")
    return out
