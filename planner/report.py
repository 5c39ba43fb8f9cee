"""Self-contained HTML report of a run directory (issue 8).

Scans a run directory recursively for ``*.png``, ``*.gif`` (embedded as base64 ``<img>``),
``summary*.json`` (one table row each: ``scenario``, ``engine``, ``expect``, ``agreement``,
``passed``) and ``plan*.json`` (listed with their top-level keys). Written atomically.
"""

from __future__ import annotations

import base64
import html
import json
from dataclasses import dataclass
from pathlib import Path

from planner.errors import InputError
from planner.fileio import atomic_write_text

_MIME = {".png": "image/png", ".gif": "image/gif"}
SUMMARY_FIELDS = ("scenario", "engine", "expect", "agreement", "passed")


@dataclass(frozen=True)
class ReportContents:
    """What was found in a run directory (paths relative to it, sorted)."""

    images: tuple[Path, ...]
    summaries: tuple[Path, ...]
    plans: tuple[Path, ...]


def scan_run(run_dir: str | Path) -> ReportContents:
    """Find figures, summaries and plans under ``run_dir`` (recursive)."""
    root = Path(run_dir)
    if not root.is_dir():
        raise InputError(f"run directory: expected an existing directory, got {str(root)!r}")
    files = sorted(p for p in root.rglob("*") if p.is_file())
    rel = [p.relative_to(root) for p in files]
    return ReportContents(
        images=tuple(p for p in rel if p.suffix.lower() in _MIME),
        summaries=tuple(p for p in rel if p.name.startswith("summary") and p.suffix == ".json"),
        plans=tuple(p for p in rel if p.name.startswith("plan") and p.suffix == ".json"),
    )


def _load(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def build_html(run_dir: str | Path) -> str:
    """The report page as one HTML string with every image inlined as base64."""
    root = Path(run_dir)
    found = scan_run(root)
    esc = html.escape
    out = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>qsplan report: {esc(root.name)}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "td,th{border:1px solid #aaa;padding:3px 6px}table{border-collapse:collapse}"
        ".ok{background:#dfd}.bad{background:#fdd}img{max-width:100%}</style></head><body>",
        f"<h1>qsplan report: {esc(root.name)}</h1>",
        "<h2>What held and what did not</h2>",
    ]
    if found.summaries:
        out.append("<table><tr><th>file</th>" + "".join(
            f"<th>{f}</th>" for f in SUMMARY_FIELDS) + "</tr>")
        for rel in found.summaries:
            data = _load(root / rel) or {}
            passed = data.get("passed")
            cls = "ok" if passed is True else "bad"
            cells = "".join(f"<td>{esc(str(data.get(f, '')))}</td>" for f in SUMMARY_FIELDS)
            out.append(f"<tr class='{cls}'><td>{esc(str(rel))}</td>{cells}</tr>")
        out.append("</table>")
    else:
        out.append("<p>No summary*.json files found.</p>")
    if found.plans:
        out.append("<h2>Plans</h2><ul>")
        for rel in found.plans:
            keys = ", ".join(sorted((_load(root / rel) or {}).keys()))
            out.append(f"<li>{esc(str(rel))}: {esc(keys)}</li>")
        out.append("</ul>")
    out.append("<h2>Figures</h2>")
    for rel in found.images:
        data = base64.b64encode((root / rel).read_bytes()).decode("ascii")
        mime = _MIME[rel.suffix.lower()]
        out.append(
            f"<figure><img alt='{esc(str(rel))}' src='data:{mime};base64,{data}'>"
            f"<figcaption>{esc(str(rel))}</figcaption></figure>"
        )
    out.append("</body></html>")
    return "\n".join(out)


def write_report(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """Write the report (default ``RUN_DIR/report.html``) atomically; returns its path."""
    target = Path(out) if out is not None else Path(run_dir) / "report.html"
    return atomic_write_text(target, build_html(run_dir))
