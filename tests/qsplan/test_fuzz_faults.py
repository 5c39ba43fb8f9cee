"""Process-level faults, a seeded handful (the long campaign: ``benchmarks/fuzz_cli.py
--faults``): real signals at random times, closed pipes, concurrent writers, tiny, read-only
and revoked file systems.  The contract is :func:`cli_fuzz_faults.check_run`'s."""

from __future__ import annotations

import random

import pytest
from cli_fuzz_faults import (
    FS_FAULTS,
    concurrent_fault,
    fs_fault,
    jobs,
    pipe_fault,
    reference,
    signal_fault,
    unshare_prefix,
)
from cli_fuzz_inputs import make_fixtures


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    root = tmp_path_factory.mktemp("faults")
    fx = make_fixtures(root / "fx")
    table = jobs(fx.plan, fx.run_dir)
    return root, table, {}


def _ref(setup, name):
    root, table, refs = setup
    if name not in refs:
        refs[name] = reference(table[name], root / f"ref-{name.replace(' ', '_')}",
                               root / "logs")
    return table[name], refs[name]


@pytest.mark.parametrize("name,seed", [("muspace", 1), ("muspace", 2), ("sweep scenes", 3)])
@pytest.mark.long
def test_signal_at_a_random_time(setup, tmp_path, name, seed):
    job, ref = _ref(setup, name)
    run = signal_fault(job, ref, tmp_path / "run", tmp_path / "logs", random.Random(seed))
    assert run.problems == [], (run.detail, run.code, run.stderr)


@pytest.mark.parametrize("name,seed", [("muspace", 4), ("report", 5)])
@pytest.mark.long
def test_closed_stdout(setup, tmp_path, name, seed):
    job, ref = _ref(setup, name)
    run = pipe_fault(job, ref, tmp_path / "run", tmp_path / "logs", random.Random(seed))
    assert run.problems == [], (run.detail, run.code, run.stderr)


@pytest.mark.long
def test_concurrent_writers(setup, tmp_path):
    job, _ = _ref(setup, "muspace")
    run = concurrent_fault(job, [("--range", "0:1", "--n", "20"), ("--range", "0:0.5", "--n",
                                                                     "20")],
                           tmp_path / "run", tmp_path / "logs")
    assert run.problems == [], (run.code, run.stderr)


@pytest.mark.skipif(unshare_prefix() is None, reason="no private mount namespace here")
@pytest.mark.parametrize("kind", FS_FAULTS)
def test_file_system_faults(setup, tmp_path, kind):
    job, ref = _ref(setup, "muspace")
    run = fs_fault(job, ref, tmp_path / "run", tmp_path / "logs", random.Random(7), kind)
    assert run.problems == [], (run.detail, run.code, run.stderr)
