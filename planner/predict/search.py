"""All feasible modes without testing every candidate: exact pruned search.

The paper tests all eq. (49) candidates (Sec. 4.7: 20 min at ``n_c = 12``) and names as future
work finding all solutions without enumerating the modes (Secs. 4.7, 6).  This module does that
with a depth-first branch-and-bound over *partial* mode assignments, pruned by an LP relaxation,
with the kinematics decided by batched tests at the leaves.  Full description, exactness
argument and measurements: ``docs/scaling.md``.

Algorithm
---------
Write ``z = (qdot, thetadot_E)`` (the unknowns of eq. 24), ``K = [W^T  -J_E]`` (2 n_c x k,
``k = 3 + |tau_I|``), ``b = J_V thetadot_V``; the relative velocity is ``v = K z - b`` (eq. 5).
A feasible mode has ``z`` and contact forces ``c (2 n_c)`` with ``W c = -g_obj``,
``J_E^T c = tau_E - g_man_E`` (eq. 26 over all contacts) and per contact: B ``v_n > 0, c = 0``
(eqs. 11, 25); S ``v_n = 0, xi v_t > 0, c_t = -mu xi c_n, c_n >= 0`` (eqs. 10, 16, 17, 22);
R ``v_n = 0, v_t = 0, |c_t| <= mu c_n`` (eqs. 9, 21).  A node gives each contact a state:
``FREE`` (undecided), ``CONTACT`` (R or S, undecided), or B / R / S+ / S-.  Children
``FREE -> B | CONTACT`` and ``CONTACT -> R | S+ | S-`` partition the parent's candidates.

A node is pruned when HiGHS proves its LP relaxation infeasible (one warm-started LP; only
bounds change between nodes).  Two relaxations (``relaxation=``):

* ``"forces"``: the contact forces only -- equilibrium; ``c = 0`` at B; ``c`` in the friction
  cone at FREE / CONTACT / R; ``c_t = -mu xi c_n``, ``c_n >= 0`` at S (inequalities relaxed by
  ``eps N``).  FREE -> CONTACT and CONTACT -> R leave it unchanged, so those children inherit
  their parent's answer.
* ``"coupled"``: the same plus the velocities ``z`` with each contact's velocity conditions
  (``v_n >= 0`` at FREE / B, ``v_n = 0`` in contact, ``v_t = 0`` at R, ``xi v_t >= 0`` at S)
  and one row that ties them to the forces: the power of the contact forces, ``c^T v =
  (K^T c)^T z - b^T c`` with ``K^T c = [-g_obj; -(tau_E - g_man_E)]`` known from eq. (26), is
  ``-sum_S mu_i c_in |v_it| <= 0`` in every feasible mode (eqs. 16-17), a *linear* inequality
  in ``(z, c)``.  Velocities alone prune almost nothing; with the power row the LP prunes far
  more (``n_c = 20`` seed 3: 1.1e6 instead of 7.1e6 candidates tested).
* ``"auto"`` (default): coupled from :data:`COUPLED_MIN_CONTACTS` contacts on (measured
  crossover; below it the forces-only LP's free inheritance wins).

Subtrees with at most ``batch_size`` candidates are generated and queued, and tested in
batches by the same code as the exhaustive path (:func:`planner.predict.stages.kinematic_stage`,
then :func:`planner.predict.stages.force_stage` on the kinematically admissible ones).

Why it is exact
---------------
A mode that exhaustive enumeration reports feasible has a velocity ``z`` and forces ``c`` that
satisfy the relaxation of every ancestor node: equilibrium and the contact rows hold to
rounding, Coulomb to ``tol max|c_A|`` (bounded by ``eps_f sum c_n`` with ``eps_f >> tol``),
the velocity rows to ``tol * velocity_scale`` (kinematic boundary cases included; the LP allows
``100 eps * velocity_scale``), and the power row holds with ``c^T v <= 0``; so it is never
pruned.  The children partition the candidates, and each surviving candidate is decided by
the same arithmetic as :func:`planner.predict.feasibility.feasible_modes` (same row order and
equilibration, one candidate's arithmetic independent of its batch).  The boundary-tolerance
modes (:func:`planner.predict.boundary.boundary_modes_of`: a strict kinematic row missed by at
most ``tol``, the forces passing eq. 28) satisfy every ancestor's relaxation too (the power row
within ``mu tol`` of the velocity scale), so the search lists the same ones.  Difference by
design: ``degenerate`` counts singular candidates among those tested.

Cost
----
One LP (forces: ``2 n_c + 1`` unknowns, ``5 n_c + k + 2`` rows; coupled: ``k`` more unknowns,
``2 n_c`` more rows) per node that cannot inherit, plus the batched kinematic test of the
queued leaves; the number of nodes grows with the partial assignments whose relaxation is
feasible, not with eq. (49).  Exponential in the worst case (the problem contains an LCP).

References
----------
Trinkle & Zeng (1994), eqs. (5), (9)-(11), (16)-(17), (21)-(26), (29), (49); Secs. 4.7, 6.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.model.modes import (
    BREAK,
    ROLL,
    SLIDE,
    candidate_count,
    candidates_from_codes,
)
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.feasibility import Prediction, predict_candidates
from planner.predict.prune_lp import CONTACT, FREE, Pruner
from planner.predict.search_tree import (
    LeafBatches,
    branch_contact,
    canonical_order,
    completions,
    subtree_size,
)
from planner.predict.stages import DEFAULT_SINGULAR_TOL, DEFAULT_TOL

__all__ = [
    "CONTACT", "FREE", "Pruner", "SearchResult", "SearchStats", "candidates_from_codes",
    "canonical_order", "search_modes",
]

#: Default largest subtree (in candidates) that is tested in one batch instead of branched
#: (Python engine; its LPs cost ~0.2 ms each, 30-50 leaf candidates' tests).
DEFAULT_BATCH_SIZE = 128
#: Subtrees with fewer candidates than this are tested without a pruning LP first.
DEFAULT_LP_MIN_SIZE = 64
#: The same two for the native engine, whose LPs are ~10x cheaper: smaller leaves pay
#: (measured on n_c = 20 and 22, seeds 10-19 -- not the benchmark's 0-9 --, docs/scaling.md).
NATIVE_BATCH_SIZE = 8
NATIVE_LP_MIN_SIZE = 4
#: Relative slack of the pruning LP's Coulomb rows (well above ``DEFAULT_TOL``).
DEFAULT_PRUNE_EPS = 1e-7
#: ``relaxation="auto"`` prunes with the coupled velocity-force LP from this many contacts
#: on, with the forces-only LP below (docs/scaling.md: measured crossover).
COUPLED_MIN_CONTACTS = 17
#: Default number of open nodes handed to an executor by :func:`search_modes`.
DEFAULT_SUBTREES = 512


@dataclass(frozen=True)
class SearchStats:
    """What the search did.

    Attributes
    ----------
    candidates : int
        Eq. (49) count ``candidate_count(n_c, 3 + |tau_I|)``.
    tested : int
        Kinematic tests in the batched stage (eqs. 23-25), one per leaf that reaches a
        candidate: a candidate sliding at a contact lies in both that contact's ``S+`` and
        ``S-`` branches (each keeps it only when the computed ``xi`` is its own), so this count
        can exceed ``candidates`` when little is pruned.
    force_tested : int
        Candidates that passed it and went through the force stage (eqs. 26-28).
    lp_solves : int
        Pruning LPs solved (force relaxations).
    engine : str
        ``"native"`` (the compiled core, :mod:`planner.predict.native_search`) or
        ``"python"`` (HiGHS through SciPy); with an executor, the engine of the subtrees
        (``"mixed"`` when some workers lacked the native core).
    """

    candidates: int
    tested: int
    force_tested: int
    lp_solves: int
    engine: str = "python"

    def to_dict(self) -> dict[str, int | str]:
        return {
            "candidates": self.candidates,
            "tested": self.tested,
            "force_tested": self.force_tested,
            "lp_solves": self.lp_solves,
            "engine": self.engine,
        }


@dataclass(frozen=True, eq=False)
class SearchResult:
    """Result of :func:`search_modes`: the prediction and the search statistics."""

    prediction: Prediction
    stats: SearchStats


def search_modes(
    system: System,
    mu: Any = None,
    *,
    tol: float = DEFAULT_TOL,
    singular_tol: float = DEFAULT_SINGULAR_TOL,
    indeterminate: bool | None = None,
    batch_size: int | None = None,
    prune_eps: float = DEFAULT_PRUNE_EPS,
    lp_min_size: int | None = None,
    executor: Any = None,
    subtrees: int = DEFAULT_SUBTREES,
    relaxation: str = "auto",
    progress: bool = False,
    engine: str = "auto",
) -> SearchResult:
    """Every feasible mode of ``system`` (same set as exhaustive eq. 49 enumeration), pruned.

    Parameters
    ----------
    system : System
    mu : float or (n_c,), optional
        Friction coefficients; defaults to ``system.mu``.
    tol, singular_tol, indeterminate
        As in :func:`planner.predict.feasibility.feasible_modes`.
    batch_size : int, optional
        Subtrees with at most this many candidates are tested in one batch, not branched
        (default :data:`NATIVE_BATCH_SIZE` with the native engine, else
        :data:`DEFAULT_BATCH_SIZE`).
    prune_eps : float
        Relative slack of the force relaxation: its Coulomb rows are relaxed by
        ``eps_f N`` with ``eps_f = 10 prune_eps max(1, mu_max)`` (must exceed ``tol``).
    lp_min_size : int, optional
        Subtrees with at most this many candidates are not pruned by an LP first (default
        :data:`NATIVE_LP_MIN_SIZE` / :data:`DEFAULT_LP_MIN_SIZE`).
    executor : planner.sweeps.executor.Executor, optional
        Search independent subtrees in parallel (Sec. 6's "test modes in parallel"): the tree
        is expanded breadth-first here until ``subtrees`` nodes are open, and each open node's
        subtree is searched by ``executor.map`` (local processes or Dask).  The modes are the
        same as without it; ``stats`` sums the workers' counts.
    subtrees : int
        Open nodes handed to the executor.
    relaxation : {"auto", "coupled", "forces"}
        Pruning LP: the contact forces only, or coupled with the velocities through the power
        row (module docstring); ``"auto"`` couples from :data:`COUPLED_MIN_CONTACTS` contacts
        on.  The modes are the same; only the work differs.
    progress : bool
        With an executor: a progress bar (tqdm, on stderr) over the subtrees.
    engine : {"auto", "native", "python"}
        Who walks the tree and solves the pruning LPs: the compiled core
        (:mod:`planner.predict.native_search`, built with the system's C compiler on first use),
        or Python with HiGHS.  ``"auto"`` (default) takes the native core when it is available
        and ``batch_size <= native_search.MAX_BATCH``; ``stats.engine`` says which ran.  The
        leaves are decided by the same batched stages either way, so the modes are the same;
        only the tree (the LP points steer the branching) and the time differ.

    Returns
    -------
    SearchResult
        ``prediction`` equal to ``feasible_modes(system, mu)`` (modes, order, certificates,
        boundary modes; ``degenerate`` counts tested candidates only) and ``stats``.
    """
    if not isinstance(system, System):
        raise InputError(f"system: expected a planner System, got {type(system).__name__}")
    mu_arr = system.mu if mu is None else as_friction(mu, system.n_contacts)
    if not (np.isfinite(tol) and tol >= 0):
        raise InputError(f"tol: expected a finite number >= 0, got {tol}")
    for name, value, low in (("batch_size", batch_size, 1), ("lp_min_size", lp_min_size, 0),
                             ("subtrees", subtrees, 1)):
        if value is None and name != "subtrees":
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise InputError(f"{name}: expected an integer >= {low}, got {value!r}")
    if not (np.isfinite(prune_eps) and prune_eps > tol):
        raise InputError(f"prune_eps: expected a finite number > tol ({tol}), got {prune_eps}")
    n_c, k = system.n_contacts, system.dof
    n_cand = candidate_count(n_c, k)
    if relaxation not in ("auto", "coupled", "forces"):
        raise InputError(
            f"relaxation: expected 'auto', 'coupled' or 'forces', got {relaxation!r}"
        )
    coupled = relaxation == "coupled" or (
        relaxation == "auto" and n_c >= COUPLED_MIN_CONTACTS
    )
    engine = _resolve_engine(engine, batch_size)
    native = engine == "native"
    if batch_size is None:
        batch_size = NATIVE_BATCH_SIZE if native else DEFAULT_BATCH_SIZE
    if lp_min_size is None:
        lp_min_size = NATIVE_LP_MIN_SIZE if native else DEFAULT_LP_MIN_SIZE
    params = _Params(k, tol, singular_tol, batch_size, prune_eps, lp_min_size, coupled, engine)
    pruner = Pruner(system, prune_eps, mu_arr, coupled=params.coupled)
    leaves = LeafBatches(system, k, tol=tol, singular_tol=singular_tol)
    root: _Node = (np.full(n_c, FREE, dtype=np.int8), np.zeros(n_c, dtype=np.int8), None, True)
    open_nodes: deque[_Node] = deque([root])
    lp_solves = 0
    if executor is None and engine == "native":
        lp_solves += _native_tree(pruner, params).search(root[0], root[1], leaves).lp_solves
    elif executor is None:
        _expand(open_nodes, pruner, leaves, mu_arr, params)
    else:
        _expand(open_nodes, pruner, leaves, mu_arr, params, breadth_until=subtrees)
        jobs = [(system, mu_arr, node, params) for node in open_nodes]
        used = set()
        for kept, tested, solves, worker_engine in executor.map(
            _search_subtree, jobs, progress=progress, desc="subtrees"
        ):
            used.add(worker_engine)
            leaves.kept.append(kept)
            leaves.tested += tested
            lp_solves += solves
        if used:  # the workers' engine(s): the breadth-first top is always Python's
            engine = used.pop() if len(used) == 1 else "mixed"
    lp_solves += pruner.solves
    codes = canonical_order(np.unique(leaves.kept_codes(), axis=0))
    cand = candidates_from_codes(codes, k)
    prediction, force_tested = predict_candidates(
        system, cand, mu_arr, tol=tol, singular_tol=singular_tol, indeterminate=indeterminate,
        method="search",
    )
    stats = SearchStats(
        candidates=n_cand,
        tested=leaves.tested,
        force_tested=force_tested,
        lp_solves=lp_solves,
        engine=engine,
    )
    return SearchResult(prediction, stats)


def _resolve_engine(engine: str, batch_size: int | None) -> str:
    """``"native"`` or ``"python"`` for the ``engine`` argument of :func:`search_modes`."""
    from planner.predict import native_search

    if engine not in ("auto", "native", "python"):
        raise InputError(f"engine: expected 'auto', 'native' or 'python', got {engine!r}")
    if engine == "python":
        return engine
    status = native_search.native_status()
    fits = batch_size is None or batch_size <= native_search.MAX_BATCH
    if engine == "native" and not status.available:
        raise InputError(f"engine: 'native' needs the compiled search core, which is not "
                         f"available here ({status.reason}); got engine='native'")
    if engine == "native" and not fits:
        raise InputError(f"batch_size: expected <= {native_search.MAX_BATCH} with "
                         f"engine='native', got {batch_size}")
    return "native" if status.available and fits else "python"


def _native_tree(pruner: Pruner, params: _Params) -> Any:
    from planner.predict.native_search import NativeTree

    return NativeTree(pruner, params.n_rows, params.batch_size, params.lp_min_size)


#: A search node: state per contact, xi per contact, the parent's LP point (or None) and
#: whether the node must solve its LP (False: the parent's point is feasible for it).
_Node = tuple[np.ndarray, np.ndarray, "np.ndarray | None", bool]


@dataclass(frozen=True)
class _Params:
    n_rows: int
    tol: float
    singular_tol: float
    batch_size: int
    prune_eps: float
    lp_min_size: int
    coupled: bool
    engine: str = "python"


def _expand(
    open_nodes: deque[_Node],
    pruner: Pruner,
    leaves: LeafBatches,
    mu_arr: np.ndarray,
    params: _Params,
    *,
    breadth_until: int | None = None,
) -> None:
    """Branch and bound over ``open_nodes`` (module docstring).

    Depth-first until no node is open; with ``breadth_until``, breadth-first and only until
    that many nodes are open (they are left in ``open_nodes``).  FREE -> BREAK | CONTACT,
    CONTACT -> ROLL | SLIDE xi=+1 | SLIDE xi=-1: the children partition the parent's codes.  A
    CONTACT or R child inherits its parent's LP point when the point meets its bounds
    (:meth:`Pruner.satisfies`): the parent's answer stands.
    """
    k = params.n_rows
    while open_nodes:
        if breadth_until is not None and len(open_nodes) >= breadth_until:
            return
        states, xi, point, changed = (
            open_nodes.pop() if breadth_until is None else open_nodes.popleft()
        )
        size = subtree_size(states, k)
        if size == 0:
            continue
        if size > params.lp_min_size:
            if changed or point is None:
                point = pruner.solve(states, xi)
                if point is None:
                    continue
        else:
            point = None
        undecided = np.any((states == FREE) | (states == CONTACT))
        if size <= params.batch_size or not undecided:
            leaves.add(completions(states, k), states, xi)
            continue
        i = branch_contact(states, None if point is None else point[pruner.nz:-1], mu_arr)
        children: tuple[tuple[int, int], ...]
        if states[i] == FREE:
            children = ((BREAK, 0), (CONTACT, 0))
        else:
            children = ((SLIDE, 1), (SLIDE, -1), (ROLL, 0))
        for code, x in children:
            child, child_xi = states.copy(), xi.copy()
            child[i], child_xi[i] = code, x
            inherit = point is not None and pruner.satisfies(point, i, code, x)
            open_nodes.append((child, child_xi, point, not inherit))


def _search_subtree(
    job: tuple[System, np.ndarray, _Node, _Params]
) -> tuple[np.ndarray, int, int, str]:
    """Executor task: search one node's subtree; its kept codes, tested count, LP count and
    engine (a worker without the native core -- a Dask worker on a machine without a C
    compiler -- searches with the Python engine: same modes).

    A worker process keeps the last system's pruner (its HiGHS model) between tasks, so many
    small subtrees cost little more than one big one.  The basis is cleared before each
    subtree, so the LP answers, and with them the branching and the statistics, do not depend
    on which worker searched which subtrees before (same counts locally and through Dask)."""
    system, mu_arr, node, params = job
    key = _pruner_key(system, mu_arr, params.prune_eps, params.coupled)
    cache = _WORKER.__dict__.setdefault("pruners", {})
    cached = cache.get(key)
    if cached is None:
        cache.clear()
        cached = cache[key] = Pruner(
            system, params.prune_eps, mu_arr, coupled=params.coupled
        )
    pruner = cached
    leaves = LeafBatches(system, params.n_rows, tol=params.tol, singular_tol=params.singular_tol)
    if params.engine == "native" and _native_available():
        # one native tree per worker and system; every subtree starts from a cold LP
        tkey = (key, "native", params.n_rows, params.batch_size, params.lp_min_size)
        tree = cache.get(tkey)
        if tree is None:
            tree = cache[tkey] = _native_tree(pruner, params)
        solves = tree.search(node[0], node[1], leaves).lp_solves
        return leaves.kept_codes(), leaves.tested, solves, "native"
    pruner.lp.reset()  # each subtree starts cold: the traversal does not depend on task order
    before = pruner.solves
    _expand(deque([node]), pruner, leaves, mu_arr, params)
    return leaves.kept_codes(), leaves.tested, pruner.solves - before, "python"


def _native_available() -> bool:
    from planner.predict.native_search import native_status

    return native_status().available


#: Per worker thread: the pruner of the last system it searched (see :func:`_search_subtree`).
#: Thread-local because a HiGHS model must not be shared by threads (Dask threads workers).
_WORKER = threading.local()


def _pruner_key(system: System, mu: np.ndarray, eps: float, coupled: bool) -> bytes:
    """Digest of everything a :class:`Pruner` is built from."""
    import hashlib

    d = hashlib.sha256()
    for a in (system.W, system.J, system.joint_inputs, system.g_obj, system.g_man, mu,
              np.asarray(system.effort_joints), np.asarray(system.velocity_joints),
              np.asarray([eps, float(coupled)])):
        a = np.ascontiguousarray(a)
        d.update(str(a.dtype).encode() + str(a.shape).encode())
        d.update(a.tobytes())
    return d.digest()
