"""Executor abstraction: the same sweep locally (processes) and through Dask (LocalCluster)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.executor import LocalExecutor, make_executor, mu_sweep, scene_sweep


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


def test_bad_inputs(example_41):
    with pytest.raises(InputError, match="workers: expected an integer >= 1, got 0"):
        LocalExecutor(0)
    with pytest.raises(InputError, match="expected a scheduler address such as"):
        make_executor("  ")
    with pytest.raises(InputError, match=r"mu_points: expected shape \(P, 3\), got \(2, 2\)"):
        mu_sweep(example_41, np.zeros((2, 2)), LocalExecutor(1))
