"""The memory budget is checked from the input's size before anything is allocated.

``planner.files.reader``: parsing a file of S bytes is refused when ``S *
PARSE_BYTES_PER_BYTE`` exceeds the budget (``--memory-gib``, ``$QSPLAN_MEMORY_GIB``); a
loader's ``cost=`` (what it will allocate from the parsed value) is checked before the value is
returned; reading never allocates more than the file's size."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import pytest

from planner.errors import InputError
from planner.files.reader import (
    GIB,
    PARSE_BYTES_PER_BYTE,
    dense_bytes,
    memory_budget,
    parse_json,
    read_json,
    set_memory_budget,
)

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


@pytest.fixture(autouse=True)
def _reset_budget(monkeypatch):
    monkeypatch.delenv("QSPLAN_MEMORY_GIB", raising=False)
    yield
    set_memory_budget(None)


def test_parsing_beyond_the_budget_is_refused_from_the_size(tmp_path, capsys):
    from qsplan.cli import main

    path = tmp_path / "s.json"
    path.write_text((DATA / "example_4_1.json").read_text())
    size = path.stat().st_size
    gib = 0.5 * size * PARSE_BYTES_PER_BYTE / GIB  # half of what the parse may take
    assert main(["modes", str(path), "--memory-gib", f"{gib:.6g}"]) == 2
    err = capsys.readouterr().err
    assert (f"expected a request within the memory budget ({gib:.3g} GiB), got system file "
            f"'{path}' of {size} bytes, whose parsing, which would need") in err, err
    assert main(["modes", str(path), "--memory-gib", f"{4 * gib:.6g}"]) == 0


def test_the_environment_budget_counts_too(tmp_path, monkeypatch, capsys):
    from qsplan.cli import main

    monkeypatch.setenv("QSPLAN_MEMORY_GIB", "1e-9")
    assert main(["modes", str(DATA / "example_4_1.json")]) == 2
    assert "expected a request within the memory budget" in capsys.readouterr().err
    monkeypatch.setenv("QSPLAN_MEMORY_GIB", "lots")
    assert main(["modes", str(DATA / "example_4_1.json")]) == 2
    assert "QSPLAN_MEMORY_GIB: expected a number in [0, 1e+06], got 'lots'" in \
        capsys.readouterr().err


def test_a_loaders_cost_is_checked_before_it_allocates(tmp_path):
    """A loader states what it will build from the parsed value: here a dense
    (2 n_c, 2 n_c) Jacobian of 20,000 contacts (11.9 GiB), refused at once."""
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"contacts": [[0.0, 1.0]] * 20_000}))
    seen = []

    def cost(value):
        seen.append(len(value["contacts"]))
        n = len(value["contacts"])
        return dense_bytes(2 * n, 2 * n), f"a dense ({2 * n}, {2 * n}) Jacobian"

    with pytest.raises(InputError, match=r"got system file '.*big.json': a dense \(40000, "
                                         r"40000\) Jacobian, which would need 11.9 GiB"):
        read_json(path, "system file", cost=cost)
    assert seen == [20_000]
    set_memory_budget(16 * GIB)
    assert len(read_json(path, "system file", cost=cost)["contacts"]) == 20_000


def test_reading_allocates_no_more_than_the_file(tmp_path):
    path = tmp_path / "small.json"
    path.write_text('{"a": [1, 2, 3]}')
    tracemalloc.start()
    read_json(path, "file")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 1_000_000  # it was a 64 MiB buffer for any file


def test_budget_sources():
    assert memory_budget() == 4 * GIB
    set_memory_budget(123)
    assert memory_budget() == 123
    set_memory_budget(None)
    assert dense_bytes(40_000, 40_000) == 12_800_000_000


@pytest.mark.parametrize("text", ["[0.5]", "[[]]", "[{}]", "[[0.5,0.5]]"])
@pytest.mark.long
def test_parse_memory_stays_under_the_bound(text):
    """The measured peak of the worst JSON shapes (docs/robustness.md) is below
    PARSE_BYTES_PER_BYTE."""
    inner = text[1:-1]
    big = ("[" + ",".join([inner] * 100_000) + "]").encode()
    tracemalloc.start()
    parse_json(big, "x")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak / len(big) < PARSE_BYTES_PER_BYTE
