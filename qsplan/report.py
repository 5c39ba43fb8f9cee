"""Self-contained HTML report of a run directory.

Scans a run directory recursively for

* ``*.png``, ``*.gif``: embedded as base64 ``<img>``, grouped by folder;
* ``checks*.json``: ``{"task", "held", "checks": [{"check", "expected", "measured", "held"}]}``
  as ``qsplan demo`` writes it, shown first;
* ``summary*.json``: one table row each (``scenario``, ``engine``, ``expect``, ``status``,
  ``agreement``, ``passed``, ``reason``; docs/file-formats.md);
* ``plan*.json``: qsplan plan files (claim, friction interval, policy, waypoints, smallest
  torque margin, end event); other JSON: its top-level keys.

Written atomically.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from pathlib import Path

from planner.errors import InputError, QsplanError
from planner.files.atomic import atomic_write_text
from planner.files.reader import read_json

_MIME = {".png": "image/png", ".gif": "image/gif"}
SUMMARY_FIELDS = ("scenario", "engine", "expect", "status", "agreement", "passed", "reason")


@dataclass(frozen=True)
class ReportContents:
    """What was found in a run directory (paths relative to it, sorted)."""

    images: tuple[Path, ...]
    summaries: tuple[Path, ...]
    plans: tuple[Path, ...]
    checks: tuple[Path, ...] = ()


def scan_run(run_dir: str | Path) -> ReportContents:
    """Find figures, summaries and plans under ``run_dir`` (recursive)."""
    root = Path(run_dir)
    if not root.is_dir():
        raise InputError(f"run directory: expected an existing directory, got {str(root)!r}")
    files = sorted(p for p in root.rglob("*") if p.is_file()
                   and not any(part.startswith(".qsplan-") for part in p.relative_to(root).parts))
    rel = [p.relative_to(root) for p in files]
    return ReportContents(
        images=tuple(p for p in rel if p.suffix.lower() in _MIME),
        summaries=tuple(p for p in rel if p.name.startswith("summary") and p.suffix == ".json"),
        plans=tuple(p for p in rel if p.name.startswith("plan") and p.suffix == ".json"),
        checks=tuple(p for p in rel if p.name.startswith("checks") and p.suffix == ".json"),
    )


def _load(path: Path) -> dict | None:
    try:
        data = read_json(path, "run file")
    except QsplanError:
        return None
    return data if isinstance(data, dict) else None


def _cell(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _checks_table(root: Path, rel: Path) -> str:
    """Table of a checks file: each check, what was expected, what was measured, held or not."""
    esc = html.escape
    data = _load(root / rel) or {}
    checks = data.get("checks")
    checks = [c for c in checks if isinstance(c, dict)] if isinstance(checks, list) else []
    held = data.get("held")
    verdict = ("every expectation held" if held is True else
               "NOT every expectation held" if held is False else "")
    rows = [f"<h3>{esc(str(rel))}: {esc(str(data.get('task', '')))}</h3>"]
    if verdict:
        rows.append(f"<p class='{'ok' if held else 'bad'}'><b>{verdict}</b> "
                    f"({sum(c.get('held') is True for c in checks)} of {len(checks)} checks)</p>")
    rows.append("<table><tr><th>check</th><th>expected</th><th>measured</th><th>held</th></tr>")
    for c in checks:
        ok = c.get("held")
        cls = ("ok" if ok else "bad") if isinstance(ok, bool) else "info"
        cells = "".join(f"<td>{esc(_cell(c.get(k, '')))}</td>"
                        for k in ("check", "expected", "measured", "held"))
        rows.append(f"<tr class='{cls}'>{cells}</tr>")
    rows.append("</table>")
    return "\n".join(rows)


def _plans_table(root: Path, plans: tuple[Path, ...]) -> str:
    """One row per plan file: claim, mu, policy, waypoints, smallest margin, end event."""
    esc = html.escape
    rows = ["<table><tr><th>file</th><th>claim</th><th>mu</th><th>control</th><th>policy</th>"
            "<th>waypoints</th><th>smallest torque margin</th><th>segment ends</th></tr>"]
    for rel in plans:
        data = _load(root / rel) or {}
        if data.get("format") != "qsplan-plan":
            keys = ", ".join(sorted(data))
            rows.append(f"<tr><td>{esc(str(rel))}</td><td colspan='7'>keys: {esc(keys)}</td></tr>")
            continue
        segments = data.get("segments")
        if isinstance(segments, list):  # versions 2 and 3: one row per segment
            for k, seg in enumerate(segments):
                if isinstance(seg, dict):
                    rows.append(_plan_row(f"{rel} segment {k + 1}", {**data, **seg}))
            continue
        rows.append(_plan_row(str(rel), data))
    rows.append("</table>")
    return "\n".join(rows)


def _plan_row(name: str, data: dict) -> str:
    """One plans-table row of a version-1 plan, or of a later version's segment merged with the
    plan's top level."""
    esc = html.escape
    wps = data.get("waypoints")
    wps = wps if isinstance(wps, list) else []
    margins = [float(w["margin"]) for w in wps if isinstance(w, dict)
               and isinstance(w.get("margin"), (int, float))]
    mu = data.get("mu") or {}
    intervals = mu.get("intervals") if isinstance(mu, dict) else None
    mu_text = (f"{mu.get('model', '')} {intervals[0]}" if isinstance(intervals, list)
               and intervals else str(mu))
    event = data.get("event") or {}
    ev = (f"{event.get('kind', '')} ({event.get('detail', '')}) at t = "
          f"{_cell(event.get('t', ''))} s" if isinstance(event, dict) else str(event))
    control = data.get("control")
    cells = [name, data.get("claim", ""), mu_text,
             ", ".join(map(str, control)) if isinstance(control, list) else control or "",
             data.get("policy", ""), len(wps),
        _cell(min(margins)) if margins else "", ev]
    return "<tr>" + "".join(f"<td>{esc(str(c))}</td>" for c in cells) + "</tr>"


