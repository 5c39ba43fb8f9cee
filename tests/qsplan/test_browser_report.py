"""The report renders every figure in headless Chromium (skipped when Chromium is absent).

Chromium loads the report with a small script appended that counts the ``<img>`` elements
whose ``naturalWidth > 0`` (decoded) and writes ``loaded/total`` into the DOM, which
``--dump-dom`` prints. A negative control (a corrupt PNG) checks that the probe can fail.
"""

import io
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from qsplan.cli import main
from qsplan.report import write_report

PNG_1x1 = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201a5f7a3"
    "5e0000000049454e44ae426082"
)
CHROMIUM = Path("/usr/bin/chromium")
pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason="/usr/bin/chromium not installed")

CHECK = ("<script>window.onload=()=>{const i=[...document.images];document.body.setAttribute("
         "'data-loaded',i.filter(x=>x.naturalWidth>0).length+'/'+i.length)}</script></body>")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync")


def _loaded_images(page: Path, profile: Path) -> tuple[int, int]:
    """(images with naturalWidth > 0, all images) of ``page`` as rendered by Chromium."""
    probe = page.with_name("probe.html")
    probe.write_text(page.read_text().replace("</body>", CHECK))
    out = subprocess.run(
        [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", "--dump-dom", probe.as_uri()],
        capture_output=True, text=True, timeout=50,
    ).stdout
    m = re.search(r'data-loaded="(\d+)/(\d+)"', out)
    assert m, f"page did not finish loading; chromium printed {out[:300]!r}"
    return int(m.group(1)), int(m.group(2))


def _gif() -> bytes:
    from PIL import Image

    frames = [Image.new("RGB", (8, 6), c) for c in ("red", "blue")]
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=100)
    return buf.getvalue()


def test_every_image_has_natural_width(tmp_path):
    run = tmp_path / "run"
    (run / "anim").mkdir(parents=True)
    (run / "f.png").write_bytes(PNG_1x1)
    (run / "anim" / "animation.gif").write_bytes(_gif())
    # a real figure: a small mu-space map written by `qsplan muspace`
    system = Path(__file__).parents[2] / "scenarios" / "data" / "example_4_1.json"
    assert main(["muspace", str(system), "--vary", "1,2", "--n", "12", "--out",
                 str(run / "mu")]) == 0
    page = write_report(run, tmp_path / "report.html")
    loaded, total = _loaded_images(page, tmp_path / "profile")
    assert total == 3
    assert loaded == total


def test_probe_detects_a_broken_image(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "good.png").write_bytes(PNG_1x1)
    (run / "broken.png").write_bytes(PNG_1x1[:20])  # truncated: the browser cannot decode it
    page = write_report(run, tmp_path / "report.html")
    assert _loaded_images(page, tmp_path / "profile") == (1, 2)


@pytest.mark.slow
def test_demo_report_images_load(tmp_path):
    """The real thing: every figure and GIF of `qsplan demo --quick` renders in Chromium."""
    from qsplan.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    if "demo" not in sub.choices:
        pytest.skip("qsplan demo is not registered yet")
    out = tmp_path / "report"
    main(["-q", "demo", "--quick", "--out", str(out)])  # exit 1/3 still writes the report
    page = out / "index.html"
    assert page.exists(), "qsplan demo wrote no index.html"
    loaded, total = _loaded_images(page, tmp_path / "profile")
    assert total >= 4
    assert loaded == total


PROBE = ("<script>window.onload=()=>{const i=document.querySelector(\"img[alt='problem.png']\");"
         "const r=i.getBoundingClientRect();document.body.setAttribute('data-problem',"
         "[r.x,r.y,r.width,r.height,i.naturalWidth].map(Math.round).join(','))}</script></body>")
WINDOW = (1100, 1000)


def _problem_rect(page: Path, profile: Path) -> tuple[int, int, int, int, int]:
    """Where the problem drawing sits on the page, as laid out by Chromium at WINDOW:
    ``(x, y, width, height, naturalWidth)`` in CSS pixels."""
    probe = page.with_name("probe_problem.html")
    probe.write_text(page.read_text().replace("</body>", PROBE))
    out = subprocess.run(
        [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", "--hide-scrollbars",
         f"--window-size={WINDOW[0]},{WINDOW[1]}", "--dump-dom", probe.as_uri()],
        capture_output=True, text=True, timeout=50).stdout
    m = re.search(r'data-problem="(\d+),(\d+),(\d+),(\d+),(\d+)"', out)
    assert m, f"no problem drawing on the page; chromium printed {out[:300]!r}"
    x, y, w, h, nat = (int(v) for v in m.groups())
    return x, y, w, h, nat


def screenshot(page: Path, out: Path, profile: Path) -> Path:
    """A screenshot of ``page`` (the top WINDOW pixels) taken by headless Chromium."""
    subprocess.run([str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", "--hide-scrollbars",
                    f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--screenshot={out}",
                    page.as_uri()], capture_output=True, text=True, timeout=50)
    assert out.exists(), "chromium wrote no screenshot"
    return out


def test_screenshot_of_a_run_report_shows_the_problem_drawing(tmp_path):
    """``qsplan simulate`` of the geometry-first box writes problem.png (its ``qsplan draw``) into
    the run folder; the report shows it first; in Chromium's screenshot the drawing's area holds
    the workpiece's fill (tab:blue at alpha 0.2 on white: about (210, 227, 240)) and the red
    contact markers (tab:red (214, 39, 40)), i.e. the drawing itself, rendered, at the top."""
    from PIL import Image

    run = tmp_path / "run"
    system = Path(__file__).parents[2] / "scenarios" / "data" / "geometry_box_low.json"
    assert main(["-q", "simulate", str(system), "--duration", "0.5", "--out", str(run)]) == 0
    assert (run / "problem.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = write_report(run, tmp_path / "report.html")
    x, y, w, h, natural = _problem_rect(page, tmp_path / "profile")
    assert natural > 0 and w > 300 and h > 200 and y + h <= WINDOW[1]  # decoded, on screen
    shot = Image.open(screenshot(page, tmp_path / "shot.png", tmp_path / "profile2"))
    pixels = np.asarray(shot.convert("RGB").crop((x, y, x + w, y + h)), dtype=int)
    fill = np.all(np.abs(pixels - (210, 227, 240)) <= 6, axis=2).mean()
    red = np.all(np.abs(pixels - (214, 39, 40)) <= 20, axis=2).sum()
    assert fill > 0.05, f"workpiece fill covers {fill:.1%} of the drawing"
    assert red >= 20, f"{red} contact-red pixels"
    # outside the drawing (the table below it) there is no workpiece fill: the check can fail
    below = np.asarray(shot.convert("RGB").crop((0, y + h + 60, WINDOW[0], WINDOW[1])), dtype=int)
    assert np.all(np.abs(below - (210, 227, 240)) <= 6, axis=2).mean() < 0.01
