"""One executor abstraction for large sweeps: local processes or Dask distributed.

Mu-space maps, batch validation of many randomised scenes and exhaustive enumeration at large
``n_c`` are embarrassingly parallel: a pure function applied to many items.  :class:`Executor`
maps such a function over items and returns the results in item order, with a tqdm progress
bar for long runs.  ``make_executor()`` gives local processes (``concurrent.futures``);
``make_executor(dask="tcp://host:8786")`` submits to a Dask scheduler instead.  Results do not
depend on the executor (same function, same items, same order).

``distributed`` is imported only when a Dask executor is made.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from planner.errors import InputError


class Executor(Protocol):
    """Maps a picklable function over items; results in item order."""

    def map(
        self, fn: Callable[[Any], Any], items: Sequence[Any], *, progress: bool = False,
        desc: str = "",
    ) -> list[Any]: ...

    def close(self) -> None: ...


def _progress(it: Iterable[Any], total: int, progress: bool, desc: str) -> Iterable[Any]:
    if not progress:
        return it
    from tqdm import tqdm

    return tqdm(it, total=total, desc=desc or "sweep", unit="item")


def _worker_init() -> None:
    """Pool worker start-up: one BLAS thread per process.

    The sweeps' NumPy work is many small batched products; with a multi-threaded BLAS each of
    ``workers`` processes would start its own threads and oversubscribe the cores (measured:
    the ``n_c = 20`` seed-3 search on 2 processes took 62 s with the default BLAS threads and
    46 s with one thread per process)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1)


@dataclass
class LocalExecutor:
    """Local execution: ``workers == 1`` runs in this process, else a process pool.

    Attributes
    ----------
    workers : int
        Number of processes (default: ``os.cpu_count()``).
    """

    workers: int = field(default_factory=lambda: os.cpu_count() or 1)
    _pool: ProcessPoolExecutor | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if isinstance(self.workers, bool) or not isinstance(self.workers, (int, np.integer)) or (
            self.workers < 1
        ):
            raise InputError(f"workers: expected an integer >= 1, got {self.workers!r}")

    def map(
        self, fn: Callable[[Any], Any], items: Sequence[Any], *, progress: bool = False,
        desc: str = "",
    ) -> list[Any]:
        items = list(items)
        if self.workers == 1 or len(items) <= 1:
            return [fn(x) for x in _progress(items, len(items), progress, desc)]
        if self._pool is None:
            self._pool = ProcessPoolExecutor(max_workers=self.workers, initializer=_worker_init)
        futures = [self._pool.submit(fn, x) for x in items]
        return [f.result() for f in _progress(futures, len(futures), progress, desc)]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


