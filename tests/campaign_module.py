"""Scripts of ``benchmarks/`` loaded as modules for the tests that run their parts (the
benchmarks directory is not a package)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


def benchmark(name: str) -> ModuleType:
    """``benchmarks/<name>.py`` as a module (fresh on every call)."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def campaign() -> ModuleType:
    """The validation campaign script as a module (fresh on every call)."""
    return benchmark("validation_campaign")
