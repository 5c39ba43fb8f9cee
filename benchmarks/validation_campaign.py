"""Validation campaign: seeded random friction points and random systems, both engines.

Cases (each simulated with :func:`sim.system_run.simulate_system`, the machinery of
``qsplan simulate``):

* ``ex41`` / ``ex43``: Examples 4.1 / 4.3 (eqs. 37, 42) scaled to 0.2 m / 2 m scenes
  (:func:`sim.scenes.paper.scaled_system`) at friction drawn uniformly from [0.05, 1] per contact;
* ``box``: random boxes on a table pushed by one frictionless finger (width, height in
  [0.05, 0.15] m, push height in [0.1, 0.9] of the height, table friction in [0.1, 1]) -- a
  system with ``workpiece`` geometry and ``environment`` contacts.

Every run is also judged against the prediction at a second random friction point whose
predicted mode set shares no mode with the first's (a negative control: agreement there is a
false agreement). A point is
*near a boundary* when the predicted mode set changes with any one coefficient moved by
``+-NEAR`` (0.03); those are counted apart.

    python benchmarks/validation_campaign.py --points 8 --seed 1
    python benchmarks/validation_campaign.py --points 200 --json out.json   # the full campaign

Rates are printed per case, engine and near/away; the full campaign (>= 200 points per example,
>= 50 systems, ~3-5 s per run) takes hours on two cores.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from typing import Any

import numpy as np

from planner.files.system_file import load_system
from planner.model.system import System
from planner.model.workpiece import WorkpieceGeometry
from planner.predict.feasibility import feasible_modes
from scenarios.registry import DATA_DIR
from sim.scenes.paper import scaled_system
from sim.system_run import judge_recording, simulate_system

NEAR = 0.03
SCALES = {"ex41": ("example_4_1", 0.01), "ex43": ("example_4_3", 0.1)}


def labels(system: System, mu: np.ndarray) -> frozenset[str]:
    return frozenset(feasible_modes(system.with_mu(mu)).labels)


def near_boundary(system: System, mu: np.ndarray) -> bool:
    """The predicted mode set changes when one coefficient moves by ``+-NEAR``."""
    base = labels(system, mu)
    for i in range(len(mu)):
        for d in (-NEAR, NEAR):
            m = mu.copy()
            m[i] = max(0.0, m[i] + d)
            if labels(system, m) != base:
                return True
    return False


def random_box(rng: np.random.Generator) -> tuple[System, np.ndarray]:
    w, h = rng.uniform(0.05, 0.15, size=2)
    y = rng.uniform(0.1, 0.9) * h
    mu_t = rng.uniform(0.1, 1.0)
    mass = 0.1
    weight = 9.81 * mass
    system = System.from_contacts(
        points=[[0.0, 0.0], [w, 0.0], [0.0, y]],
        normals=[[0.0, 1.0], [0.0, 1.0], [1.0, 0.0]],
        mu=[mu_t, mu_t, 0.0],
        external_wrench=(0.0, -weight, -weight * w / 2),
        contact_velocities=[[0.0, 0.0], [0.0, 0.0], [0.001, 0.0]],
        workpiece=WorkpieceGeometry(np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]), mass),
        environment=[True, True, False],
    )
    return system, np.array([mu_t, mu_t, 0.0])


def draw(case: str, rng: np.random.Generator) -> tuple[System, np.ndarray, np.ndarray]:
    """``(system, mu, control mu)``; the control's predicted mode set shares no mode with
    ``mu``'s (``mu`` itself when none is found in 50 draws: no control for that point)."""
    if case == "box":
        system, mu = random_box(rng)
        for _ in range(50):
            c = rng.uniform(0.1, 1.0)
            ctrl = np.array([c, c, 0.0])
            if not labels(system, ctrl) & labels(system, mu):
                return system, mu, ctrl
        return system, mu, mu
    data, scale = SCALES[case]
    system = scaled_system(load_system(DATA_DIR / f"{data}.json"), scale)
    mu = rng.uniform(0.05, 1.0, size=system.n_contacts)
    for _ in range(50):
        ctrl = rng.uniform(0.05, 1.0, size=system.n_contacts)
        if not labels(system, ctrl) & labels(system, mu):
            return system, mu, ctrl
    return system, mu, mu


def run_point(case: str, engine: str, system: System, mu: np.ndarray, ctrl: np.ndarray
              ) -> dict[str, Any]:
    t0 = time.perf_counter()
    res = simulate_system(system, engine, mu=mu)
    p = res.summary["parameters"]
    row: dict[str, Any] = {
        "case": case, "engine": engine, "mu": mu.tolist(), "status": res.verdict.outcome.value,
        "predicted": res.summary["predicted"]["labels"],
        "observed": res.summary["observed"]["counts"], "reason": res.verdict.reason,
        "near_boundary": near_boundary(system, mu), "control_mu": ctrl.tolist(),
    }
    if not np.array_equal(ctrl, mu) and res.verdict.outcome.value != "fault":
        scale = p["speed_scale"]
        judged = feasible_modes(system.with_mu(ctrl).with_joint_inputs(
            np.asarray(system.joint_inputs) * scale))
        load = float(np.linalg.norm(np.asarray(system.g_obj)[:2]))
        v, _, _ = judge_recording(res.recording, judged, engine, p["drive_speed_m_per_s"],
                                  load, p["length"])
        row["control_status"] = v.outcome.value
    row["wall_s"] = time.perf_counter() - t0
    return row


def table(rows: list[dict[str, Any]]) -> str:
    out = ["| case | engine | where | n | agreed | disagreed | inconclusive | fault | "
           "false agreement on control |", "|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["case"], r["engine"], r["near_boundary"]) for r in rows})
    for case, engine, near in keys:
        sel = [r for r in rows if (r["case"], r["engine"], r["near_boundary"]) == (case, engine,
                                                                                   near)]
        c = Counter(r["status"] for r in sel)
        ctrl = [r for r in sel if "control_status" in r]
        false = sum(r["control_status"] == "agreed" for r in ctrl)
        n = len(sel)
        out.append(f"| {case} | {engine} | {'near boundary' if near else 'away'} | {n} | "
                   + " | ".join(f"{c[s]} ({c[s] / n:.0%})" for s in
                                ("agreed", "disagreed", "inconclusive", "fault"))
                   + f" | {false} of {len(ctrl)} |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=8, help="points per case and engine")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--engines", default="pymunk,mujoco")
    ap.add_argument("--cases", default="ex41,ex43,box")
    ap.add_argument("--json", help="write every row to this file")
    args = ap.parse_args()
    rows = []
    for case in args.cases.split(","):
        rng = np.random.default_rng([args.seed, sum(map(ord, case))])
        points = [draw(case, rng) for _ in range(args.points)]
        for engine in args.engines.split(","):
            for system, mu, ctrl in points:
                r = run_point(case, engine, system, mu, ctrl)
                rows.append(r)
                print(f"{case} {engine} mu={np.round(mu, 3).tolist()} {r['status']:12s} "
                      f"control {r.get('control_status', '-'):10s} "
                      f"{'near' if r['near_boundary'] else 'away'} pred {r['predicted']} "
                      f"obs {r['observed']} [{r['wall_s']:.1f} s]", flush=True)
    print(table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
