import json
from pathlib import Path

import pytest

from planner.errors import InputError
from qsplan.report import build_html, scan_run, write_report

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


def test_plan_table_and_info_rows(tmp_path):
    (tmp_path / "hand").mkdir()
    (tmp_path / "hand" / "plan.json").write_text(json.dumps({
        "format": "qsplan-plan", "claim": "S+1 S+2 S-3 S-4", "policy": "midband",
        "control": ["effort", "velocity"], "mu": {"model": "common", "intervals": [[0.0, 0.2]]},
        "event": {"kind": "new contact", "detail": "vertex 4", "t": 13.3},
        "waypoints": [{"margin": 0.003}, {"margin": 0.00117}, {"margin": 0.002}]}))
    (tmp_path / "hand" / "bounds.png").write_bytes(PNG_1x1)
    (tmp_path / "summary.json").write_text(json.dumps({"scenario": "muspace_ex41"}))
    page = build_html(tmp_path)
    assert "S+1 S+2 S-3 S-4" in page and "0.00117" in page and "new contact (vertex 4)" in page
    assert "class='info'" in page and "0 of 1 summaries passed" in page
    assert "<h3>hand</h3>" in page


def test_garbage_json_does_not_break_the_page(tmp_path):
    (tmp_path / "summary.json").write_text("{not json")
    (tmp_path / "plan.json").write_text(json.dumps({"format": "qsplan-plan", "waypoints": 3,
                                                    "mu": "x", "control": 5}))
    page = build_html(tmp_path)
    assert "summary.json" in page and "plan.json" in page


def test_checks_file_is_shown_first(tmp_path):
    (tmp_path / "checks.json").write_text(json.dumps({
        "task": "two-finger task", "held": False, "checks": [
            {"check": "planning time", "expected": "<= 5 s", "measured": "2.5 s", "held": True},
            {"check": "negative control fails", "expected": "fails", "measured": "passed",
             "held": False}]}))
    (tmp_path / "summary.json").write_text(json.dumps({"scenario": "x", "passed": True}))
    page = build_html(tmp_path)
    assert scan_run(tmp_path).checks == (Path("checks.json"),)
    assert "NOT every expectation held" in page and "1 of 2 checks" in page
    assert page.index("negative control fails") < page.index("<th>scenario</th>")


def test_the_story_comes_first_then_the_torque_regions_then_the_tables(tmp_path):
    """A demo folder: story/ figures, then figures/ (Figs. 10-13), then the tables, then the
    other figures."""
    import json as _json

    from qsplan.report import build_html

    png = bytes.fromhex("89504e470d0a1a0a")  # the PNG signature is enough to embed
    for rel in ("story/task_story.png", "figures/fig13_guaranteed.png",
                "task/pymunk/timeline.png"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(png)
    (tmp_path / "task" / "pymunk" / "summary.json").write_text(_json.dumps(
        {"scenario": "whole task", "status": "agreed", "passed": True}))
    page = build_html(tmp_path)
    order = [page.index(x) for x in ("story/task_story.png", "figures/fig13_guaranteed.png",
                                     "<th>scenario</th>", "task/pymunk/timeline.png")]
    assert order == sorted(order)
    assert page.index("The task: start, segments and goal") < page.index("What held")


def test_problem_drawings_first_and_once(tmp_path):
    """problem.png of each run folder (the drawing of its source file) is shown before the
    tables; byte-identical drawings (one plan validated at several frictions) appear once."""
    from qsplan.report import build_html

    png = bytes.fromhex("89504e470d0a1a0a0000000d4948445200000001000000010806000000"
                        "1f15c4890000000d49444154789c6360f8cfc0f01f0005000201a5f7a3"
                        "5e0000000049454e44ae426082")
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "problem.png").write_bytes(png)
        (tmp_path / name / "timeline.png").write_bytes(png)
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "problem.png").write_bytes(png + b"\0")  # another problem
    page = build_html(tmp_path)
    head = page.index("The problem (qsplan draw")
    assert head < page.index("What held and what did not")
    section = page[head:page.index("What held and what did not")]
    assert "a/problem.png" in section and "c/problem.png" in section
    assert "b/problem.png" not in page and page.count("timeline.png</figcaption>") == 2
