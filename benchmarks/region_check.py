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

The whole set (``--set MASS,COM,CONTACTS``; docs/planning.md, "Uncertainty beyond friction",
"Contact positions"): every random hand gets an ``uncertainty`` section -- mass ``m0 (1 +-
MASS)``, centre of mass ``c0 +- COM`` m in both body coordinates and, for a segment with one
effort-controlled joint (the only partition the planner guarantees over contact positions),
every contact ``+- CONTACTS`` m along its feature
(:func:`planner.sweeps.set_samples.with_uncertainty`) -- and is planned over friction box x that
set.  At each waypoint the plan's band (one effort joint: its ends pulled in by 1e-6 of the
width and its middle; a one-sided band's finite end pulled in and one end's size inside), region
(several: as above) or held configuration (none), and the held command, are checked at every
vertex of mass x centre of mass x contact offsets (:func:`planner.sweeps.set_samples.set_vertices`)
with up to 8 friction corners and ``--samples`` random friction points each, and at ``--inner``
random interior points with 2 corners and ``--samples`` random points, by
:func:`planner.sweeps.set_samples.set_violations`: the system rebuilt at the point from the moved
contact points (finger Jacobian by finite differences of the link frames), the full mode
enumeration, the claimed mode the only feasible one.  Mutations, one effort joint: each finite
end of the band moved out by 1 % of its width, and an effort in the part of the band computed
*without* the contact offsets (the load set alone) or *without* the load set (the offsets alone)
that the whole-set band excludes, are checked at every vertex with every friction corner (a
21-point diagonal for one shared coefficient) until a sample finds another mode ("caught").
The results file is rewritten after every hand; ``--limit`` stops a hand after that many
seconds (recorded as ``stopped``, with the waypoints it checked).

    PYTHONPATH=. python benchmarks/region_check.py --seed 0 --hands 16 \
        --set 0.05,0.001,0.0005 --waypoints 4 --inner 10 --samples 1 --limit 240 \
        --out benchmarks/results/region_check_set.json
"""

from __future__ import annotations

import argparse
import json
import signal
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import FileFormatError, QsplanError
from planner.files.atomic import atomic_write_json
from planner.files.hand_file import hand_file_from_dict
from planner.plan.bounds import box_points
from planner.plan.guarantee import Guarantee, guarantee
from planner.plan.intervals import Interval, subtract
from planner.plan.model import Segment
from planner.plan.offset_bounds import offset_box
from planner.plan.partition import joint_inputs
from planner.plan.polytope import torque_scale
from planner.plan.segment_planner import plan_segment
from planner.predict.feasibility import feasible_modes
from planner.sweeps.random_hands import random_hand
from planner.sweeps.set_samples import (
    friction_corners,
    set_interior,
    set_vertices,
    set_violations,
    with_uncertainty,
)

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ("three_finger_hand", "prismatic_finger_hand", "two_link_finger_hand",
             "table_push_hand", "two_finger_hand")
#: with ``--set``: the three-finger hand (two effort joints) is left out -- contact positions are
#: guaranteed with one effort joint, and its region over the load set (every friction corner x
#: vertex load) did not plan one hand within 10 minutes on the shared 2-core machine
SET_TEMPLATES = ("prismatic_finger_hand", "two_link_finger_hand", "two_finger_hand",
                 "table_push_hand")
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


def band_probes(piece: Interval, scale: float) -> list[float]:
    """Efforts inside one piece of a band: its ends pulled in by 1e-6 of the width and the
    middle; a one-sided piece: its finite end pulled in by 1e-6 of ``w`` and ``w`` inside,
    ``w`` the end's size or, when that is zero, ``scale`` (:func:`torque_scale`)."""
    a, b = piece.lower, piece.upper
    if np.isfinite(a) and np.isfinite(b):
        return [a + 1e-6 * (b - a), 0.5 * (a + b), b - 1e-6 * (b - a)]
    if not (np.isfinite(a) or np.isfinite(b)):
        return [-scale, 0.0, scale]
    end, sgn = (a, 1.0) if np.isfinite(a) else (b, -1.0)
    w = abs(end) or scale
    return [end + sgn * 1e-6 * w, end + sgn * w]


def widened_probes(pieces: Sequence[Interval], scale: float) -> list[float]:
    """Each finite end of ``pieces`` moved out by 1 % of its piece's width (of the end's size,
    or ``scale``, for a one-sided piece)."""
    out = []
    for p in pieces:
        w = p.upper - p.lower
        for end, sgn in ((p.lower, -1.0), (p.upper, 1.0)):
            if np.isfinite(end):
                out.append(end + sgn * 0.01 * (w if np.isfinite(w) else abs(end) or scale))
    return out


