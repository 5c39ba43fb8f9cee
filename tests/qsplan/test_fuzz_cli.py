"""The command line at its edges: a fuzz campaign over every subcommand.

Hostile inputs -- broken JSON, wrong types, NaN/Infinity, huge numbers, missing and unknown
keys in system, hand and plan files; NaN/inf/absurd option values; unwritable, special and
wrong-kind output paths -- are fed to ``qsplan.cli.main`` in-process.  The contract checked on
every input (:func:`run_case`):

* no traceback (no exception escapes ``main``, none is printed);
* an input built to be bad exits 2, with a message that says what was expected and what came;
* no partial output set: a run that does not finish (exit 2 or 3) leaves every file of the
  fixture folder as it was (old outputs whole, no new or empty folders), a run that finishes
  leaves no staging folder and writes its whole set; special files stay special.

This module keeps a seeded subset short (seconds); ``benchmarks/fuzz_cli.py`` runs the long
campaign with the same generator and prints the table of docs/robustness.md.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from cli_fuzz_cases import COMMANDS, generate, problems, run_case
from cli_fuzz_formats import FORMAT_GENERATORS, generate_formats, make_formats
from cli_fuzz_inputs import DATA, OLD, ROOT, make_fixtures


# ---------------------------------------------------------------------------------------------
# The short campaign (seeded) and targeted tests.
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fx(tmp_path_factory):
    return make_fixtures(tmp_path_factory.mktemp("fuzz_cli"))


@pytest.fixture(scope="module")
def ff(fx):
    return make_formats(fx)


@pytest.fixture(autouse=True)
def _log_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("QSPLAN_LOG_DIR", str(tmp_path / "logs"))


# Cheap commands get more inputs; plan costs ~0.5 s per accepted input.
SHORT = {"modes": 40, "muspace": 14, "plan": 6, "validate": 10, "simulate": 10, "demo": 8,
         "scenarios": 10,
         "sweep": 12, "report": 12}


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.long
def test_short_campaign(fx, command):
    cases = generate(fx, seed=COMMANDS.index(command), per_command=SHORT[command],
                     commands=(command,))
    outcomes = [run_case(c, fx) for c in cases]
    assert problems(outcomes) == []
    codes = {o.code for o in outcomes}
    assert 2 in codes  # the campaign really reached the error paths


@pytest.mark.parametrize("command", sorted(FORMAT_GENERATORS))
def test_short_campaign_newer_formats(fx, ff, command):
    """Geometry, chain and multi-body system files, hand files with a goal, version-2 plans,
    ``scenarios run --set``, hostile run folders, special files inside output sets."""
    cases = generate_formats(fx, ff, seed=sorted(FORMAT_GENERATORS).index(command),
                             per_command=8, commands=(command,))
    outcomes = [run_case(c, fx) for c in cases]
    assert problems(outcomes) == []
    assert 2 in {o.code for o in outcomes} or command == "report"


def test_unexpected_exception_is_one_line_and_a_log(monkeypatch, capsys, tmp_path):
    from qsplan.cli import main

    def boom(args):
        raise ZeroDivisionError("simulated internal fault")

    parser_args = ["modes", str(DATA / "example_4_1.json")]
    import qsplan.cli as cli

    real = cli.build_parser

    def patched():
        p = real()
        p._subparsers._group_actions[0].choices["modes"].set_defaults(func=boom)
        return p

    monkeypatch.setattr(cli, "build_parser", patched)
    assert main(parser_args) == 3
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert "internal fault: ZeroDivisionError: simulated internal fault" in err
    log = Path(err.split("traceback in ")[1].split(";")[0])
    assert log.parent == tmp_path / "logs" and "Traceback" in log.read_text()
    assert main(parser_args + ["--debug"]) == 3
    assert "Traceback (most recent call last)" in capsys.readouterr().err


def test_argparse_errors_say_expected_and_got(capsys):
    from qsplan.cli import main

    for argv, text in [(["modes", "x", "--workers", "two"],
                        "argument --workers: expected an integer, got 'two'"),
                       (["sweep", "nope", "--out", "x"], "expected one of 'mu', 'scenes', got"),
                       (["muspace", "x"], "expected the arguments --vary, --out, got none")]:
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2 and text in capsys.readouterr().err


@pytest.mark.parametrize("target", ["/dev/null", "fifo", "link_to_fifo"])
def test_special_output_paths_are_refused_not_replaced(fx, capsys, target):
    from qsplan.cli import main

    path = target if target.startswith("/") else str(fx.root / target)
    kind_before = stat.S_IFMT(os.stat(path).st_mode)
    for argv in (["muspace", str(fx.system), "--vary", "1,2", "--n", "2", "--out", path],
                 ["plan", str(fx.hand), "--out", path, "--waypoints", "2"],
                 ["sweep", "mu", str(fx.system), "--grid", "1", "--out", path]):
        assert main(argv) == 2
        assert "it is not replaced" in capsys.readouterr().err
    assert stat.S_IFMT(os.stat(path).st_mode) == kind_before


def test_failed_run_keeps_the_old_output_set(fx, monkeypatch, capsys):
    """muspace writes its JSON, then the PNG fails: the old pair stays, no new JSON."""
    import planner.plots.muspace as plots
    from qsplan.cli import main

    out = fx.fresh("keep")
    out.mkdir()
    (out / "muspace.json").write_bytes(OLD)
    (out / "muspace.png").write_bytes(OLD)
    (out / "notes.txt").write_bytes(b"mine")

    def fail(*a, **k):
        raise OSError("simulated disk full while drawing")

    monkeypatch.setattr(plots, "plot_slices", fail)
    argv = ["muspace", str(fx.system), "--vary", "1,2", "--n", "2", "--out", str(out)]
    assert main(argv) == 3
    assert "simulated disk full" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["muspace.json", "muspace.png", "notes.txt"]
    assert (out / "muspace.json").read_bytes() == OLD == (out / "muspace.png").read_bytes()
    monkeypatch.undo()
    assert main(argv) == 0
    assert (out / "muspace.json").read_bytes() != OLD != (out / "muspace.png").read_bytes()
    assert (out / "notes.txt").read_bytes() == b"mine"  # other files are left alone


def test_failed_run_leaves_no_new_folder(fx):
    from qsplan.cli import main

    out = fx.fresh("never") / "deeper"
    assert main(["muspace", str(fx.system), "--vary", "1,2", "--range", "0.5:0.1",
                 "--out", str(out)]) == 2
    assert main(["muspace", str(fx.root / "missing.json"), "--vary", "1,2",
                 "--out", str(out)]) == 2
    assert not out.parent.exists()


def test_too_large_exhaustive_enumeration_is_refused_with_its_size(tmp_path, capsys):
    """1200 contacts: C(1200, 3) + 1200 * 1199 > 2e8 candidates (eq. 49).  Exhaustive enumeration
    streams in bounded memory, but a request this large is refused at once with its size and
    the way out (--search), never attempted."""
    import numpy as np

    from planner.model.modes import candidate_count
    from planner.predict.feasibility import MAX_EXHAUSTIVE_CANDIDATES
    from qsplan.cli import main

    rng = np.random.default_rng(0)
    n = 1200
    assert candidate_count(n, 3) > MAX_EXHAUSTIVE_CANDIDATES
    angles = rng.uniform(0, 2 * np.pi, n)
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    points = rng.normal(size=(n, 2))
    cols = []
    for (nx, ny), (px, py) in zip(normals, points):
        for x, y in ((nx, ny), (-ny, nx)):
            cols.append([x, y, px * y - py * x])
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"wrench_matrix": np.array(cols).T.tolist(), "mu": [0.3] * n,
                                "external_wrench": [0, -1, 0], "manipulator": {
                                    "contact_velocities": rng.normal(size=(n, 2)).tolist()}}))
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"expected at most {MAX_EXHAUSTIVE_CANDIDATES} candidate modes" in err, err
    assert str(candidate_count(n, 3)) in err and "--search" in err, err


def test_help_texts_show_defaults_and_no_markup(capsys):
    from qsplan.cli import build_parser, main

    parser = build_parser()
    names = sorted(parser._subparsers._group_actions[0].choices)
    for name in names:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        text = capsys.readouterr().out
        assert "%%" not in text and "``" not in text and ":func:" not in text, name
        assert "issue" not in text.lower(), name
    with pytest.raises(SystemExit):
        main(["muspace", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 0:1)" in text and "(default: 4)" in text


def test_numbers_are_printed_plainly(capsys):
    import numpy as np

    from qsplan.cli import main
    from qsplan.options import fmt, fmt_list

    assert fmt(-0.0) == "0" and fmt(np.float64(-1e-9), ".3f") == "0.000"
    assert fmt(-1e-9, "+.5f") == "+0.00000" and fmt(-2.5, ".2f") == "-2.50"
    assert fmt_list(np.array([-0.0, 1.5, -1e-20])) == "[0, 1.5, -1e-20]"

    assert main(["modes", str(DATA / "example_4_3.json"), "--mu", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "np.float64" not in out and "-0 " not in out and "-0.0 " not in out
    assert " -0," not in out and "[-0," not in out


@pytest.mark.parametrize("argv,message", [
    (["muspace", "{sys}", "--vary", "nan,1", "--out", "{tmp}/m"],
     "--vary: expected a contact index in 1..3 or a friction group (the file names none), "
     "got 'nan'"),
    (["muspace", "{sys}", "--vary", "1,2", "--range", "1e308:1e308", "--out", "{tmp}/m"],
     "--range: expected a number in [0, 1e+06], got '1e308'"),
    (["muspace", "{sys}", "--vary", "1,2", "--range", "0,1", "--out", "{tmp}/m"],
     "--range: expected LO:HI, e.g. 0:1, got '0,1' (a comma is not a range separator)"),
    (["plan", "two_finger_hand", "--mu", "0:1e308", "--out", "{tmp}/p.json"],
     "--mu: expected a number in [0, 1e+06], got '1e308'"),
    (["sweep", "mu", "{sys}", "--grid", "1000", "--out", "{tmp}/s.json"],
     "got a grid of 1000^3 = 1000000000 friction points, which would need"),
    (["validate", "{sys}", "--out", "/dev/null"],
     "--out: expected a directory or a new path, got '/dev/null', which is a character device"),
    (["validate", "{sys}", "--out", "{sys}"], "which is a regular file; it is not replaced"),
])
def test_messages_of_the_known_edge_cases(argv, message, tmp_path, capsys):
    from qsplan.cli import main

    sys_path = tmp_path / "s.json"
    sys_path.write_text((DATA / "example_4_1.json").read_text())
    assert main([a.replace("{sys}", str(sys_path)).replace("{tmp}", str(tmp_path))
                 for a in argv]) == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


@pytest.mark.long
def test_subprocess_edges(tmp_path):
    """The console path: exit codes and stderr of a real process (no traceback, one line)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg",
           "QSPLAN_LOG_DIR": str(tmp_path / "logs")}
    sys_file = str(DATA / "example_4_1.json")
    runs = [
        (["validate", sys_file, "--out", "/dev/null"], 2),
        (["muspace", sys_file, "--vary", "1,2", "--out", str(tmp_path / "x" / "y"),
          "--n", "2", "--memory-gib", "1e-9"], 2),
        (["modes", sys_file, "--mu", "0.1"], 0),
    ]
    for argv, code in runs:
        res = subprocess.run([sys.executable, "-m", "qsplan.cli", *argv], env=env,
                             capture_output=True, text=True, timeout=120)
        assert res.returncode == code, res.stderr
        assert "Traceback" not in res.stderr
        assert code == 0 or len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()
