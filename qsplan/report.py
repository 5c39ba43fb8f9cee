"""Self-contained HTML report of a run directory.

Scans a run directory recursively for

* ``*.png``, ``*.gif``: embedded as base64 ``<img>``, grouped by folder; ``problem.png`` (the
  drawing of the file a run came from, written with the run) first;
* ``checks*.json``: ``{"task", "held", "checks": [{"check", "expected", "measured", "held"}]}``
  as ``qsplan demo`` writes it, shown first;
* ``summary*.json``: one table row each (``scenario``, ``engine``, ``expect``, ``status``,
  ``agreement``, ``passed``, ``reason``; docs/file-formats.md);
* ``plan*.json``: qsplan plan files (claim, friction interval, policy, waypoints, smallest
  torque margin, end event); other JSON: its top-level keys.

What a hostile run folder cannot do: make the report read outside the folder (a symbolic link
whose target lies outside it is listed, never followed or embedded; linked folders are not
descended into), block it (FIFOs, sockets and devices are skipped unread), blow it up (an image
over :data:`MAX_EMBED_BYTES` bytes or :data:`MAX_EMBED_PIXELS` pixels, from the PNG / GIF
header, and images beyond :data:`MAX_TOTAL_EMBED_BYTES` in all are listed, not embedded), or
break it (file names that are not UTF-8, integers of hundreds of digits, strings that are not
valid Unicode: shown, never a fault).  A report written inside a staging folder is titled by the
folder's final name (:func:`planner.files.outputs.final_path`).  Written atomically.
"""

from __future__ import annotations

import base64
import html
import math
import os
import stat
import struct
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

from planner.errors import InputError, QsplanError
from planner.files.atomic import atomic_write_bytes
from planner.files.reader import read_json
from planner.plots.draw_file import PROBLEM_PICTURE

_MIME = {".png": "image/png", ".gif": "image/gif"}
SUMMARY_FIELDS = ("scenario", "engine", "expect", "status", "agreement", "passed", "reason")
MAX_EMBED_BYTES = 32 * 2 ** 20
"""Largest image embedded (bytes); a report opens in a browser, where every byte is held
about 1.33 times (base64) plus the decoded picture."""
MAX_EMBED_PIXELS = 50_000_000
"""Largest image embedded (width x height from its header: 200 MB decoded at 4 bytes a pixel)."""
MAX_TOTAL_EMBED_BYTES = 256 * 2 ** 20
"""Images embedded in one report at most (bytes, before base64)."""


@dataclass(frozen=True)
class ReportContents:
    """What was found in a run directory (paths relative to it, sorted); ``skipped``: files
    the report would have used but does not read, with the reason."""

    images: tuple[Path, ...]
    summaries: tuple[Path, ...]
    plans: tuple[Path, ...]
    checks: tuple[Path, ...] = ()
    skipped: tuple[tuple[Path, str], ...] = ()


def _wanted(name: str) -> bool:
    suffix = os.path.splitext(name)[1].lower()
    return suffix in _MIME or suffix == ".json" and name.startswith(("summary", "plan", "checks"))


def _inside(path: Path, root: Path) -> bool:
    try:
        path.relative_to(root)
        return True
    except ValueError:
        return False


def scan_run(run_dir: str | Path) -> ReportContents:
    """Find figures, summaries and plans under ``run_dir`` (recursive; never through a link
    out of it, never into a staging folder)."""
    root = Path(run_dir)
    if not root.is_dir():
        raise InputError(f"run directory: expected an existing directory, got {str(root)!r}")
    real_root = root.resolve()
    rel: list[Path] = []
    skipped: list[tuple[Path, str]] = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        here = Path(dirpath)
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".qsplan-"))
        for d in dirnames:
            if (here / d).is_symlink() and not _inside((here / d).resolve(), real_root):
                skipped.append(((here / d).relative_to(root), "a link out of the run folder"))
        for name in filenames:
            path = here / name
            if not _wanted(name):
                continue
            try:
                st = os.lstat(path)
                if stat.S_ISLNK(st.st_mode):
                    if not _inside(path.resolve(), real_root):
                        skipped.append((path.relative_to(root), "a link out of the run folder"))
                        continue
                    st = os.stat(path)
            except OSError:
                continue  # vanished or a dangling link
            if stat.S_ISREG(st.st_mode):
                rel.append(path.relative_to(root))
    rel.sort()
    return ReportContents(
        images=tuple(p for p in rel if p.suffix.lower() in _MIME),
        summaries=tuple(p for p in rel if p.name.startswith("summary") and p.suffix == ".json"),
        plans=tuple(p for p in rel if p.name.startswith("plan") and p.suffix == ".json"),
        checks=tuple(p for p in rel if p.name.startswith("checks") and p.suffix == ".json"),
        skipped=tuple(sorted(skipped)),
    )


