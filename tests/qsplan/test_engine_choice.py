"""Engine choice: every engine of the settings table is accepted wherever a user names one
(``qsplan simulate / validate / scenarios run --engine``, ``qsplan demo --engines``); an
unknown name, or an engine whose optional package is missing (DART without ``dartpy``), is bad
input (exit 2) with a message that names the choices or the install command -- never a
traceback. Runs without any optional engine installed."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from planner.errors import InputError
from sim.backends import BACKENDS, DEFAULT_ENGINES, ENGINES, PACKAGES, make_backend, require_engine
from sim.settings import SETTINGS, SceneKind

ROOT = Path(__file__).resolve().parents[2]
BOX = str(ROOT / "scenarios" / "data" / "box_on_table_high.json")


def test_engines_come_from_the_settings_table():
    assert ENGINES == ("pymunk", "mujoco", "dart")
    assert set(DEFAULT_ENGINES) == {"pymunk", "mujoco"}
    for engine in ENGINES:
        assert engine in BACKENDS and engine in PACKAGES
        assert all((kind, engine) in SETTINGS for kind in SceneKind)


@pytest.fixture
def without_dartpy(monkeypatch):
    """The machine as a user without ``qsplan[dart]`` has it."""
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a, **k: None if name == "dartpy" else real(name, *a, **k))


MISSING = r"engine 'dart' needs the Python package 'dartpy'.*pip install 'qsplan\[dart\]'"


def test_missing_engine_package_is_input_error(without_dartpy):
    with pytest.raises(InputError, match=MISSING):
        require_engine("dart")
    with pytest.raises(InputError, match=MISSING):
        make_backend("dart")
    with pytest.raises(InputError, match="engine: expected one of pymunk, mujoco, dart, got 'x'"):
        require_engine("x")


@pytest.mark.parametrize("argv", [
    ["simulate", BOX, "--engine", "dart"],
    ["scenarios", "run", "ex41_3s", "--engine", "dart", "--out", "{tmp}/o"],
    ["demo", "--engines", "pymunk,dart", "--out", "{tmp}/d"],
])
def test_cli_without_dartpy_exits_2_naming_the_extra(argv, without_dartpy, tmp_path, capsys):
    from qsplan.cli import main

    code = main([a.replace("{tmp}", str(tmp_path)) for a in argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "pip install 'qsplan[dart]'" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists() and not (tmp_path / "d").exists()


def test_cli_unknown_engine_lists_the_choices(capsys):
    from qsplan.cli import main

    assert main(["simulate", BOX, "--engine", "bullet"]) == 2
    assert "--engine: expected one of pymunk, mujoco, dart, got 'bullet'" in capsys.readouterr().err


def test_demo_runs_every_installed_engine_by_default():
    import argparse

    from qsplan.commands import demo

    sub = argparse.ArgumentParser().add_subparsers()
    demo.register(sub)
    assert sub.choices["demo"].get_default("engines") is None
    expected = ["pymunk", "mujoco"] + (["dart"] if importlib.util.find_spec("dartpy") else [])
    assert demo.chosen_engines(None) == expected
    if "dart" in expected:
        assert demo.chosen_engines("dart,pymunk,dart") == ["dart", "pymunk"]


def test_demo_without_dartpy_runs_the_two_others(without_dartpy):
    from qsplan.commands import demo

    assert demo.chosen_engines(None) == ["pymunk", "mujoco"]
    with pytest.raises(InputError, match=MISSING):
        demo.chosen_engines("pymunk,dart")


def test_demo_with_dart_in_the_registry_and_not_installed(monkeypatch):
    """An engine added to the registry whose package is missing is left out of the default."""
    import sim.backends as backends
    from qsplan.commands import demo

    monkeypatch.setitem(backends.PACKAGES, "dart", ("no_such_package_qsplan", "pip install x"))
    assert demo.chosen_engines(None) == ["pymunk", "mujoco"]


@pytest.mark.parametrize("text, message", [
    ("pymunk,,dart", "--engine: expected one of pymunk, mujoco, dart or several of them "
                     "comma-separated, got 'pymunk,,dart'"),
    ("pymunk,bullet", "--engine: expected one of pymunk, mujoco, dart, got 'bullet'"),
])
def test_several_engines_bad_input(text, message, capsys):
    from qsplan.cli import main

    assert main(["simulate", BOX, "--engine", text]) == 2
    assert message in capsys.readouterr().err
