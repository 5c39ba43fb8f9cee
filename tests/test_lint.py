"""ruff and mypy are clean on the packages (the project's rule: "mypy and ruff clean in CI").

Both run from the ``test`` extra, so the README's test command checks them on a fresh machine;
their configuration is in ``pyproject.toml``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)


def test_ruff_is_clean():
    res = _run("ruff", "check", "--no-cache", ".")
    assert res.returncode == 0, res.stdout + res.stderr


@pytest.mark.long
def test_mypy_is_clean_on_every_package():
    res = _run("mypy", "--no-incremental")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Success: no issues found" in res.stdout, res.stdout
