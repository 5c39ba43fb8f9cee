"""The report renders every figure in headless Chromium (skipped when Chromium is absent)."""

import re
import subprocess
from pathlib import Path

import pytest

from planner.report import write_report

PNG_1x1 = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201a5f7a3"
    "5e0000000049454e44ae426082"
)
CHROMIUM = Path("/usr/bin/chromium")
pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason="/usr/bin/chromium not installed")

CHECK = ("<script>window.onload=()=>{const i=[...document.images];document.body.setAttribute("
         "'data-loaded',i.filter(x=>x.naturalWidth>0).length+'/'+i.length)}</script></body>")


def test_every_image_has_natural_width(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (run / "f.png").write_bytes(PNG_1x1)
    page = write_report(run)
    page.write_text(page.read_text().replace("</body>", CHECK))
    out = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}", "--dump-dom",
         page.as_uri()],
        capture_output=True, text=True, timeout=50,
    ).stdout
    m = re.search(r'data-loaded="(\d+)/(\d+)"', out)
    assert m, "page did not finish loading"
    assert int(m.group(2)) >= 1 and m.group(1) == m.group(2)
