"""Executor abstraction: the same sweep locally (processes) and through Dask (LocalCluster)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.model.modes import enumerate_modes
from planner.predict.feasibility import feasible_modes
from planner.sweeps.executor import (
    LocalExecutor,
    enumerate_modes_slice,
    exhaustive_modes,
    make_executor,
    mu_sweep,
    scene_sweep,
)
from planner.sweeps.random_systems import random_system


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None
    )
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_mu_sweep_same_locally_and_through_dask(dask_client, example_41):
    grid = np.linspace(0.0, 1.0, 5)
    mus = np.array(np.meshgrid(grid, grid, grid)).reshape(3, -1).T
    serial = mu_sweep(example_41, mus, LocalExecutor(1), chunk=7)
    local = LocalExecutor(2)
    try:
        procs = mu_sweep(example_41, mus, local, chunk=7)
    finally:
        local.close()
    dask = mu_sweep(example_41, mus, make_executor(dask_client), chunk=7)
    exhaustive = mu_sweep(example_41, mus, LocalExecutor(1), chunk=7, pruned=False)
    assert serial == procs == dask == exhaustive
    seen = {label for labels in serial for label in labels}
    assert {"S+1 S-2 S-3", "R1 S-2 B3"} <= seen
    assert any(not labels for labels in serial)  # jammed points exist


def test_scene_sweep_same_locally_and_through_dask(dask_client):
    local = scene_sweep(range(6), 6, LocalExecutor(1), check=True)
    dask = scene_sweep(range(6), 6, make_executor(dask_client), check=True)
    assert local == dask
    for row in local:
        assert row["modes"] == row["exhaustive_modes"]


def test_chunked_exhaustive_same_locally_dask_and_in_one_batch(dask_client):
    for seed in range(3):
        system = random_system(seed, 8)
        one_batch = feasible_modes(system, indeterminate=False).labels
        local = exhaustive_modes(system, LocalExecutor(1), chunk=100)
        dask = exhaustive_modes(system, make_executor(dask_client), chunk=300)
        assert local == dask == one_batch


@pytest.mark.parametrize(("start", "stop"), [(0, 1107), (5, 17), (100, 900), (1100, 1107)])
def test_enumerate_modes_slice_matches_enumeration(start, stop):
    codes = enumerate_modes(8, 8).codes
    np.testing.assert_array_equal(enumerate_modes_slice(8, 8, start, stop), codes[start:stop])


def test_bad_inputs(example_41):
    with pytest.raises(InputError, match="workers: expected an integer >= 1, got 0"):
        LocalExecutor(0)
    with pytest.raises(InputError, match="expected a scheduler address such as"):
        make_executor("  ")
    with pytest.raises(InputError, match=r"mu_points: expected shape \(P, 3\), got \(2, 2\)"):
        mu_sweep(example_41, np.zeros((2, 2)), LocalExecutor(1))
    with pytest.raises(InputError, match="chunk: expected >= 1, got 0"):
        exhaustive_modes(example_41, LocalExecutor(1), chunk=0)
    with pytest.raises(InputError, match="dask: expected a scheduler address or a client"):
        from planner.sweeps.executor import DaskExecutor

        DaskExecutor()


def test_sweep_cli_same_file_locally_and_through_dask_address(dask_client, data_dir, tmp_path):
    from qsplan.cli import main

    system = str(data_dir / "example_4_1.json")
    local, dask = tmp_path / "local.json", tmp_path / "dask.json"
    common = ["sweep", "mu", system, "--grid", "3", "--no-progress"]
    assert main([*common, "--workers", "1", "--out", str(local)]) == 0
    address = dask_client.scheduler.address
    assert main([*common, "--dask", address, "--out", str(dask)]) == 0
    assert local.read_text() == dask.read_text()
    scenes = tmp_path / "scenes.json"
    assert main(["sweep", "scenes", "--contacts", "5", "--count", "3", "--check",
                 "--workers", "1", "--no-progress", "--out", str(scenes)]) == 0


def test_sweep_cli_bad_input_exit_2(tmp_path, capsys):
    from qsplan.cli import main

    assert main(["sweep", "mu", "--out", str(tmp_path / "x.json")]) == 2
    assert "expected a SYSTEM.json argument" in capsys.readouterr().err


def test_search_subtrees_in_parallel_same_modes_locally_and_through_dask(dask_client):
    """search_modes(executor=...) hands open subtrees to the executor: same modes as the
    serial search and as exhaustive enumeration, in processes and through Dask."""
    from planner.predict.search import search_modes

    system = random_system(1, 10)
    serial = search_modes(system, indeterminate=False)
    exhaustive = feasible_modes(system, indeterminate=False)
    local = LocalExecutor(2)
    try:
        procs = search_modes(system, indeterminate=False, executor=local, subtrees=8)
    finally:
        local.close()
    dask = search_modes(
        system, indeterminate=False, executor=make_executor(dask_client), subtrees=8
    )
    for res in (serial, procs, dask):
        assert res.prediction.labels == exhaustive.labels
        assert res.prediction.status == exhaustive.status
    assert procs.stats.tested == dask.stats.tested > 0
    with pytest.raises(InputError, match="subtrees: expected an integer >= 1, got 0"):
        search_modes(system, executor=local, subtrees=0)


@pytest.mark.parametrize("engine", ["native", "python"])
def test_search_subtrees_with_each_engine_same_modes(engine):
    """Both engines search the executor's subtrees (local processes): the exhaustive modes, and
    the statistics name the engine the workers used."""
    from planner.predict import native_search
    from planner.predict.search import search_modes

    if engine == "native" and not native_search.native_status().available:
        pytest.skip("native core unavailable")
    system = random_system(3, 11)
    local = LocalExecutor(2)
    try:
        res = search_modes(system, indeterminate=False, executor=local, subtrees=16,
                           engine=engine)
    finally:
        local.close()
    assert res.prediction.labels == feasible_modes(system, indeterminate=False).labels
    assert res.stats.engine == engine


def test_a_worker_without_the_native_core_searches_in_python(monkeypatch):
    """A Dask worker on a machine without a C compiler: its subtree runs in Python, same
    kept candidates as a native worker's."""
    import numpy as np

    import planner.predict.search as search
    from planner.predict import native_search

    if not native_search.native_status().available:
        pytest.skip("native core unavailable")
    system = random_system(2, 9)
    params = search._Params(system.dof, 1e-9, 1e-10, 8, 1e-7, 4, False, "native")
    root = (np.full(9, search.FREE, dtype=np.int8), np.zeros(9, dtype=np.int8), None, True)
    job = (system, system.mu, root, params)
    kept_native, _, _, used = search._search_subtree(job)
    assert used == "native"
    monkeypatch.setattr(search, "_native_available", lambda: False)
    kept_python, _, _, used = search._search_subtree(job)
    assert used == "python"
    same = search.canonical_order(np.unique(kept_native, axis=0))
    other = search.canonical_order(np.unique(kept_python, axis=0))
    ok_native = feasible_modes(system, indeterminate=False).labels
    assert ok_native  # the system moves
    # both keep every candidate that can be feasible (their trees differ, so the sets may too)
    for kept in (same, other):
        pred, _ = search.predict_candidates(
            system, search.candidates_from_codes(kept, 9), system.mu, tol=1e-9,
            singular_tol=1e-10, indeterminate=False)
        assert pred.labels == ok_native