def wider_probes(wide: Guarantee, pieces: Sequence[Interval], scale: float) -> list[float]:
    """One effort in each part of ``wide``'s pieces overlapping ``pieces`` that ``pieces`` do
    not hold: its middle, or ``w`` past its finite end (``w`` as in :func:`band_probes`)."""
    out = []
    for p in wide.pieces:
        if not any(p.lower <= q.upper and q.lower <= p.upper for q in pieces):
            continue
        for d in subtract(p, list(pieces)):
            if d.upper - d.lower <= 1e-9 * max(abs(d.lower), abs(d.upper), scale):
                continue  # a shared end, not a wider band
            if np.isfinite(d.lower) and np.isfinite(d.upper):
                out.append(0.5 * (d.lower + d.upper))
            else:
                out += [x for x in band_probes(d, scale)[1:]]
    return out


def check_set_plan(hand: Any, rp: Segment, intervals: Sequence[Any], lo: np.ndarray,
                   hi: np.ndarray,
                   rng: np.random.Generator, *, n_inner: int = 20, n_mu: int = 2,
                   max_corners: int = 8, mutate: bool = True,
                   into: dict[str, Any] | None = None) -> dict[str, Any]:
    """The whole-set check of one planned segment (module docstring, ``--set``), filled into
    ``into`` (a new dict by default) as it goes: a run stopped mid-check keeps the waypoints
    done (``checked``)."""
    V, E = rp.velocity_joints, rp.effort_joints
    common = len(intervals) == 1
    mu = list(intervals[0]) if common else [list(p) for p in intervals]
    model = "common" if common else "independent"
    row = {} if into is None else into
    row.update({"claim": rp.claim, "p": len(E), "model": model,
                "waypoints": len(rp.waypoints), "checked": 0, "torques": 0, "samples": 0,
                "set_vertices": 0, "violations": [], "mutations": [], "exact": []})
    corners = friction_corners(lo, hi, common)
    grid = (np.linspace(lo, hi, 21) if common else corners)

    def random_mu(k: int) -> np.ndarray:
        u = rng.random((k, 1)) if common else rng.random((k, len(lo)))
        return lo + u * (hi - lo)

    def some_corners(k: int) -> np.ndarray:
        return corners if len(corners) <= k else corners[rng.choice(len(corners), k, False)]

    def record(w: Any, taus: list[Any], n: int, bad: list[Any]) -> None:
        row["torques"] += len(taus)
        row["samples"] += n
        row["violations"] += [{"t": w.t, "mass": v.point.mass, "com": v.point.com,
                               "offsets": v.point.offsets, "mu": v.mu, "tau": v.tau,
                               "labels": v.labels} for v in bad]

    for w, reg in zip(rp.waypoints, rp.regions, strict=True):
        q = np.asarray(w.q, dtype=float)
        joints = joint_inputs(hand, V, w.velocity_commands)
        system = hand.system(q, 0.0, joints)
        scale = torque_scale(system, tuple(int(j) for j in system.effort_joints))
        pieces: list[Interval] = []
        if len(E) == 1:  # the plan's band piece (its replaced infinite ends open again)
            hi_, lo_ = (np.inf if k in reg.open_rows else s * float(reg.b[k])
                        for k, s in ((0, 1.0), (1, -1.0)))
            pieces = [Interval(lo_, hi_)]
            taus: list[Any] = [[t] for t in band_probes(pieces[0], scale)]
            row["exact"].append(bool(reg.exact))
        elif len(E):
            taus = torques_inside(reg.A, reg.b, reg.centre, rng, 4)
        else:
            taus = [np.zeros(0)]
        taus.append(np.array(w.torque_commands))
        vertices = set_vertices(hand)
        row["set_vertices"] = len(vertices)
        n1, bad = set_violations(hand, q, joints, rp.claim, taus, vertices,
                                 lambda _p: np.concatenate([some_corners(max_corners),
                                                            random_mu(n_mu)]))
        record(w, taus, n1, bad)
        inner = set_interior(hand, rng, n_inner)
        n2, bad = set_violations(hand, q, joints, rp.claim, taus, inner,
                                 lambda _p: np.concatenate([some_corners(2), random_mu(n_mu)]))
        record(w, [], n2, bad)
        row["checked"] += 1
        if not (mutate and pieces):
            continue
        box = offset_box(hand, q, joints)
        kinds = {"widened_1pct": widened_probes(pieces, scale)}
        if box is not None:
            g0 = guarantee(system, rp.claim, mu, model=model, loads=hand.load_vertices(q))
            kinds["without_contacts"] = wider_probes(g0, pieces, scale)
        if hand.load_vertices(q) is not None:
            g1 = guarantee(system, rp.claim, mu, model=model, box=box)
            kinds["without_load_set"] = wider_probes(g1, pieces, scale)
        for kind, probes in kinds.items():
            for t in probes:
                n, bad = set_violations(hand, q, joints, rp.claim, [[t]], vertices, grid,
                                        first=True)
                row["mutations"].append({"t": w.t, "kind": kind, "tau": t, "samples": n,
                                         "caught": bool(bad),
                                         "labels": list(bad[0].labels) if bad else None})
    return row