def shown(path: Path | str) -> str:
    """A file name as text that any page can hold (bytes that are not UTF-8 as U+FFFD)."""
    return os.fsencode(str(path)).decode("utf-8", "replace")


def _number(value: object) -> float | None:
    """A JSON number as a float (+-inf beyond the float range); None for anything else."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _load(path: Path) -> dict | None:
    try:
        data = read_json(path, "run file")
    except QsplanError:
        return None
    return data if isinstance(data, dict) else None


def _cell(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10 ** 15:
        return format(Decimal(value), ".4g")  # hundreds of digits: 1.000e+400
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
    rows = [f"<h3>{esc(shown(rel))}: {esc(str(data.get('task', '')))}</h3>"]
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
            rows.append(f"<tr><td>{esc(shown(rel))}</td><td colspan='7'>keys: {esc(keys)}</td>"
                        "</tr>")
            continue
        segments = data.get("segments")
        if isinstance(segments, list):  # versions 2 and 3: one row per segment
            for k, seg in enumerate(segments):
                if isinstance(seg, dict):
                    rows.append(_plan_row(f"{shown(rel)} segment {k + 1}", {**data, **seg}))
            continue
        rows.append(_plan_row(shown(rel), data))
    rows.append("</table>")
    return "\n".join(rows)


def _plan_row(name: str, data: dict) -> str:
    """One plans-table row of a version-1 plan, or of a later version's segment merged with the
    plan's top level."""
    esc = html.escape
    wps = data.get("waypoints")
    wps = wps if isinstance(wps, list) else []
    margins = [m for m in (_number(w.get("margin")) for w in wps if isinstance(w, dict))
               if m is not None]
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


def _image_header_pixels(head: bytes) -> int | None:
    """Width x height from a PNG (IHDR) or GIF (logical screen) header; None if neither."""
    if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR" and len(head) >= 24:
        w, h = struct.unpack(">II", head[16:24])
        return w * h
    if head[:6] in (b"GIF87a", b"GIF89a") and len(head) >= 10:
        w, h = struct.unpack("<HH", head[6:10])
        return w * h
    return None


def _embed(path: Path, budget: list[int]) -> tuple[str | None, str]:
    """``(base64 text, "")`` of an image within the caps (``budget[0]``: bytes still allowed
    in this report), else ``(None, why not)``."""
    try:
        size = os.stat(path).st_size
        if size > MAX_EMBED_BYTES:
            return None, f"{size} bytes, over the cap of {MAX_EMBED_BYTES} bytes per image"
        if size > budget[0]:
            return None, (f"the report already embeds {MAX_TOTAL_EMBED_BYTES - budget[0]} bytes "
                          f"of images (cap {MAX_TOTAL_EMBED_BYTES})")
        data = path.read_bytes()
    except OSError as exc:
        return None, f"unreadable ({exc.strerror})"
    pixels = _image_header_pixels(data[:32])
    if pixels is not None and pixels > MAX_EMBED_PIXELS:
        w_h = (struct.unpack(">II", data[16:24]) if data[:1] == b"\x89"
               else struct.unpack("<HH", data[6:10]))
        return None, (f"{w_h[0]} x {w_h[1]} = {pixels} pixels, over the cap of "
                      f"{MAX_EMBED_PIXELS}")
    budget[0] -= len(data)
    return base64.b64encode(data[:MAX_EMBED_BYTES]).decode("ascii"), ""


def _figures(root: Path, images: list[Path], heading: str | None,
             budget: list[int]) -> list[str]:
    """``<figure>`` elements of ``images``, one ``<h3>`` per folder (``heading`` for the top)."""
    esc = html.escape
    out = []
    folder = None
    for rel in images:
        if rel.parent != folder:
            folder = rel.parent
            out.append(f"<h3>{esc(shown(folder) if str(folder) != '.' else heading or '')}"
                       "</h3>")
        encoded, why = _embed(root / rel, budget)
        if encoded is None:
            out.append(f"<p class='info'>not embedded: {esc(shown(rel))} ({esc(why)})</p>")
            continue
        mime = _MIME[rel.suffix.lower()]
        out.append(
            f"<figure><img alt='{esc(shown(rel))}' src='data:{mime};base64,{encoded}'>"
            f"<figcaption>{esc(shown(rel))}</figcaption></figure>"
        )
    return out


