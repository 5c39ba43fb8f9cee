"""The report on hostile run folders: links out of the folder are never followed, embedded
files are capped (bytes and image pixels), odd names and numbers are no internal fault, and a
report written into a staging folder is titled by its real folder."""

from __future__ import annotations

import base64
import json
import os
import struct
import zlib

import pytest

import qsplan.report as report
from planner.files.outputs import output_set
from qsplan.report import build_html, scan_run, write_report

PNG_1x1 = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201a5f7a3"
    "5e0000000049454e44ae426082"
)


def _png_header(width: int, height: int) -> bytes:
    """A PNG signature and IHDR chunk claiming ``width x height`` pixels (no image data)."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", len(ihdr)) + chunk
            + struct.pack(">I", zlib.crc32(chunk)))


def test_links_out_of_the_run_folder_are_not_followed(tmp_path):
    secret = tmp_path / "elsewhere"
    secret.mkdir()
    leak = PNG_1x1 + b"SECRET-BYTES"
    (secret / "private.png").write_bytes(leak)
    (secret / "summary.json").write_text(json.dumps({"scenario": "secret-run", "passed": True}))
    run = tmp_path / "run"
    (run / "a").mkdir(parents=True)
    (run / "a" / "map.png").write_bytes(PNG_1x1)
    os.symlink(secret / "private.png", run / "leak.png")
    os.symlink(secret, run / "linked_dir")
    os.symlink(run / "a" / "map.png", run / "inside.png")  # a link inside the folder is fine
    page = build_html(run)
    assert base64.b64encode(leak).decode() not in page
    assert "secret-run" not in page
    assert "leak.png" in page and "a link out of the run folder" in page
    assert page.count("data:image/png;base64,") == 2  # a/map.png and inside.png


def test_embedded_files_are_capped(tmp_path, monkeypatch):
    run = tmp_path / "run"
    run.mkdir()
    (run / "huge_pixels.png").write_bytes(_png_header(100_000, 100_000))
    (run / "big.png").write_bytes(PNG_1x1 + b"\0" * 5000)
    (run / "ok.png").write_bytes(PNG_1x1)
    monkeypatch.setattr(report, "MAX_EMBED_BYTES", 4000)
    page = build_html(run)
    assert page.count("data:image/png;base64,") == 1
    assert "huge_pixels.png" in page and "10000000000 pixels" in page
    assert "big.png" in page and f"{len(PNG_1x1) + 5000} bytes, over the cap" in page


def test_total_embedded_bytes_are_capped(tmp_path, monkeypatch):
    run = tmp_path / "run"
    run.mkdir()
    for k in range(5):
        (run / f"f{k}.png").write_bytes(PNG_1x1 + b"\0" * 1000)
    monkeypatch.setattr(report, "MAX_TOTAL_EMBED_BYTES", 2500)
    page = build_html(run)
    assert page.count("data:image/png;base64,") == 2
    assert "report already embeds" in page


def test_non_utf8_file_name_and_huge_numbers(tmp_path, capsys):
    from qsplan.cli import main

    run = tmp_path / "run"
    run.mkdir()
    (run / os.fsdecode(b"bild-\xff\xfe.png")).write_bytes(PNG_1x1)
    (run / "plan.json").write_text(
        '{"format": "qsplan-plan", "claim": "4S", "waypoints": [{"margin": 1' + "0" * 400
        + '}, {"margin": -1e308}], "event": {"kind": "x", "t": 1' + "0" * 400 + '}}')
    (run / "summary.json").write_text(
        '{"scenario": "s", "agreement": 9' + "9" * 400 + ', "passed": true}')
    (run / "checks.json").write_text(
        '{"held": true, "checks": [{"check": "c", "measured": 1' + "0" * 400
        + ', "held": true}]}')
    page = build_html(run)
    assert "bild-" in page and "1.000e+400" in page
    assert main(["report", str(run)]) == 0, capsys.readouterr().err
    text = (run / "report.html").read_bytes().decode("utf-8")
    assert "bild-\ufffd\ufffd.png" in text
    assert "1.000e+400" in text


def test_report_in_a_staging_folder_is_titled_by_its_real_folder(tmp_path):
    dest = tmp_path / "my-report"
    with output_set(dest, "dir") as work:
        (work / "summary.json").write_text(json.dumps({"scenario": "x", "passed": True}))
        write_report(work, work / "index.html")
    page = (dest / "index.html").read_text()
    assert "<title>qsplan report: my-report</title>" in page
    assert ".qsplan-staging" not in page


def test_special_files_are_skipped_never_read(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    os.mkfifo(run / "pipe.png")
    os.mkfifo(run / "summary_pipe.json")
    (run / "ok.png").write_bytes(PNG_1x1)
    found = scan_run(run)
    assert [str(p) for p in found.images] == ["ok.png"]
    assert build_html(run).count("data:image/png;base64,") == 1


@pytest.mark.parametrize("name", ["a.png", "b.gif"])
def test_unreadable_image_is_listed_not_a_fault(tmp_path, monkeypatch, name):
    run = tmp_path / "run"
    run.mkdir()
    (run / name).write_bytes(b"x")
    real = report.Path.read_bytes

    def denied(self):
        if self.name == name:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self)

    monkeypatch.setattr(report.Path, "read_bytes", denied)
    page = build_html(run)
    assert name in page and "not embedded" in page