def plan_hand(d: dict[str, Any], waypoints: int = 11
              ) -> tuple[Any, Segment, np.ndarray, np.ndarray]:
    hf = hand_file_from_dict(d)
    s, n_c = hf.segment, hf.hand.n_contacts
    mu = [list(p) for p in hf.mu_interval]
    rp = plan_segment(hf.hand, hf.q0, data=d, drive=s.drives, speed=s.speeds, mode=s.mode,
                      mu=mu if len(mu) > 1 else mu[0],
                      model="independent" if len(mu) > 1 else "common", max_time=s.max_time,
                      steps=s.steps, waypoints=min(s.waypoints, waypoints), partial=True)
    lo = np.array([p[0] for p in mu] * (n_c if len(mu) == 1 else 1))
    hi = np.array([p[1] for p in mu] * (n_c if len(mu) == 1 else 1))
    return hf.hand, rp, lo, hi


def set_sizes(text: str) -> tuple[float, float, float]:
    """``MASS,COM,CONTACTS``: mass +- fraction, centre of mass +- m, contacts +- m."""
    parts = text.split(",")
    try:
        vals = tuple(float(x) for x in parts)
    except ValueError:
        vals = ()
    if len(vals) != 3 or not all(np.isfinite(v) and v >= 0 for v in vals) or vals[0] >= 1:
        raise argparse.ArgumentTypeError(
            f"expected MASS,COM,CONTACTS (a fraction below 1, metres, metres; each >= 0), "
            f"got {text!r}")
    return vals  # type: ignore[return-value]


def effort_count(d: dict[str, Any]) -> int:
    """Effort-controlled joints of a hand-file dict's segment."""
    hf = hand_file_from_dict(d)
    return hf.hand.n_joints - len(hf.segment.drives)


def summarise(rows: list[dict[str, Any]], sizes: Any, seed: int, hands: int,
              t0: float) -> dict[str, Any]:
    planned = [r for r in rows if "claim" in r]
    summary: dict[str, Any] = {
        "seed": seed, "hands": hands, "tried": len(rows), "plans": len(planned),
        "waypoints": sum(r["waypoints"] for r in planned),
        "torque_points": sum(r["torques"] for r in planned),
        "redrawn": sum(r["redrawn"] for r in rows),
        "seconds": round(time.perf_counter() - t0, 1)}
    if sizes is None:
        found = [f for r in planned for f in r["outside_factor"]]
        summary.update({
            "friction_samples": sum(r["samples"] for r in planned),
            "violations": sum(len(r["violations"]) for r in planned),
            "outside_checked": len(found),
            "outside_open": sum(r.get("outside_open", 0) for r in planned),
            "outside_caught": sum(f is not None for f in found),
            "outside_factor_max": max((f for f in found if f is not None), default=None)})
        return summary
    muts = [m for r in planned for m in r["mutations"]]
    summary.update({
        "checked_waypoints": sum(r["checked"] for r in planned),
        "stopped": sum("stopped" in r for r in rows),
        "set": {"mass_fraction": sizes[0], "com_m": sizes[1], "contacts_m": sizes[2]},
        "samples": sum(r["samples"] for r in planned),
        "violations": sum(len(r["violations"]) for r in planned),
        "no_region": sum(r["plan"].startswith("NoRegionError") for r in rows),
        "refused": sum(r["plan"].startswith("DegenerateError") for r in rows),
        "with_contacts": sum(r.get("contacts_m", 0) > 0 for r in planned),
        "exact_waypoints": sum(sum(r["exact"]) for r in planned),
        "mutations": {k: {"checked": sum(m["kind"] == k for m in muts),
                          "caught": sum(m["kind"] == k and m["caught"] for m in muts)}
                      for k in ("widened_1pct", "without_contacts", "without_load_set")}})
    return summary


class HandTimeoutError(Exception):
    """One hand's planning and check ran over ``--limit`` seconds."""


def _alarm(signum: int, frame: Any) -> None:
    raise HandTimeoutError