def distinct_pictures(root: Path, images: list[Path]) -> list[Path]:
    """``images`` without byte-identical repeats (the runs of one plan or system at several
    frictions or engines draw the same problem): the first of each kept."""
    import hashlib

    seen: set[str] = set()
    out = []
    for rel in images:
        try:
            with open(root / rel, "rb") as f:  # never more than an embeddable image
                digest = hashlib.sha256(f.read(MAX_EMBED_BYTES + 1)).hexdigest()
        except OSError:
            digest = str(rel)
        if digest not in seen:
            seen.add(digest)
            out.append(rel)
    return out


def report_title(run_dir: str | Path) -> str:
    """The run folder's name as the report shows it: its final name when it is a staging
    folder being written (:func:`planner.files.outputs.final_path`)."""
    from planner.files.outputs import final_path

    root = Path(run_dir)
    name = final_path(root.absolute()).name
    return shown(name if not name.startswith(".qsplan-") else root.name)


#: Folders shown before the tables, in order: the task in pictures (``qsplan demo``'s
#: ``story/``: start, segments, goal, torque regions), then the torque bounds (``figures/``).
STORY_FOLDERS = (("story", "The task: start, segments and goal"),
                 ("figures", "Torque regions (Figures 10-13)"))


def build_html(run_dir: str | Path) -> str:
    """The report page as one HTML string with every image inlined as base64: the drawing of
    the problem (:data:`planner.plots.draw_file.PROBLEM_PICTURE`), the story figures
    (:data:`STORY_FOLDERS`), then what held (checks, summaries, plans), then the
    other figures."""
    root = Path(run_dir)
    found = scan_run(root)
    esc = html.escape
    title = report_title(root)
    budget = [MAX_TOTAL_EMBED_BYTES]
    out = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'>",
        f"<title>qsplan report: {esc(title)}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "td,th{border:1px solid #aaa;padding:3px 6px}table{border-collapse:collapse}"
        ".ok{background:#dfd}.bad{background:#fdd}.info{background:#eef}img{max-width:100%}"
        "</style></head><body>",
        f"<h1>qsplan report: {esc(title)}</h1>",
    ]
    rest = list(found.images)
    problems = [rel for rel in rest if rel.name == PROBLEM_PICTURE]
    if problems:
        out.append("<h2>The problem (qsplan draw of the file each run came from)</h2>")
        out += _figures(root, distinct_pictures(root, problems), title, budget)
        rest = [rel for rel in rest if rel not in problems]
    if any(rel.parts[0] == "story" for rel in rest if len(rel.parts) > 1):
        for name, title in STORY_FOLDERS:
            mine = [rel for rel in rest if len(rel.parts) > 1 and rel.parts[0] == name]
            if mine:
                out.append(f"<h2>{esc(title)}</h2>")
                out += _figures(root, mine, None, budget)
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
            out.append(f"<tr class='{cls}'><td>{esc(shown(rel))}</td>{cells}</tr>")
        out.append("</table>")
        n_ok = sum((_load(root / r) or {}).get("passed") is True for r in found.summaries)
        out.append(f"<p>{n_ok} of {len(found.summaries)} summaries passed.</p>")
    else:
        out.append("<p>No summary*.json files found.</p>")
    if found.plans:
        out.append("<h2>Plans</h2>")
        out.append(_plans_table(root, found.plans))
    out.append("<h2>Figures</h2>")
    out += _figures(root, rest, title, budget)
    if found.skipped:
        out.append("<h2>Not read</h2><ul>")
        out += [f"<li>{esc(shown(rel))}: {esc(why)}</li>" for rel, why in found.skipped]
        out.append("</ul>")
    out.append("</body></html>")
    return "\n".join(out)


def write_report(run_dir: str | Path, out: str | Path | None = None) -> Path:
    """Write the report (default ``RUN_DIR/report.html``) atomically; returns its path."""
    target = Path(out) if out is not None else Path(run_dir) / "report.html"
    # "replace": a string from a JSON file may hold a lone surrogate ("\\ud800")
    return atomic_write_bytes(target, build_html(run_dir).encode("utf-8", "replace"))
