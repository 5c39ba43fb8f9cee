"""Draw the pictures of the README and the tutorial into docs/images/ (committed PNGs).

    PYTHONPATH=. python scripts/make_readme_figure.py [--out docs/images]

* ``readme.png``: (a) Example 4.1 of Trinkle & Zeng (1994): the workpiece bounded by the
  contact tangents of eq. (37), inward normals and the fingers' velocities ``J_i thetadot``;
  (b) its friction space at ``mu_3 = 0.1`` labelled by feasible mode set (Fig. 3) with the
  general test (eqs. 26-28); (c) the two-finger plan of Sec. 5.2: the torque band that
  guarantees the 4S mode for every ``mu`` in ``[0, 0.2]`` (Fig. 13) and the planned torque.
* ``tutorial_disc_muspace.png``: exactly what ``qsplan muspace disc.json --vary 2,3 --n 100``
  draws for the tutorial's system (the file is read from docs/tutorial.md).

Everything is computed by the library; nothing is hand-drawn. Runs in ~10 s.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def tutorial_system_text() -> str:
    """The JSON block marked ``<!-- test: file disc.json -->`` in docs/tutorial.md."""
    text = (ROOT / "docs" / "tutorial.md").read_text()
    m = re.search(r"<!-- test: file disc\.json -->\s*```json\n(.*?)```", text, re.S)
    if not m:
        raise SystemExit("docs/tutorial.md: expected a block marked "
                         "'<!-- test: file disc.json -->', found none")
    return m.group(1)


def draw_geometry(ax, system) -> None:
    from sim.scenes.shapes import workpiece_polygon

    pts, nrm = np.asarray(system.points), np.asarray(system.normals)
    poly = workpiece_polygon(pts, nrm, 1.25 * float(np.max(np.linalg.norm(pts, axis=1))))
    ax.fill(*np.vstack([poly, poly[:1]]).T, color="#dddddd", ec="black", lw=1)
    vel = np.asarray(system.joint_inputs).reshape(-1, 2)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    scale = 0.25 * float(np.ptp(poly[:, 0]))
    for i, (r, n, t, v) in enumerate(zip(pts, nrm, tng, vel)):
        ax.plot(*r, "o", color="tab:red", zorder=3)
        ax.annotate("", r + 0.6 * scale * n, r, arrowprops={"arrowstyle": "->", "color": "0.4"})
        vw = v[0] * n + v[1] * t
        ax.annotate("", r + scale * vw, r, arrowprops={"arrowstyle": "-|>", "color": "tab:red",
                                                       "lw": 1.5})
        ax.text(*(r - 0.35 * scale * n), str(i + 1), ha="center", va="center")
    ax.plot(0, 0, "k+", ms=10)
    ax.annotate("", (0, -scale), (0, 0), arrowprops={"arrowstyle": "-|>", "color": "black"})
    ax.set_aspect("equal")
    ax.set_title("Example 4.1 (eq. 37): fingers push\n(red: $J_i\\dot\\theta$, grey: normals)",
                 fontsize=9)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_muspace(ax, system, n: int = 120) -> None:
    from matplotlib.colors import ListedColormap

    from planner.friction.muspace import mu_grid

    grid = mu_grid(system, (0, 1), [0.2, 0.3, 0.1], (0.0, 1.0), n=n)
    sets = grid.mode_sets()
    names = sorted(set(sets.ravel()), key=lambda s: (s == "jam", s))
    colours = ["#9ecae1", "#fdae6b", "#a1d99b", "#bcbddc", "#fc9272"][: len(names)]
    colours = [("#444444" if s == "jam" else c) for s, c in zip(names, colours)]
    index = np.vectorize(names.index)(sets)
    ax.imshow(index.T, origin="lower", extent=(0, 1, 0, 1), cmap=ListedColormap(colours),
              vmin=-0.5, vmax=len(names) - 0.5, interpolation="nearest")
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(color=c, label=s) for s, c in zip(names, colours)], fontsize=7,
              loc="upper left", framealpha=0.9)
    ax.set_xlabel("$\\mu_1$")
    ax.set_ylabel("$\\mu_2$")
    ax.set_title("its friction space at $\\mu_3 = 0.1$ (Fig. 3):\nwhich mode happens", fontsize=9)


def draw_plan(ax) -> bool:
    """Torque band of the two-finger plan; False (and a note) when ``qsplan plan`` is missing."""
    from qsplan.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "plan.json"
        try:
            code = main(["-q", "plan", "two_finger_hand", "--mu", "0:0.2", "--out", str(path)])
        except SystemExit as exc:  # argparse: no such subcommand
            code = exc.code
        if code != 0 or not path.exists():
            ax.text(0.5, 0.5, "qsplan plan not available", ha="center", transform=ax.transAxes)
            return False
        plan = json.loads(path.read_text())
    wp = plan["waypoints"]
    t = np.array([w["t"] for w in wp])
    band = np.array([w["band"] for w in wp]) * 1e3
    tau = np.array([w["torque_command"] for w in wp]) * 1e3
    ax.fill_between(t, band[:, 0], band[:, 1], color="#a1d99b", label="guarantees the claim")
    ax.plot(t, tau, "k-", lw=1.5, label="planned torque")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("effort joint torque [mN m]")
    ax.set_title(f"two-finger plan (Sec. 5.2, Fig. 13): {plan['claim']}\n"
                 f"for every $\\mu$ in [{plan['mu']['intervals'][0][0]:g}, "
                 f"{plan['mu']['intervals'][0][1]:g}]", fontsize=9)
    ax.legend(fontsize=7, loc="best")
    return True


def make_readme_figure(out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from planner.files.atomic import save_figure
    from planner.files.system_file import load_system

    system = load_system(ROOT / "scenarios" / "data" / "example_4_1.json")
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    draw_geometry(axes[0], system)
    draw_muspace(axes[1], system)
    draw_plan(axes[2])
    fig.tight_layout()
    path = save_figure(fig, out / "readme.png", dpi=100)
    plt.close(fig)
    return path


def make_tutorial_figure(out: Path) -> Path:
    from planner.files.atomic import atomic_write_bytes
    from qsplan.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        system = Path(tmp) / "disc.json"
        system.write_text(tutorial_system_text())
        code = main(["-q", "muspace", str(system), "--vary", "2,3", "--n", "100", "--out",
                     str(Path(tmp) / "disc_mu")])
        if code != 0:
            raise SystemExit(f"qsplan muspace failed with exit code {code}")
        return atomic_write_bytes(out / "tutorial_disc_muspace.png",
                                  (Path(tmp) / "disc_mu" / "muspace.png").read_bytes())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "images"), help="output folder")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in (make_readme_figure(out), make_tutorial_figure(out)):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
