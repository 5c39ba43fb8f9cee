"""Friction-space maps: Examples 4.1 and 4.3 (Figs. 3, 6) and the rod of Sec. 5.1 (Fig. 8).

Each scenario writes ``<name>_muspace.json`` (a :class:`planner.friction.muspace.MuSpaceMap`:
labelled grids plus closed-form inequalities), ``<name>_muspace.png`` (slice maps with closed-form
boundaries) and ``summary.json`` (Examples 4.1 and 4.3 also ``<name>_muspace3d.json``, the
3-D decomposition of the unit cube), and checks what the paper says about its figure
(``passed``/``reason``).  Options: ``n`` (grid points per axis of a slice, default 150), ``n3``
(per axis of the 3-D grid, default 21).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.files.atomic import atomic_write_json
from planner.files.system_file import load_system
from planner.friction.muspace import JAM, MuSpaceMap, muspace_map
from planner.model.system import System
from scenarios.registry import Expect, Scenario, register

DATA = Path(__file__).resolve().parent / "data"
SLICES = (0.0, 0.2, 0.4, 0.6)
#: Example 4.3: slices where the empty region near the origin shows (small mu_3) and where
#: S+1 B2 R3 appears (mu_3 = 0.6): all four modes of Fig. 6.
SLICES_43 = (0.0, 0.15, 0.3, 0.6)
BASE_MU = (0.2, 0.3, 0.1)


def _cube_summary(system: System, out_dir: Path, name: str, n: int) -> dict[str, Any]:
    """3-D decomposition of the unit cube of (mu_1, mu_2, mu_3), written as
    ``<name>_muspace3d.json``: region fractions, the fraction with >= 3 modes at once and the
    side of the largest all-jam cube at the origin (grid resolution ``1 / (n - 1)``)."""
    m = muspace_map(system, (0, 1, 2), BASE_MU, n=n)
    atomic_write_json(out_dir / f"{name}_muspace3d.json", m.to_dict())
    g = m.grids[0]
    count = g.feasible.sum(axis=1).reshape(g.shape)
    side = 0.0
    for a in range(1, n + 1):
        if count[:a, :a, :a].any():
            break
        side = float(g.axes[0][a - 1])
    return {"grid_3d": [n, n, n], "fractions_3d": g.region_fractions(),
            "fraction_3d_three_modes": float(np.mean(count >= 3)),
            "jam_cube_side_at_origin": side}


def _outputs(name: str, cube: bool = False) -> tuple[str, ...]:
    """What :func:`_write` (and :func:`_cube_summary` with ``cube``) write for ``name``."""
    return (f"{name}_muspace.json", f"{name}_muspace.png", "summary.json",
            *((f"{name}_muspace3d.json",) if cube else ()))


def _write(m: MuSpaceMap, out_dir: Path, name: str, checks: dict[str, bool],
           extra: dict[str, Any] | None = None, decorate: Any = None) -> dict[str, Any]:
    from planner.plots.muspace import plot_slices

    out_dir.mkdir(parents=True, exist_ok=True)
    json_path = atomic_write_json(out_dir / f"{name}_muspace.json", m.to_dict())
    panels, titles = m.panels()
    png = plot_slices(panels, titles, out_dir / f"{name}_muspace.png",
                      closed_forms=m.closed_forms, decorate=decorate)
    failed = [k for k, ok in checks.items() if not ok]
    summary = {
        "scenario": name, "engine": None, "expect": "info",
        "status": "info", "passed": not failed, "agreement": None,
        "reason": "all checks hold" if not failed else f"failed: {', '.join(failed)}",
        "checks": checks,
        "mode_sets": sorted({s for g in m.grids for s in g.mode_sets().ravel()}),
        "files": {"json": str(json_path), "png": str(png)},
        **(extra or {}),
    }
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


def run_example_41(out_dir: Path, n: int = 150, n3: int = 21, **_: Any) -> dict[str, Any]:
    """Fig. 3: the 3S region shrinks as mu_3 grows, the R1 S2 region does not change, jam."""
    system = load_system(DATA / "example_4_1.json")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    cube = _cube_summary(system, out_dir, "example_4_1", int(n3))
    m = muspace_map(system, (0, 1), BASE_MU, n=int(n), sliced=2, slice_values=SLICES)
    three_s, rs = "S+1 S-2 S-3", "R1 S-2 B3"
    area_3s = [float(g.feasible[:, g.labels.index(three_s)].mean()) if three_s in g.labels
               else 0.0 for g in m.grids]
    rs_masks = [g.feasible[:, g.labels.index(rs)] for g in m.grids]
    checks = {
        "3S region shrinks as mu_3 grows": bool(np.all(np.diff(area_3s) <= 0)
                                                and area_3s[-1] < area_3s[0]),
        "R1 S-2 B3 region unchanged by mu_3": all(np.array_equal(rs_masks[0], r)
                                                   for r in rs_masks),
        "jam region present": all(JAM in g.mode_sets() for g in m.grids),
    }
    return _write(m, out_dir, "example_4_1", checks, {"area_3s": area_3s, **cube})


def run_example_43(out_dir: Path, n: int = 150, n3: int = 21, **_: Any) -> dict[str, Any]:
    """Fig. 6: four modes, three feasible at once over a large region, nothing (jam) near the
    origin of friction space (Sec. 4.3)."""
    system = load_system(DATA / "example_4_3.json")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    m = muspace_map(system, (0, 1), BASE_MU, n=int(n), sliced=2, slice_values=SLICES_43)
    labels = sorted({lab for g in m.grids for lab in g.labels})
    three = [float(np.mean(g.feasible.sum(axis=1) >= 3)) for g in m.grids]
    cube = _cube_summary(system, out_dir, "example_4_3", int(n3))
    checks = {
        "four distinct modes": len(labels) == 4,
        "three modes at once over > 25 % of a slice": max(three) > 0.25,
        "three modes at once over > 50 % of the unit cube": cube["fraction_3d_three_modes"] > 0.5,
        "jam in a cube of side >= 0.1 at the origin": cube["jam_cube_side_at_origin"] >= 0.1,
    }
    return _write(m, out_dir, "example_4_3", checks,
                  {"modes": labels, "fraction_three_modes": three, **cube})


def rod(l1: float = 0.3, l2: float = 0.7) -> System:
    """Thin rod on two supports at -l1, +l2 approaching each other (Sec. 5.1, Fig. 7)."""
    return System.from_contacts(points=[[-l1, 0], [l2, 0]], normals=[[0, 1], [0, 1]],
                                mu=[0.3, 0.3], external_wrench=[0, -1, 0],
                                contact_velocities=[[0, -1], [0, 1]])  # (n, t), t = -x


def run_rod(out_dir: Path, n: int = 150, l1: float = 0.3, l2: float = 0.7,
            **_: Any) -> dict[str, Any]:
    """Fig. 8 without the static/kinetic rectangle (see scenarios/ruler_muspace.py)."""
    m = muspace_map(rod(l1, l2), (0, 1), (0.3, 0.3), n=int(n))
    g = m.grids[0]
    sets = g.mode_sets()
    m1, m2 = np.meshgrid(*g.axes, indexing="ij")
    gap = l2 * m1 - l1 * m2
    away = np.abs(gap) > 1e-9
    checks = {
        "R1 S-2 below l1 mu2 = l2 mu1": bool(np.all((sets == "R1 S-2")[away & (gap > 0)])),
        "S+1 R2 above l1 mu2 = l2 mu1": bool(np.all((sets == "S+1 R2")[away & (gap < 0)])),
    }
    return _write(m, Path(out_dir), "rod", checks)


register(Scenario(name="muspace_ex41", summary="mu-space map of Example 4.1 (3S, RS, jam)",
                  reference="Sec. 4.1, eq. 37, Fig. 3", expect=Expect.INFO, run=run_example_41,
                  outputs=_outputs("example_4_1", cube=True)))
register(Scenario(name="muspace_ex43", summary="mu-space map of Example 4.3 (four modes)",
                  reference="Sec. 4.3, eq. 42, Fig. 6", expect=Expect.INFO, run=run_example_43,
                  outputs=_outputs("example_4_3", cube=True)))
register(Scenario(name="muspace_rod", summary="rod: R1 S2 / S1 R2 split at l1 mu2 = l2 mu1",
                  reference="Sec. 5.1, Fig. 8", expect=Expect.INFO, run=run_rod,
                  outputs=_outputs("rod")))
