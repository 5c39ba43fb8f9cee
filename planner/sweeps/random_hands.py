"""Seeded random hands in the hand-file format (``qsplan-hand``, :mod:`planner.files.hand_file`).

A random hand is drawn from a *template* hand file (a dict, e.g. one of the shipped files): the
whole geometry is scaled by a random factor, optionally mirrored about the world ``y`` axis (vertex
order reversed so the workpiece stays counter-clockwise, edge and vertex indices remapped, finger
sides, angles and revolute joint rates flipped), the workpiece's vertices, the finger pivots and
the first joint positions jittered, the masses and load redrawn, and the friction box replaced by
a random one (per contact, or one interval for all).  The contacts are closed by the loader's
Newton step; a draw that does not close raises the loader's :class:`FileFormatError`.

Units: SI as in the hand file (m, kg, N, rad, s).
"""

from __future__ import annotations

import copy
import math
from typing import Any

import numpy as np


def _mirror_point(p: Any) -> list[float]:
    return [-float(p[0]), float(p[1])]


def _mirror_edge(e: Any) -> list[list[float]]:
    """A surface edge mirrored with its ends swapped (its inward normal, rot90 of the edge
    direction, stays on the same side of the mirrored surface)."""
    return [_mirror_point(e[1]), _mirror_point(e[0])]


def mirror_hand(d: dict[str, Any]) -> dict[str, Any]:
    """The hand file ``d`` mirrored about the world ``y`` axis (x -> -x); a new dict."""
    d = copy.deepcopy(d)
    wp = d["workpiece"]
    n = len(wp["vertices"])
    wp["vertices"] = [_mirror_point(v) for v in reversed(wp["vertices"])]
    wp["com"] = _mirror_point(wp["com"])
    if "pose" in wp:
        x, y, th = wp["pose"]
        wp["pose"] = [-x, y, -th]
    d["palm"]["edge"] = _mirror_edge(d["palm"]["edge"])
    for s in d.get("environment", []):
        s["edge"] = _mirror_edge(s["edge"])
    revolute: list[bool] = []
    for f in d["fingers"]:
        f["pivot"] = _mirror_point(f["pivot"])
        if "links" in f:
            for j, lk in enumerate(f["links"]):
                if "offset" in lk:
                    lk["offset"] = (math.pi - lk["offset"]) if lk["type"] == "prismatic" \
                        else -lk["offset"]
                if lk["type"] == "revolute":
                    lk["position"] = (math.pi - lk["position"]) if j == 0 else -lk["position"]
                revolute.append(lk["type"] == "revolute")
        else:
            f["angle"] = math.pi - f["angle"]
            revolute.append(True)
    for c in d["contacts"]:
        if "vertex" in c:
            c["vertex"] = n - 1 - c["vertex"]
        if "edge" in c:
            c["edge"] = (n - 2 - c["edge"]) % n
        if c["kind"] == "side":
            c["side"] = -c.get("side", 1)
    if "load" in d and "force" in d["load"]:
        fx, fy = d["load"]["force"]
        d["load"]["force"] = [-fx, fy]
    seg = d["segment"]
    drives = seg["drive"] if isinstance(seg["drive"], list) else [seg["drive"]]
    speeds = seg["speed"] if isinstance(seg["speed"], list) else [seg["speed"]]
    seg["drive"] = drives
    seg["speed"] = [-s if revolute[j] else s for j, s in zip(drives, speeds)]
    goal = d.get("goal")
    if goal is not None:  # the goal pose and grasp, mirrored the same way
        if "pose" in goal:
            x, y, th = goal["pose"]
            goal["pose"] = [-x, y, -th]
        for c in goal.get("contacts", []):
            if "vertex" in c:
                c["vertex"] = n - 1 - c["vertex"]
            if "edge" in c:
                c["edge"] = (n - 2 - c["edge"]) % n
            if c.get("kind") == "side":
                c["side"] = -c.get("side", 1)
    return d


