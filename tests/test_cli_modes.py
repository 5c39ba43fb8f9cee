"""``qsplan modes``: table and JSON output, exit codes."""

from __future__ import annotations

import json

from planner.cli import main


def test_modes_json(capsys, data_dir):
    code = main(["modes", str(data_dir / "example_4_3.json"), "--mu", "0.5,0.5,0.5", "--json"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["status"] == "ambiguous" and out["candidates"] == 7
    labels = {m["mode"] for m in out["modes"]}
    assert len(labels) == 3
    for m in out["modes"]:
        assert set(m) >= {"mode", "qdot", "joint_velocities", "contact_forces", "joint_efforts",
                          "force_indeterminate"}
        assert len(m["qdot"]) == 3 and len(m["contact_forces"]) == 3


def test_modes_table_and_jam(capsys, data_dir):
    assert main(["modes", str(data_dir / "example_4_1.json"), "--mu", "0.9,0.9,0.9"]) == 0
    out = capsys.readouterr().out
    assert "status: jammed" in out and "no feasible mode" in out
    assert main(["modes", str(data_dir / "example_4_1.json"), "--mu", "0.1"]) == 0
    assert "mode S+1 S-2 S-3  (3S)" in capsys.readouterr().out


def test_modes_bad_input_exit_2(capsys, tmp_path, data_dir):
    assert main(["modes", str(data_dir / "example_4_1.json"), "--mu", "0.1,x,0.2"]) == 2
    assert "--mu: expected comma-separated numbers, got 'x'" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["modes", str(bad)]) == 2
    assert "expected valid JSON" in capsys.readouterr().err
    assert main(["modes", str(data_dir / "example_4_1.json"), "--mu", "0.1,0.2"]) == 2
    assert "expected 3 friction coefficients" in capsys.readouterr().err
