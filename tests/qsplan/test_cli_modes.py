"""``qsplan modes``: table and JSON output, exit codes."""

from __future__ import annotations

import json

import numpy as np

from qsplan.cli import main


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


def test_modes_search_gives_the_exhaustive_modes(capsys, tmp_path):
    """``--search`` (pruned, optionally on 2 processes) prints the same modes and forces as
    the exhaustive default, plus how many candidates it tested."""
    from planner.files.system_file import save_system
    from planner.sweeps.random_systems import random_system

    path = save_system(random_system(1, 9), tmp_path / "r9.json")
    outs = []
    for extra in ([], ["--search"], ["--search", "--workers", "2"]):
        assert main(["modes", str(path), "--json", "--no-indeterminate", *extra]) == 0
        outs.append(json.loads(capsys.readouterr().out))
    for out in outs[1:]:
        assert out.pop("search")["tested"] < out["candidates"]
        assert out["status"] == outs[0]["status"]
        assert [m["mode"] for m in out["modes"]] == [m["mode"] for m in outs[0]["modes"]]
        for m, ref in zip(out["modes"], outs[0]["modes"]):  # same to rounding (batched BLAS)
            for key in ("qdot", "contact_forces", "joint_efforts"):
                assert np.allclose(m[key], ref[key], rtol=1e-12, atol=1e-12), key
    assert main(["modes", str(path), "--search"]) == 0
    assert "kinematic tests for the" in capsys.readouterr().out
    assert main(["modes", str(path), "--workers", "2"]) == 2
    assert "expected together with --search" in capsys.readouterr().err
    assert main(["modes", str(path), "--search", "--workers", "0"]) == 2
    assert "--workers: expected an integer in 1..1024, got 0" in capsys.readouterr().err
