"""Every registered subcommand has a useful --help; bad input exits 2."""

from pathlib import Path

import pytest

from qsplan.cli import build_parser, main


def _commands():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return sorted(sub.choices.items())


# Known gaps in files owned by other engineers (strict: the mark must go once they are fixed).
MISSING_DESCRIPTION: set[str] = set()


def _params():
    out = []
    for name, parser in _commands():
        marks = [pytest.mark.xfail(strict=True, reason=f"qsplan/commands/{name}.py sets no "
                                   "add_parser(description=...)")] if name in MISSING_DESCRIPTION else []
        out.append(pytest.param(name, parser, id=name, marks=marks))
    return out


@pytest.mark.parametrize("name,parser", _params())
def test_help_exits_zero_with_description(name, parser, capsys):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert len(parser.description or "") >= 40, f"{name}: description too short"
    assert name in capsys.readouterr().out


def test_report_bad_run_dir_exits_2(tmp_path, capsys):
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert "expected an existing directory" in capsys.readouterr().err


def test_no_command_exits_2():
    assert main([]) == 2


def test_readme_table_lists_every_subcommand():
    readme = (Path(__file__).resolve().parents[2] / "README.md").read_text()
    table = readme[readme.index("## Command line"):readme.index("## Documentation")]
    missing = [name for name, _ in _commands() if f"`qsplan {name}" not in table]
    assert not missing, f"README command table: expected a row for every subcommand, missing {missing}"


EX41 = str(Path(__file__).resolve().parents[2] / "scenarios" / "data" / "example_4_1.json")
BAD_INPUT = [
    ("modes", ["modes", "{tmp}/missing.json"], "expected an existing file"),
    ("modes", ["modes", EX41, "--mu", "a,b"], "--mu: expected comma-separated numbers"),
    ("modes", ["modes", EX41, "--mu", "0.3,0.2"], "expected 3 friction coefficients"),
    ("muspace", ["muspace", EX41, "--vary", "1", "--out", "{tmp}/m"], "--vary: expected"),
    ("plan", ["plan", "no_such_hand", "--out", "{tmp}/p.json"], "hand: expected a hand file path or one of ['block_tilting', 'box_pivot_down', 'box_pivot_up', 'figure9_task_hand', 'flip_against_wall', 'prismatic_finger_hand', 'side_push', 'table_push_hand', 'three_finger_hand', 'two_finger_hand', 'two_link_finger_hand']"),
    ("validate", ["validate", EX41, "--engine", "bullet"], "--engine: expected one of"),
    ("sweep", ["sweep", "mu", EX41, "--mu-range", "1,0", "--out", "{tmp}/s.json"],
     "--mu-range: expected LO <= HI"),
    ("scenarios", ["scenarios", "run", "nosuch", "--engine", "pymunk", "--out", "{tmp}/r"],
     "unknown scenario 'nosuch'"),
    ("report", ["report", "{tmp}/missing"], "expected an existing directory"),
    ("demo", ["demo", "--engines", "bullet", "--out", "{tmp}/d"], "--engines: expected names"),
]


@pytest.mark.parametrize("name,argv,message", BAD_INPUT,
                         ids=[f"{a[0]}-{i}" for i, a in enumerate(BAD_INPUT)])
def test_bad_input_exits_2_with_message(name, argv, message, tmp_path, capsys):
    registered = {n for n, _ in _commands()}
    if name not in registered:
        pytest.skip(f"qsplan {name} is not registered yet")
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert f"qsplan {name}: error:" in err and message in err, err