@dataclass
class DaskExecutor:
    """Dask distributed: ``address`` of a running scheduler (``tcp://host:8786``) or a cluster.

    ``client`` may be given directly (e.g. a ``distributed.Client(LocalCluster(...))``); then
    the executor does not close it.
    """

    address: Any = None
    client: Any = None
    _own: bool = field(default=False, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.client is None:
            if self.address is None:
                raise InputError("dask: expected a scheduler address or a client, got neither")
            from distributed import Client

            try:
                self.client = Client(self.address, timeout="10s")
            except (OSError, TimeoutError) as exc:
                raise InputError(
                    f"dask: expected a reachable scheduler at {self.address!r}, got {exc}"
                ) from exc
            except ValueError as exc:  # distributed cannot parse the address
                raise InputError(
                    f"dask: expected a scheduler address such as tcp://host:8786, got "
                    f"{self.address!r} ({exc})"
                ) from None
            self._own = True

    def map(
        self, fn: Callable[[Any], Any], items: Sequence[Any], *, progress: bool = False,
        desc: str = "",
    ) -> list[Any]:
        items = list(items)
        futures = self.client.map(fn, items, pure=False)
        if progress:
            from distributed import as_completed

            for _ in _progress(as_completed(futures), len(futures), progress, desc):
                pass
        return self.client.gather(futures)

    def close(self) -> None:
        if self._own and self.client is not None:
            self.client.close()
            self.client = None


def make_executor(dask: Any = None, workers: int | None = None) -> LocalExecutor | DaskExecutor:
    """Local processes by default; Dask when ``dask`` is a scheduler address or a Client."""
    if dask is None:
        return LocalExecutor() if workers is None else LocalExecutor(workers)
    if isinstance(dask, str):
        if not dask.strip():
            raise InputError("dask: expected a scheduler address such as tcp://host:8786, got ''")
        return DaskExecutor(address=dask)
    return DaskExecutor(client=dask)


# ---------------------------------------------------------------------------------------------
# Sweeps (pure functions of their items, so identical on every executor).
# ---------------------------------------------------------------------------------------------
def _mu_chunk(task: tuple[Any, np.ndarray, bool]) -> list[list[str]]:
    from planner.predict.search import search_modes

    system, mus, pruned = task
    if pruned:
        return [search_modes(system, m, indeterminate=False).prediction.labels for m in mus]
    from planner.predict.feasibility import feasible_modes

    return [feasible_modes(system, m, indeterminate=False).labels for m in mus]


def mu_sweep(
    system: Any, mu_points: Any, executor: Executor, *, chunk: int = 16,
    pruned: bool = True, progress: bool = False,
) -> list[list[str]]:
    """Feasible mode labels at each friction vector of ``mu_points (P, n_c)`` (a mu-space map).

    Returns one list of labels per row of ``mu_points``, in order (eqs. 13-28 at each point;
    determinate modes only).
    """
    mus = np.atleast_2d(np.asarray(mu_points, dtype=float))
    if mus.shape[1] != system.n_contacts:
        raise InputError(
            f"mu_points: expected shape (P, {system.n_contacts}), got {mus.shape}"
        )
    if chunk < 1:
        raise InputError(f"chunk: expected >= 1, got {chunk}")
    tasks = [(system, mus[i:i + chunk], pruned) for i in range(0, len(mus), chunk)]
    out = executor.map(_mu_chunk, tasks, progress=progress, desc="mu sweep")
    return [labels for part in out for labels in part]


def _scene(task: tuple[int, int, bool]) -> dict[str, Any]:
    from planner.predict.search import search_modes
    from planner.sweeps.random_systems import random_system

    seed, n_c, check = task
    system = random_system(seed, n_c)
    res = search_modes(system, indeterminate=False)
    row: dict[str, Any] = {
        "seed": seed, "n_contacts": n_c, "modes": res.prediction.labels,
        "status": res.prediction.status.value, **res.stats.to_dict(),
    }
    if check:
        from planner.predict.feasibility import feasible_modes

        row["exhaustive_modes"] = feasible_modes(system, indeterminate=False).labels
    return row


def scene_sweep(
    seeds: Sequence[int], n_contacts: int, executor: Executor, *, check: bool = False,
    progress: bool = False,
) -> list[dict[str, Any]]:
    """All feasible modes of many seeded random scenes (``planner.sweeps.random_systems``).

    ``check=True`` also runs exhaustive enumeration per scene (``exhaustive_modes``).
    """
    tasks = [(int(s), int(n_contacts), bool(check)) for s in seeds]
    return executor.map(_scene, tasks, progress=progress, desc=f"scenes n_c={n_contacts}")


def _exhaustive_chunk(task: tuple[Any, int, int, np.ndarray]) -> list[tuple[int, str]]:
    from planner.predict.search import candidates_from_codes, canonical_order
    from planner.predict.stages import force_stage, kinematic_stage

    system, start, stop, mu = task
    codes = enumerate_modes_slice(system.n_contacts, system.dof, start, stop)
    cand = candidates_from_codes(canonical_order(codes), system.dof)
    kin = kinematic_stage(system, cand)
    idx = np.flatnonzero(kin.ok)
    fs = force_stage(system, cand, idx, kin.xi[idx], mu)
    margin = np.minimum(fs.margin[0], kin.margin[idx])
    feasible = fs.nonsingular[0] & (margin >= -1e-9)
    from planner.model.modes import Mode

    return [
        (start + int(idx[j]),
         Mode(tuple(int(c) for c in cand.codes[idx[j]]),
              tuple(int(x) for x in kin.xi[idx[j]])).label)
        for j in np.flatnonzero(feasible)
    ]


def enumerate_modes_slice(n_contacts: int, n_rows: int, start: int, stop: int) -> np.ndarray:
    """Codes ``(stop - start, n_c)`` of candidates ``start:stop`` of eq. (49) in the order of
    :func:`planner.model.modes.enumerate_modes`, without building the whole set (large ``n_c``)."""
    from math import comb

    from planner.model.modes import ROLL, SLIDE

    out = []
    pos = 0
    for n_r in range(n_rows // 2 + 1):
        n_s = n_rows - 2 * n_r
        if n_r + n_s > n_contacts:
            continue
        per_r = comb(n_contacts - n_r, n_s)
        block = comb(n_contacts, n_r) * per_r
        if pos + block <= start or pos >= stop:
            pos += block
            continue
        import itertools

        for r_set in itertools.combinations(range(n_contacts), n_r):
            if pos + per_r <= start:
                pos += per_r
                continue
            if pos >= stop:
                break
            rest = [c for c in range(n_contacts) if c not in r_set]
            for s_set in itertools.combinations(rest, n_s):
                if start <= pos < stop:
                    code = np.zeros(n_contacts, dtype=np.int8)
                    code[list(r_set)] = ROLL
                    code[list(s_set)] = SLIDE
                    out.append(code)
                pos += 1
                if pos >= stop:
                    break
        if pos >= stop:
            break
    return np.array(out, dtype=np.int8).reshape(-1, n_contacts)


def exhaustive_modes(
    system: Any, executor: Executor, *, mu: Any = None, chunk: int = 50_000,
    progress: bool = False,
) -> list[str]:
    """Labels of all feasible determinate modes by exhaustive eq. (49) enumeration, in chunks
    of ``chunk`` candidates mapped over ``executor`` (for large ``n_c``; same decisions as
    :func:`planner.predict.feasibility.feasible_modes`, candidate order)."""
    from planner.model.modes import candidate_count

    mu_arr = system.mu if mu is None else np.broadcast_to(
        np.asarray(mu, dtype=float), (system.n_contacts,)
    )
    total = candidate_count(system.n_contacts, system.dof)
    if chunk < 1:
        raise InputError(f"chunk: expected >= 1, got {chunk}")
    tasks = [(system, s, min(s + chunk, total), mu_arr) for s in range(0, total, chunk)]
    parts = executor.map(_exhaustive_chunk, tasks, progress=progress, desc="exhaustive")
    return [label for _, label in sorted(p for part in parts for p in part)]
