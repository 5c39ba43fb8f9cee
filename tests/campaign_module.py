"""``benchmarks/validation_campaign.py`` loaded as a module for the tests that re-run its points
(the benchmarks directory is not a package)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def campaign() -> ModuleType:
    """The validation campaign script as a module (fresh on every call)."""
    spec = importlib.util.spec_from_file_location(
        "validation_campaign", ROOT / "benchmarks" / "validation_campaign.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
