"""Guaranteed torque regions checked by dense friction sampling on random hands.

Random hands (:func:`planner.sweeps.random_hands.random_hand`: shipped hand files scaled,
mirrored, jittered, with random friction boxes -- half of them drawn in ``[0.3, 0.9]``) are
planned with :func:`planner.plan.segment_planner.plan_segment` (``partial=True``: the waypoints
a region exists for).  At every waypoint, torques inside the region -- its Chebyshev centre, the
held command, and points along random and axis directions 60-98 % of the way to the boundary
(the last ones next to the vertices) -- are checked at friction vectors of the box (corners,
a grid and uniform samples; one shared coefficient when the plan's model is ``common``) with
:func:`planner.predict.feasibility.feasible_modes`, the full mode enumeration, independent of
the region's rows: the claimed mode must be the only feasible one.  A *violation* is any
sample where it is not.

Tightness (and a proof that the check can fail): from the centre, a torque just past the
nearest face that is a mode boundary (``d * f``, ``d`` the distance to the face, ``f`` = 1.02,
1.1, 1.5, 2, 4; the region's ``open_rows`` -- the box of commands, a one-sided band's replaced
infinite end -- are skipped, and a region with no other face is counted as ``outside_open``) is
checked the same way; the smallest ``f`` at which some sample admits a rival or loses the mode is
reported per waypoint (None: not found up to 4; the region is an inner approximation, one
failing row per rival).  Nothing is asserted here; tests/planner/test_region_check.py holds a short
version and the mutation test.

    PYTHONPATH=. python benchmarks/region_check.py --seed 0 --hands 12 \
        --out benchmarks/results/region_check.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, QsplanError
from planner.files.atomic import atomic_write_json
from planner.files.hand_file import hand_file_from_dict
from planner.plan.bounds import box_points
from planner.plan.model import Segment
from planner.plan.partition import joint_inputs
from planner.plan.segment_planner import plan_segment
from planner.predict.feasibility import feasible_modes
from planner.sweeps.random_hands import random_hand

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ("three_finger_hand", "prismatic_finger_hand", "two_link_finger_hand",
             "table_push_hand", "two_finger_hand")
FACTORS = (1.02, 1.1, 1.5, 2.0, 4.0)
REDRAWS = 5


def template(name: str) -> dict[str, Any]:
    return json.loads((ROOT / "scenarios" / "data" / f"{name}.json").read_text())


def torques_inside(A: np.ndarray, b: np.ndarray, c: np.ndarray, rng: np.random.Generator,
                   n: int) -> list[np.ndarray]:
    """Centre ``c``, points toward the ``2 p`` axis directions at 98 % of the way to the
    boundary (near the vertices of a box-like region) and ``n`` random directions at 60-98 %."""
    p = len(c)
    if p == 0:
        return [c]
    dirs = [s * e for e in np.eye(p) for s in (1.0, -1.0)]
    dirs += [d / np.linalg.norm(d) for d in rng.standard_normal((n, p))]
    fr = [0.98] * (2 * p) + list(rng.uniform(0.6, 0.98, n))
    out = [c]
    for d, f in zip(dirs, fr):
        Ad, slack = A @ d, b - A @ c
        t = np.min(np.where(Ad > 0, slack / np.where(Ad > 0, Ad, 1.0), np.inf))
        if np.isfinite(t):
            out.append(c + f * t * d)
    return out


def frictions(lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator, n: int,
              model: str) -> np.ndarray:
    """``(m, n_c)`` friction vectors: the box's corners, a 3-point grid (capped at 81) and ``n``
    uniform samples (``box``); or a shared coefficient at the ends and ``n`` samples."""
    if model == "common":
        m = np.concatenate([[lo[0], hi[0]], rng.uniform(lo[0], hi[0], n)])
        return np.repeat(m[:, None], len(lo), axis=1)
    corners, grid = box_points(lo, hi, 3)
    if len(grid) > 81:
        grid = grid[rng.choice(len(grid), 81, replace=False)]
    return np.concatenate([corners, grid, rng.uniform(lo, hi, size=(n, len(lo)))])


def bad_samples(system: Any, E: tuple[int, ...], tau: np.ndarray, mus: np.ndarray,
                claim: str) -> list[tuple[list[float], list[str]]]:
    """The friction samples at which ``claim`` is not the only feasible mode at ``tau``."""
    inputs = np.array(system.joint_inputs)
    inputs[list(E)] = tau
    s = system.with_joint_inputs(inputs)
    out = []
    for mu in mus:
        labels = feasible_modes(s, mu).labels
        if labels != [claim]:
            out.append((mu.tolist(), list(labels)))
    return out


def region_model(rp: Segment, lo: np.ndarray, hi: np.ndarray) -> str:
    """The friction set a planned segment's regions hold for: one shared coefficient with one
    effort joint and one interval for every contact (the common model's band), else the box."""
    one = len(rp.effort_joints) == 1 and np.all(lo == lo[0]) and np.all(hi == hi[0])
    return "common" if one else "box"


def check_plan(hand: Any, rp: Segment, lo: np.ndarray, hi: np.ndarray,
               rng: np.random.Generator, *, n_tau: int = 4, n_mu: int = 40,
               outside: bool = True) -> dict[str, Any]:
    """Counts and violations of one planned segment (module docstring)."""
    V, E = rp.velocity_joints, rp.effort_joints
    model = region_model(rp, lo, hi)
    row: dict[str, Any] = {"claim": rp.claim, "p": len(E), "model": model,
                           "waypoints": len(rp.waypoints), "torques": 0, "samples": 0,
                           "violations": [], "outside_factor": []}
    for w, reg in zip(rp.waypoints, rp.regions, strict=True):
        base = hand.system(w.q, 0.0, joint_inputs(hand, V, w.velocity_commands))
        mus = frictions(lo, hi, rng, n_mu, model)
        taus = torques_inside(reg.A, reg.b, reg.centre, rng, n_tau) + [
            np.array(w.torque_commands)]
        for tau in taus:
            bad = bad_samples(base, E, tau, mus, rp.claim)
            row["torques"] += 1
            row["samples"] += len(mus)
            row["violations"] += [{"t": w.t, "tau": tau.tolist(), "mu": m, "labels": lab}
                                  for m, lab in bad]
        if outside and len(E):
            norms = np.linalg.norm(reg.A, axis=1)
            dist = (reg.b - reg.A @ reg.centre) / norms
            dist[list(reg.open_rows)] = np.inf  # no mode boundary there: nothing to catch
            if not np.isfinite(dist).any():
                row["outside_open"] = row.get("outside_open", 0) + 1
                continue
            k = int(np.argmin(dist))
            found = None
            for f in FACTORS:
                tau = reg.centre + f * dist[k] * reg.A[k] / norms[k]
                if bad_samples(base, E, tau, mus, rp.claim):
                    found = f
                    break
            row["outside_factor"].append(found)
    return row


def plan_hand(d: dict[str, Any]) -> tuple[Any, Segment, np.ndarray, np.ndarray]:
    hf = hand_file_from_dict(d)
    s, n_c = hf.segment, hf.hand.n_contacts
    mu = [list(p) for p in hf.mu_interval]
    rp = plan_segment(hf.hand, hf.q0, data=d, drive=s.drives, speed=s.speeds, mode=s.mode,
                      mu=mu if len(mu) > 1 else mu[0],
                      model="independent" if len(mu) > 1 else "common", max_time=s.max_time,
                      steps=s.steps, waypoints=min(s.waypoints, 11), partial=True)
    lo = np.array([p[0] for p in mu] * (n_c if len(mu) == 1 else 1))
    hi = np.array([p[1] for p in mu] * (n_c if len(mu) == 1 else 1))
    return hf.hand, rp, lo, hi


def run(seed: int, hands: int, *, n_tau: int = 4, n_mu: int = 40,
        outside: bool = True) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    for h in range(hands):
        name = TEMPLATES[h % len(TEMPLATES)]
        mu_range = (0.3, 0.9) if h % 2 else (0.0, 0.4)
        entry: dict[str, Any] = {"hand": h, "template": name, "redrawn": 0}
        for _ in range(REDRAWS):  # a jittered workpiece may be non-convex: draw again
            d = random_hand(template(name), rng, mu_range=mu_range)
            entry["mu"] = d["mu"]["interval"]
            try:
                hand, rp, lo, hi = plan_hand(d)
                break
            except FileFormatError:
                entry["redrawn"] += 1
            except QsplanError as exc:
                entry["plan"] = f"{type(exc).__name__}: {str(exc)[:160]}"
                break
        if "plan" in entry or entry["redrawn"] == REDRAWS:
            entry.setdefault("plan", "no valid draw")
            rows.append(entry)
            continue
        entry["plan"] = "partial" if rp.shortfall else "full"
        entry.update(check_plan(hand, rp, lo, hi, rng, n_tau=n_tau, n_mu=n_mu, outside=outside))
        rows.append(entry)
    planned = [r for r in rows if "claim" in r]
    found = [f for r in planned for f in r["outside_factor"]]
    summary = {
        "seed": seed, "hands": hands, "plans": len(planned),
        "waypoints": sum(r["waypoints"] for r in planned),
        "torque_points": sum(r["torques"] for r in planned),
        "friction_samples": sum(r["samples"] for r in planned),
        "violations": sum(len(r["violations"]) for r in planned),
        "redrawn": sum(r["redrawn"] for r in rows),
        "outside_checked": len(found),
        "outside_open": sum(r.get("outside_open", 0) for r in planned),
        "outside_caught": sum(f is not None for f in found),
        "outside_factor_max": max((f for f in found if f is not None), default=None),
        "seconds": round(time.perf_counter() - t0, 1),
    }
    return {"summary": summary, "rows": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hands", type=int, default=12)
    ap.add_argument("--torques", type=int, default=4, help="random interior torques per waypoint")
    ap.add_argument("--samples", type=int, default=40, help="uniform friction samples per torque")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    res = run(a.seed, a.hands, n_tau=a.torques, n_mu=a.samples)
    for r in res["rows"]:
        if "claim" in r:
            print(f"{r['hand']:3d} {r['template']:22s} {r['claim']:24s} p={r['p']} "
                  f"{r['model']:6s} wp={r['waypoints']:3d} samples={r['samples']:6d} "
                  f"violations={len(r['violations'])} outside={r['outside_factor']}")
        else:
            print(f"{r['hand']:3d} {r['template']:22s} no plan: {r['plan'][:70]}")
    print(json.dumps(res["summary"]))
    if a.out:
        atomic_write_json(a.out, res)


if __name__ == "__main__":
    main()