def check_hand(entry: dict[str, Any], name: str, mu_range: tuple[float, float],
               rng: np.random.Generator, sizes: tuple[float, float, float] | None,
               waypoints: int, n_tau: int, n_mu: int, n_inner: int, outside: bool) -> None:
    """Draw, plan and check one random hand, filling ``entry`` as it goes."""
    for _ in range(REDRAWS):  # a jittered workpiece may be non-convex: draw again
        d = random_hand(template(name), rng, mu_range=mu_range)
        entry["mu"] = d["mu"]["interval"]
        try:
            if sizes is not None:
                # contact positions are guaranteed with one effort joint: the others
                # get the mass and centre-of-mass set alone
                contacts = sizes[2] if effort_count(d) == 1 else 0.0
                d = with_uncertainty(d, sizes[0], sizes[1], contacts)
                entry["contacts_m"] = contacts
            hand, rp, lo, hi = plan_hand(d, waypoints)
            break
        except FileFormatError:
            entry["redrawn"] += 1
        except QsplanError as exc:
            entry["plan"] = f"{type(exc).__name__}: {str(exc)[:160]}"
            return
    else:
        entry["plan"] = "no valid draw"
        return
    entry["plan"] = "partial" if rp.shortfall else "full"
    if sizes is None:
        entry.update(check_plan(hand, rp, lo, hi, rng, n_tau=n_tau, n_mu=n_mu,
                                outside=outside))
    else:
        ivs = hand_file_from_dict(d).mu_interval
        check_set_plan(hand, rp, list(ivs), lo, hi, rng, n_inner=n_inner, n_mu=n_mu,
                       into=entry)


def run(seed: int, hands: int, *, n_tau: int = 4, n_mu: int = 40, outside: bool = True,
        sizes: tuple[float, float, float] | None = None, waypoints: int = 11,
        n_inner: int = 20, out: Path | None = None, limit: int = 0) -> dict[str, Any]:
    """``limit`` > 0: stop a hand after that many seconds (what it checked is kept)."""
    rng = np.random.default_rng(seed)
    signal.signal(signal.SIGALRM, _alarm)
    t0 = time.perf_counter()
    rows: list[dict[str, Any]] = []
    res: dict[str, Any] = {}
    names = TEMPLATES if sizes is None else SET_TEMPLATES
    for h in range(hands):
        name = names[h % len(names)]
        odd = h % 2 if sizes is None else (h // len(names)) % 2  # every template in both
        mu_range = (0.3, 0.9) if odd else (0.0, 0.4)
        entry: dict[str, Any] = {"hand": h, "template": name, "redrawn": 0}
        th = time.perf_counter()
        if limit:
            signal.alarm(limit)
        try:
            check_hand(entry, name, mu_range, rng, sizes, waypoints, n_tau, n_mu, n_inner,
                       outside)
        except HandTimeoutError:
            what = "checking" if "claim" in entry else "planning"
            entry["stopped"] = f"after {limit} s ({what})"
            entry.setdefault("plan", f"stopped: planning over {limit} s")
        finally:
            signal.alarm(0)
        entry["seconds"] = round(time.perf_counter() - th, 1)
        rows.append(entry)
        res = {"summary": summarise(rows, sizes, seed, hands, t0), "rows": rows}
        if out is not None:  # after every hand: a run cut short keeps what it did
            atomic_write_json(out, res)
        print(row_line(entry), flush=True)
    return res


def row_line(r: dict[str, Any]) -> str:
    if "claim" not in r:
        return f"{r['hand']:3d} {r['template']:22s} no plan: {r['plan'][:70]}"
    head = (f"{r['hand']:3d} {r['template']:22s} {r['claim']:24s} p={r['p']} "
            f"{r['model']:6s} wp={r['waypoints']:3d} samples={r['samples']:6d} "
            f"violations={len(r['violations'])}")
    if "outside_factor" in r:
        return head + f" outside={r['outside_factor']}"
    caught = sum(m["caught"] for m in r["mutations"])
    return head + (f" contacts={r['contacts_m']:g} mutations caught {caught}/"
                   f"{len(r['mutations'])} {r['seconds']} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hands", type=int, default=12)
    ap.add_argument("--torques", type=int, default=4, help="random interior torques per waypoint")
    ap.add_argument("--samples", type=int, default=40,
                    help="uniform friction samples per torque (with --set: per set point)")
    ap.add_argument("--set", type=set_sizes, default=None, metavar="MASS,COM,CONTACTS",
                    help="check over the whole set: mass +- fraction, centre of mass +- m, "
                         "contacts +- m (e.g. 0.05,0.001,0.0005)")
    ap.add_argument("--waypoints", type=int, default=11, help="at most this many waypoints")
    ap.add_argument("--inner", type=int, default=20,
                    help="with --set: random interior points of the set per waypoint")
    ap.add_argument("--limit", type=int, default=0,
                    help="stop a hand after this many seconds (0: no limit)")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    res = run(a.seed, a.hands, n_tau=a.torques, n_mu=a.samples, sizes=a.set,
              waypoints=a.waypoints, n_inner=a.inner, out=a.out, limit=a.limit)
    print(json.dumps(res["summary"]))


if __name__ == "__main__":
    main()
