"""The validation campaign's engines against each other (``validation_campaign.py
--table-only``; docs/validation-campaign.md).

A *point* is one ``(case, index, seed)`` of the campaign; its rows are the runs of that point in
each engine (possibly from several JSONL files). Where a point lies (near a region boundary,
wedge possible, away) is decided by the planner alone, so it is the same in every engine's row.

* :func:`pairwise_table` -- per case and engine pair, the points both engines ran (a verdict,
  not refused or broken) and on how many their verdicts are the same; away from region
  boundaries (``where="away"``) or anywhere (``None``);
* :func:`consensus_table` -- per case, the points all engines ran: unanimous, or a strict
  majority with an odd engine (explained: its run recorded an engine artefact,
  :mod:`sim.consensus`), or no majority; and which engine was odd how often.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from itertools import combinations
from typing import Any

from sim.consensus import consensus_of, title

RAN = ("agreed", "disagreed", "inconclusive", "fault")


def points(rows: list[dict[str, Any]]) -> dict[tuple[str, int, int], dict[str, dict[str, Any]]]:
    """``(case, index, seed) -> {engine: row}`` of the system points (not the hands) that ran
    (the last row of an engine wins)."""
    out: dict[tuple[str, int, int], dict[str, dict[str, Any]]] = {}
    for r in rows:
        if r.get("case") == "hand" or "index" not in r or r.get("status") not in RAN:
            continue
        out.setdefault((r["case"], r["index"], r["seed"]), {})[r["engine"]] = r
    return out


def _select(rows: list[dict[str, Any]], where: Callable[[dict[str, Any]], str],
            at: str | None) -> dict[tuple[str, int, int], dict[str, dict[str, Any]]]:
    pts = points(rows)
    if at is None:
        return pts
    return {k: v for k, v in pts.items() if where(next(iter(v.values()))) == at}


def _cases(keys: Any) -> list[str]:
    return sorted({k[0] for k in keys})


def pairwise_table(rows: list[dict[str, Any]], where: Callable[[dict[str, Any]], str],
                   at: str | None = "away", common: bool = False) -> str:
    """Markdown: per case (and the drawn kinds together) and engine pair, ``same of both``;
    ``common``: only the points every engine ran (every column on the same points)."""
    pts = _select(rows, where, at)
    if common:
        every = {e for v in pts.values() for e in v}
        pts = {k: v for k, v in pts.items() if set(v) == every}
    engines = sorted({e for v in pts.values() for e in v},
                     key=lambda e: ("pymunk", "mujoco", "dart").index(e)
                     if e in ("pymunk", "mujoco", "dart") else 9)
    pairs = list(combinations(engines, 2))
    out = ["| case | " + " | ".join(f"{title(a)} - {title(b)}" for a, b in pairs) + " |",
           "|---|" + "---|" * len(pairs)]
    groups = [(c, [c]) for c in _cases(pts)]
    drawn = [c for c in _cases(pts) if c not in ("ex41", "ex43", "system")]
    if len(drawn) > 1:
        groups.append(("drawn systems together", drawn))
    for name, cases in groups:
        cells = []
        for a, b in pairs:
            both = [v for k, v in pts.items() if k[0] in cases and a in v and b in v]
            same = sum(v[a]["status"] == v[b]["status"] for v in both)
            cells.append(f"{same} of {len(both)}" + (f" ({same / len(both):.0%})"
                                                     if both else ""))
        out.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def consensus_table(rows: list[dict[str, Any]], where: Callable[[dict[str, Any]], str],
                    at: str | None = "away") -> str:
    """Markdown: per case, the points every engine of the file(s) ran -- unanimous; one odd
    engine, explained by a recorded artefact or not (rows without recorded artefacts count as
    unexplained); no majority -- and the odd engines."""
    pts = _select(rows, where, at)
    engines = {e for v in pts.values() for e in v}
    full = {k: v for k, v in pts.items() if set(v) == engines}
    out = ["| case | points | unanimous | odd engine, artefact measured | odd engine, none "
           "measured | no majority | odd engines |", "|---|---|---|---|---|---|---|"]
    for case in _cases(full):
        n = Counter()
        odd: Counter[str] = Counter()
        for k, v in full.items():
            if k[0] != case:
                continue
            c = consensus_of({e: r["status"] for e, r in v.items()},
                             {e: r.get("artefacts") or () for e, r in v.items()})
            n["points"] += 1
            if c.unanimous:
                n["unanimous"] += 1
            elif c.majority is None:
                n["none"] += 1
            else:
                n["explained" if c.explained else "unexplained"] += 1
                odd.update(c.odd)
        odds = ", ".join(f"{title(e)} {m}" for e, m in odd.most_common()) or "-"
        out.append(f"| {case} | {n['points']} | {n['unanimous']} | {n['explained']} | "
                   f"{n['unexplained']} | {n['none']} | {odds} |")
    return "\n".join(out)


def odd_unrecorded(rows: list[dict[str, Any]], where: Callable[[dict[str, Any]], str],
                   seed: int) -> list[tuple[str, int, str, int]]:
    """``(case, index, engine, seed)`` of each point of ``seed`` away from region boundaries
    whose odd engine's row recorded no engine artefacts (a row written before they were)."""
    out = []
    for (case, index, s), v in sorted(_select(rows, where, "away").items()):
        if s != seed or len(v) < 3:
            continue
        c = consensus_of({e: r["status"] for e, r in v.items()})
        out += [(case, index, e, s) for e in c.odd if "artefacts" not in v[e]]
    return out