def _figures(root: Path, images: list[Path], heading: str | None) -> list[str]:
    """``<figure>`` elements of ``images``, one ``<h3>`` per folder (``heading`` for the top)."""
    esc = html.escape
    out = []
    folder = None
    for rel in images:
        if rel.parent != folder:
            folder = rel.parent
            out.append(f"<h3>{esc(str(folder) if str(folder) != '.' else heading or root.name)}"
                       "</h3>")
        encoded = base64.b64encode((root / rel).read_bytes()).decode("ascii")
        mime = _MIME[rel.suffix.lower()]
        out.append(
            f"<figure><img alt='{esc(str(rel))}' src='data:{mime};base64,{encoded}'>"
            f"<figcaption>{esc(str(rel))}</figcaption></figure>"
        )
    return out


#: Folders shown before the tables, in order: the task in pictures (``qsplan demo``'s
#: ``story/``: start, segments, goal, torque regions), then the torque bounds (``figures/``).
STORY_FOLDERS = (("story", "The task: start, segments and goal"),
                 ("figures", "Torque regions (Figures 10-13)"))


def build_html(run_dir: str | Path) -> str:
    """The report page as one HTML string with every image inlined as base64: the story
    figures first (:data:`STORY_FOLDERS`), then what held (checks, summaries, plans), then the
    other figures."""
    root = Path(run_dir)
    found = scan_run(root)
    esc = html.escape
    out = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>qsplan report: {esc(root.name)}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "td,th{border:1px solid #aaa;padding:3px 6px}table{border-collapse:collapse}"
        ".ok{background:#dfd}.bad{background:#fdd}.info{background:#eef}img{max-width:100%}"
        "</style></head><body>",
        f"<h1>qsplan report: {esc(root.name)}</h1>",
    ]
    rest = list(found.images)
    if any(rel.parts[0] == "story" for rel in rest if len(rel.parts) > 1):
        for name, title in STORY_FOLDERS:
            mine = [rel for rel in rest if len(rel.parts) > 1 and rel.parts[0] == name]
            if mine:
                out.append(f"<h2>{esc(title)}</h2>")
                out += _figures(root, mine, None)
                rest = [rel for rel in rest if rel not in mine]
    out.append("<h2>What held and what did not</h2>")
    for rel in found.checks:
        out.append(_checks_table(root, rel))
    if found.summaries:
        out.append("<table><tr><th>file</th>" + "".join(
            f"<th>{f}</th>" for f in SUMMARY_FIELDS) + "</tr>")
        for rel in found.summaries:
            data = _load(root / rel) or {}
            passed = data.get("passed")
            cls = ("ok" if passed else "bad") if isinstance(passed, bool) else "info"
            cells = "".join(f"<td>{esc(_cell(data.get(f, '')))}</td>" for f in SUMMARY_FIELDS)
            out.append(f"<tr class='{cls}'><td>{esc(str(rel))}</td>{cells}</tr>")
        out.append("</table>")
        n_ok = sum((_load(root / r) or {}).get("passed") is True for r in found.summaries)
        out.append(f"<p>{n_ok} of {len(found.summaries)} summaries passed.</p>")
    else:
        out.append("<p>No summary*.json files found.</p>")
    if found.plans:
        out.append("<h2>Plans</h2>")
        out.append(_plans_table(root, found.plans))
    out.append("<h2>Figures</h2>")
    out += _figures(root, rest, None)
    out.append("</body></html>")
    return "\n".join(out)


def write_report(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """Write the report (default ``RUN_DIR/report.html``) atomically; returns its path."""
    target = Path(out) if out is not None else Path(run_dir) / "report.html"
    return atomic_write_text(target, build_html(run_dir))
