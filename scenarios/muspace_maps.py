"""Friction-space maps: Examples 4.1 and 4.3 (Figs. 3, 6) and the rod of Sec. 5.1 (Fig. 8)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planner.fileio import atomic_write_json
from planner.io import load_system
from planner.model import System
from planner.muspace import mu_grid
from scenarios.registry import Scenario, register

DATA = Path(__file__).resolve().parent / "data"
SLICES = (0.0, 0.2, 0.4, 0.6)


def _maps(system: System, out_dir: Path, name: str, base: list[float], n: int) -> dict[str, Any]:
    from planner.plot_muspace import plot_slices

    out_dir.mkdir(parents=True, exist_ok=True)
    if system.n_contacts == 2:
        grids, titles = [mu_grid(system, (0, 1), base, n=n)], [name]
    else:
        grids = [mu_grid(system, (0, 1), [base[0], base[1], m3], n=n) for m3 in SLICES]
        titles = [f"mu_3={m3}" for m3 in SLICES]
    atomic_write_json(out_dir / f"{name}_muspace.json", {"slices": [g.to_dict() for g in grids]})
    plot_slices(grids, titles, out_dir / f"{name}_muspace.png")
    summary = {"scenario": name, "mode_sets": sorted({s for g in grids
                                                      for s in g.mode_sets().ravel()})}
    atomic_write_json(out_dir / "summary.json", summary)
    return summary


def _example(name: str, n: int = 150, **_: Any) -> Any:
    return lambda out_dir, **opt: _maps(load_system(DATA / f"{name}.json"), Path(out_dir),
                                        name, [0.2, 0.3, 0.1], int(opt.get("n", n)))


def rod(l1: float = 0.3, l2: float = 0.7) -> System:
    """Thin rod on two supports at -l1, +l2 approaching each other (Sec. 5.1)."""
    return System.from_contacts(points=[[-l1, 0], [l2, 0]], normals=[[0, 1], [0, 1]],
                                mu=[0.3, 0.3], external_wrench=[0, -1, 0],
                                contact_velocities=[[0, -1], [0, 1]])  # (n, t), t = -x


register(Scenario(name="muspace_ex41", summary="mu-space map of Example 4.1 (3S, RS, jam)",
                  reference="Sec. 4.1, Fig. 3", expect="info", run=_example("example_4_1")))
register(Scenario(name="muspace_ex43", summary="mu-space map of Example 4.3 (four modes)",
                  reference="Sec. 4.3, Fig. 6", expect="info", run=_example("example_4_3")))
register(Scenario(name="muspace_rod", summary="rod: R1 S2 / S1 R2 split at l1 mu2 = l2 mu1",
                  reference="Sec. 5.1, Fig. 8", expect="info",
                  run=lambda out_dir, **opt: _maps(rod(), Path(out_dir), "rod", [0.3, 0.3],
                                                   int(opt.get("n", 150)))))
