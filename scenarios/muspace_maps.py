"""Friction-space maps: Examples 4.1 and 4.3 (Figs. 3, 6) and the rod of Sec. 5.1 (Fig. 8).

Each scenario writes ``<name>_muspace.json`` (a :class:`planner.muspace.MuSpaceMap`: labelled
grids plus closed-form inequalities), ``<name>_muspace.png`` (slice maps with closed-form
boundaries) and ``summary.json``, and checks what the paper says about its figure
(``passed``/``reason``).  Options: ``n`` (grid points per axis, default 150).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.fileio import atomic_write_json
from planner.io import load_system
from planner.model import System
from planner.muspace import JAM, MuSpaceMap, mu_grid, muspace_map
from scenarios.registry import Scenario, register

DATA = Path(__file__).resolve().parent / "data"
SLICES = (0.0, 0.2, 0.4, 0.6)
BASE_MU = (0.2, 0.3, 0.1)


def _write(m: MuSpaceMap, out_dir: Path, name: str, checks: dict[str, bool],
           extra: dict[str, Any] | None = None, decorate: Any = None) -> dict[str, Any]:
    from planner.plot_muspace import plot_slices

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


def run_example_41(out_dir: Path, n: int = 150, **_: Any) -> dict[str, Any]:
    """Fig. 3: the 3S region shrinks as mu_3 grows, the R1 S2 region does not change, jam."""
    system = load_system(DATA / "example_4_1.json")
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
    return _write(m, Path(out_dir), "example_4_1", checks, {"area_3s": area_3s})


def run_example_43(out_dir: Path, n: int = 150, **_: Any) -> dict[str, Any]:
    """Fig. 6: four modes, three feasible at once over a large region, jam near the origin."""
    system = load_system(DATA / "example_4_3.json")
    m = muspace_map(system, (0, 1), BASE_MU, n=int(n), sliced=2, slice_values=SLICES)
    labels = sorted({lab for g in m.grids for lab in g.labels})
    three = [float(np.mean(g.feasible.sum(axis=1) >= 3)) for g in m.grids]
    near = mu_grid(system, (0, 1, 2), BASE_MU, (0.0, 0.05), n=6)
    checks = {
        "four distinct modes": len(labels) == 4,
        "three modes at once over > 25 % of a slice": max(three) > 0.25,
        "jam in the cube [0, 0.05]^3 at the origin": bool(not near.feasible.any()),
    }
    return _write(m, Path(out_dir), "example_4_3", checks,
                  {"modes": labels, "fraction_three_modes": three})


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
                  reference="Sec. 4.1, eq. 37, Fig. 3", expect="info", run=run_example_41))
register(Scenario(name="muspace_ex43", summary="mu-space map of Example 4.3 (four modes)",
                  reference="Sec. 4.3, eq. 42, Fig. 6", expect="info", run=run_example_43))
register(Scenario(name="muspace_rod", summary="rod: R1 S2 / S1 R2 split at l1 mu2 = l2 mu1",
                  reference="Sec. 5.1, Fig. 8", expect="info", run=run_rod))