def _scale(d: dict[str, Any], s: float) -> None:
    """Every length of ``d`` times ``s`` in place (angles, masses and forces unchanged)."""
    def pts(v: Any) -> list[list[float]]:
        return [[s * float(x), s * float(y)] for x, y in v]

    wp = d["workpiece"]
    wp["vertices"] = pts(wp["vertices"])
    wp["com"] = [s * float(x) for x in wp["com"]]
    if "pose" in wp:
        wp["pose"] = [s * wp["pose"][0], s * wp["pose"][1], wp["pose"][2]]
    d["palm"]["edge"] = pts(d["palm"]["edge"])
    for e in d.get("environment", []):
        e["edge"] = pts(e["edge"])
    revolute: list[bool] = []
    for f in d["fingers"]:
        f["pivot"] = [s * float(x) for x in f["pivot"]]
        if "links" in f:
            for lk in f["links"]:
                lk["length"] *= s
                lk["width"] *= s
                if lk["type"] == "prismatic":
                    lk["position"] *= s
                revolute.append(lk["type"] == "revolute")
        else:
            f["length"] *= s
            f["width"] *= s
            revolute.append(True)
    seg = d["segment"]
    seg["speed"] = [v if revolute[j] else s * v for j, v in zip(seg["drive"], seg["speed"])]


def random_hand(template: dict[str, Any], rng: np.random.Generator, *,
                mu_range: tuple[float, float] = (0.0, 0.9), jitter: float = 0.03,
                mirror: bool | None = None) -> dict[str, Any]:
    """A random hand-file dict drawn from ``template`` (module docstring).

    ``jitter``: relative size of the geometric perturbations (of the workpiece's size);
    ``mu_range``: where the friction box's ends are drawn (each interval at least 0.02 wide);
    ``mirror``: force (True/False) or draw (None) the mirror image.
    """
    d = copy.deepcopy(template)
    seg = d["segment"]
    seg["drive"] = seg["drive"] if isinstance(seg["drive"], list) else [seg["drive"]]
    seg["speed"] = seg["speed"] if isinstance(seg["speed"], list) else [seg["speed"]]
    d.pop("goal", None)
    if mirror if mirror is not None else bool(rng.integers(2)):
        d = mirror_hand(d)
    _scale(d, float(np.exp(rng.uniform(math.log(0.7), math.log(1.4)))))
    wp = d["workpiece"]
    v = np.array(wp["vertices"], dtype=float)
    size = float(np.max(np.ptp(v, axis=0)))
    wp["vertices"] = (v + rng.normal(0.0, 0.3 * jitter * size, v.shape)).tolist()
    # keep the palm/surface vertices on their surface: jitter only along the line then
    touching = {c["vertex"] for c in d["contacts"] if c["kind"] in ("palm", "surface")}
    for i in touching:
        wp["vertices"][i][1] = float(v[i, 1])
    lo_c, hi_c = v.min(axis=0), v.max(axis=0)
    wp["com"] = (np.clip(np.array(wp["com"]) + rng.normal(0, jitter * size, 2), lo_c,
                         hi_c)).tolist()
    wp["mass"] = float(wp.get("mass", 0.1) * rng.uniform(0.5, 2.0))
    for f in d["fingers"]:
        f["pivot"] = (np.array(f["pivot"]) + rng.normal(0, 0.3 * jitter * size, 2)).tolist()
    if "load" in d and "force" in d["load"]:
        d["load"]["force"] = (np.array(d["load"]["force"]) * rng.uniform(0.5, 2.0)).tolist()
    n_c = len(d["contacts"])
    lo = rng.uniform(mu_range[0], mu_range[1] - 0.02, n_c)
    hi = np.minimum(lo + rng.uniform(0.02, 0.3, n_c), mu_range[1])
    if rng.integers(2):
        d["mu"] = {"interval": [[float(a), float(b)] for a, b in zip(lo, hi)]}
    else:
        d["mu"] = {"interval": [float(lo[0]), float(hi[0])]}
    d["name"] = f"random_{d.get('name', 'hand')}"
    return d
