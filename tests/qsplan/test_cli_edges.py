"""Edges of the command line the fuzz campaign reaches: each is bad input (exit 2) with a message
that says what was expected and what came, never an internal fault."""

from __future__ import annotations

import pytest


@pytest.mark.parametrize("address", ["not a url", "tcp://host:notaport"])
def test_unparsable_dask_address_is_bad_input(tmp_path, capsys, address):
    from qsplan.cli import main

    code = main(["sweep", "scenes", "--count", "1", "--contacts", "3", "--dask", address,
                 "--out", str(tmp_path / "s.json")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert (f"dask: expected a scheduler address such as tcp://host:8786, got {address!r}"
            in err)
    assert list(tmp_path.iterdir()) == []


def test_unknown_scenario_parameter_says_what_came(tmp_path, capsys):
    from qsplan.cli import main

    assert main(["scenarios", "run", "ex41_3s", "--out", str(tmp_path / "o"), "--set",
                 "nosuch=1"]) == 2
    err = capsys.readouterr().err
    assert "expected one of: mu; got 'nosuch'" in err
