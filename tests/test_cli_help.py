"""Every registered subcommand has a useful --help; bad input exits 2."""

import pytest

from planner.cli import build_parser, main


def _commands():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return sorted(sub.choices.items())


# Known gaps in files owned by other engineers (strict: the mark must go once they are fixed).
MISSING_DESCRIPTION: set[str] = set()


def _params():
    out = []
    for name, parser in _commands():
        marks = [pytest.mark.xfail(strict=True, reason=f"planner/commands/{name}.py sets no "
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
