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


@pytest.fixture(scope="session")
def figure9_plan():
    """The Figure 9 task planned with the defaults (``plan_hand`` of the shipped file), once per
    test process: the task planning, its run, its mirror image and its acute tip read it."""
    from planner.plan.hand_planner import plan_hand

    return plan_hand(DATA / "figure9_task_hand.json")
