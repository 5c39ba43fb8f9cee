import json

import pytest

from planner.errors import InputError
from planner.report import build_html, scan_run, write_report

PNG_1x1 = bytes.fromhex(
    "89504e470d0a1a0a0000000d4948445200000001000000010806000000"
    "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201a5f7a3"
    "5e0000000049454e44ae426082"
)


def _run_dir(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "map.png").write_bytes(PNG_1x1)
    (tmp_path / "a" / "summary.json").write_text(json.dumps(
        {"scenario": "ex41", "engine": "pymunk", "expect": "agree", "agreement": 0.97,
         "passed": True}))
    (tmp_path / "summary_bad.json").write_text(json.dumps(
        {"scenario": "ex43", "engine": "mujoco", "passed": False}))
    (tmp_path / "plan.json").write_text(json.dumps({"waypoints": []}))
    return tmp_path


def test_scan_finds_everything(tmp_path):
    found = scan_run(_run_dir(tmp_path))
    assert [str(p) for p in found.images] == ["a/map.png"]
    assert len(found.summaries) == 2 and len(found.plans) == 1


def test_html_embeds_images_and_rows(tmp_path):
    page = build_html(_run_dir(tmp_path))
    assert page.count("data:image/png;base64,") == 1
    assert "ex41" in page and "ex43" in page and "class='bad'" in page
    out = write_report(tmp_path)
    assert out.read_text() == page


def test_missing_dir(tmp_path):
    with pytest.raises(InputError, match="expected an existing directory"):
        scan_run(tmp_path / "nope")
