"""The demo's engines side by side: every run's verdict per engine, where the engines disagree
with each other, and their consensus (:mod:`sim.consensus`).

The demo's runs are grouped by question -- the same plan at the same friction with the same
expectation, in every engine -- and each question gets one :class:`sim.consensus.Consensus`
(whole run and, for a task, per segment). A run check that failed in an engine the consensus
names as the odd one, with an engine artefact measured in that engine's run, is an engine
artefact, not a model error: :func:`excuse_checks` marks it held and says why.
"""

from __future__ import annotations

from typing import Any

from sim.consensus import Consensus, consensus, segment_consensus, title


def question(r: dict[str, Any]) -> tuple[Any, ...]:
    """What a run asks, whatever the engine: ``(task, expect, mu, name without engine)``."""
    name = str(r.get("name", "")).replace(f", {r['engine']}", "")
    return (bool(r["task"]), r["expect"], float(r["parameters"]["mu"][0]), name)


def by_question(results: list[dict[str, Any]]) -> dict[tuple[Any, ...], list[dict[str, Any]]]:
    """The runs of each question, in the demo's order."""
    out: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in results:
        out.setdefault(question(r), []).append(r)
    return out


def consensus_table(results: list[dict[str, Any]]) -> dict[str, Any]:
    """JSON-ready: per question its ``runs`` name, ``expect``, the whole run's consensus and,
    for a task, each segment's."""
    rows = []
    for (_, expect, _, name), runs in by_question(results).items():
        rows.append({"run": name, "expect": expect, "whole": consensus(runs).to_dict(),
                     "segments": [c.to_dict() for c in segment_consensus(runs)]})
    return {"engines": sorted({r["engine"] for r in results}), "questions": rows}


def excuse_checks(checks: list[dict[str, Any]], results: list[dict[str, Any]]
                  ) -> list[dict[str, Any]]:
    """``checks`` with every failed run check of an odd engine whose run measured an engine
    artefact marked held, the artefact appended to ``measured`` (a check names its engine as
    ``in <engine>, mu=...``)."""
    odd: list[tuple[tuple[str, ...], str, float, tuple[str, ...]]] = []
    for (task, expect, mu, _), runs in by_question(results).items():
        c = consensus(runs)
        for e in c.odd:
            if c.causes.get(e):
                odd.append((CHECKS[(task, expect)], e, mu, c.causes[e]))
    out = []
    for ch in checks:
        if not ch["held"]:
            for prefixes, e, mu, causes in odd:
                if ch["check"].startswith(prefixes) and f"in {e}, mu={mu:g}" in ch["check"]:
                    ch = {**ch, "held": True,
                          "measured": f"{ch['measured']} -- {title(e)} is the odd engine, "
                                      f"engine artefact measured: {'; '.join(causes)}"}
                    break
        out.append(ch)
    return out


#: ``(task, expect)`` of a question -> how its run checks begin (:mod:`qsplan.demo_task`,
#: :mod:`qsplan.commands.demo`).
CHECKS: dict[tuple[bool, str], tuple[str, ...]] = {
    (True, "agree"): ("task segment", "whole task in"),
    (True, "disagree"): ("negative control (torques reversed)",),
    (False, "disagree"): ("negative control in",),
    (False, "agree"): (),
}


def side_by_side_lines(results: list[dict[str, Any]]) -> list[str]:
    """The report's section: a row per question (and per task segment), a column per engine,
    then the consensus, and where the engines disagree with each other."""
    engines = list(dict.fromkeys(r["engine"] for r in results))
    L = ["## Engines side by side\n",
         "Every run in every engine (" + ", ".join(title(e) for e in engines) + "); where "
         "they disagree with each other, the consensus names the odd engine and the engine "
         "artefact its run measured (creep of a contact predicted to stick, lift-off, "
         "chatter, penetration, capped contact solves; thresholds: docs/simulation.md, "
         "\"Engines side by side\").\n",
         "| run | expected | " + " | ".join(title(e) for e in engines) + " | consensus |",
         "|---|---|" + "---|" * len(engines) + "---|"]
    split: list[tuple[str, Consensus]] = []
    for (_, expect, _, name), runs in by_question(results).items():
        c = consensus(runs)
        want = "agreed" if expect == "agree" else "disagreed"
        L.append(f"| {name} | {want} | " + " | ".join(c.verdicts.get(e, "-") for e in engines)
                 + f" | {c.majority or 'none'} |")
        if not c.unanimous:
            split.append((name, c))
        for c_seg, k in zip(segment_consensus(runs), range(1, 100)):
            L.append(f"| {name}: segment {k} | {want if expect == 'agree' else '-'} | "
                     + " | ".join(c_seg.verdicts.get(e, "-") for e in engines)
                     + f" | {c_seg.majority or 'none'} |")
            if not c_seg.unanimous:
                split.append((f"{name}, segment {k}", c_seg))
    L.append("")
    if split:
        L.append("Where the engines disagree with each other:\n")
        L += [f"- {name}: {c.text}." for name, c in split]
    else:
        L.append("The engines agree with each other on every run and segment.")
    L.append("")
    return L
