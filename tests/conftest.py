"""Shared fixtures: the paper's example systems (from scenarios/data) and helpers."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

DATA = Path(__file__).resolve().parents[1] / "scenarios" / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    return DATA


@pytest.fixture(scope="session")
def example_41():
    from planner.files.system_file import load_system

    return load_system(DATA / "example_4_1.json")


@pytest.fixture(scope="session")
def example_43():
    from planner.files.system_file import load_system

    return load_system(DATA / "example_4_3.json")
