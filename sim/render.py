"""Drawing of recorded runs (matplotlib, imported lazily with the Agg backend).

``timeline_plot``: per contact, predicted tokens vs observed tokens over time.
``animation_gif``: the workpiece polygon and fingertips from recorded poses, contacts coloured
by observed mode (R green, S+ orange, S- red, B grey, JAM black).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import atomic_write_bytes, save_figure
from sim.run import Recording

COLOURS = {"R": "tab:green", "S+": "tab:orange", "S-": "tab:red", "B": "0.6", "JAM": "black"}
ORDER = ["B", "R", "S-", "S+", "JAM"]


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _tokens(label: str, n: int) -> list[str]:
    if label == "JAM":
        return ["JAM"] * n
    return [tok.rstrip("0123456789") for tok in label.split()]


def timeline_plot(rec: Recording, observed: list[str], predicted: list[str], path: Path) -> Path:
    """Save a per-contact timeline (observed tokens as points, predicted sets as bands)."""
    plt = _plt()
    P = len(rec.pair_names)
    fig, axes = plt.subplots(P, 1, figsize=(7, 1.6 * P + 0.6), sharex=True, squeeze=False)
    obs = np.array([_tokens(o, P) for o in observed]) if observed else np.zeros((0, P))
    for j, ax in enumerate(axes[:, 0]):
        for label in predicted:
            tok = _tokens(label, P)[j]
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


def animation_gif(rec: Recording, observed: list[str], polygon: np.ndarray, path: Path,
                  frames: int = 30, finger_radius: float = 0.0) -> Path:
    """Save a GIF drawn from recorded workpiece and fingertip poses and contact points."""
    plt = _plt()
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
        toks = _tokens(observed[k], P) if observed else ["B"] * P
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
