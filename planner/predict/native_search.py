"""Native core of the exact pruned search: ``planner/predict/native/search_core.c``, compiled on
first use, loaded with :mod:`ctypes`, driven from :func:`planner.predict.search.search_modes`.

The C core walks the same tree as the Python search (:func:`planner.predict.search._expand`) and
solves the same pruning LP (:class:`planner.predict.prune_lp.Pruner` builds it: the matrix and
the row/column bounds of every contact state) with a small dense dual simplex that restarts
every node from its parent's basis; it prunes a node only on a Farkas certificate it has
re-checked against the data.  The leaves' candidates come back to Python, where the unchanged
batched stages (:func:`planner.predict.stages.kinematic_stage`, then the force stage) decide
them, so the modes are those of exhaustive enumeration (eq. 49).  docs/scaling.md, "The native
core", has the algorithm, the exactness argument and the measurements.

Building: the first call compiles the C file with the system's C compiler (``$CC``, Python's
configured compiler, ``cc``, ``gcc`` or ``clang``) into a cache folder (``$QSPLAN_CACHE_DIR``,
else ``$XDG_CACHE_HOME/qsplan`` or ``~/.cache/qsplan``, else the temporary folder), keyed by
the source, the flags, the compiler and the CPU; later calls load the cached library.  Without
a compiler :func:`native_status` says why, and ``search_modes(engine="auto")`` uses the Python
search (same modes, slower) and reports ``engine="python"`` in its statistics.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import sysconfig
import tempfile
import threading
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from planner.model.modes import BREAK, ROLL, SLIDE
from planner.predict.prune_lp import CONTACT, FREE, Pruner
from planner.predict.search_tree import LeafBatches, subtree_count

__all__ = ["NativeStats", "NativeStatus", "NativeTree", "native_status"]

SOURCE = Path(__file__).resolve().with_name("native") / "search_core.c"
#: Contact states in the C core's key order (``KEYS`` in search_core.c): (state, xi).
KEY_ORDER = ((BREAK, 0), (SLIDE, -1), (SLIDE, 1), (ROLL, 0), (FREE, 0), (CONTACT, 0))
#: Rows one contact state sets in the LP (``MAXR`` in search_core.c).
MAX_ROWS = 8
#: Candidates handed back to Python per call (one batched kinematic test).
CODES_PER_CALL = 1 << 15
#: Largest leaf (``batch_size``) the native core takes: a leaf's candidates must fit one call.
MAX_BATCH = CODES_PER_CALL // 2
#: Branching threshold of :func:`planner.predict.search_tree.branch_contact`.
ZERO_FORCE = 1e-9


@dataclass(frozen=True)
class NativeStatus:
    """Whether the native core can be used: ``available``, the library's ``path`` or the
    ``reason`` it is not (no compiler, a compile error: its first line)."""

    available: bool
    reason: str
    path: str | None = None


@dataclass(frozen=True)
class NativeStats:
    """What one native search did: LPs solved (``lp_solves``), dual simplex pivots, children
    that took their parent's point without an LP (``inherited``), LPs ended without a verdict
    (``unknown``: the node was kept), refactorisations, cold starts, nodes, leaves, and the
    leaves' eq. (49) sizes summed (``leaf_candidates``: the candidates handed to Python)."""

    lp_solves: int = 0
    pivots: int = 0
    inherited: int = 0
    unknown: int = 0
    refactors: int = 0
    cold_starts: int = 0
    nodes: int = 0
    leaves: int = 0
    leaf_candidates: int = 0


_LOCK = threading.Lock()
_STATUS: NativeStatus | None = None
_LIB: Any = None


def _cache_dir() -> Path | None:
    """The first writable cache folder (module docstring)."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    options = [os.environ.get("QSPLAN_CACHE_DIR"), xdg and str(Path(xdg) / "qsplan"),
               str(Path.home() / ".cache" / "qsplan"),
               str(Path(tempfile.gettempdir()) / f"qsplan-{uid}")]
    for opt in options:
        if not opt:
            continue
        path = Path(opt)
        try:
            path.mkdir(parents=True, exist_ok=True)
            if os.access(path, os.W_OK):
                return path
        except OSError:
            continue
    return None


def _compilers() -> list[str]:
    out = []
    for name in (os.environ.get("CC"), sysconfig.get_config_var("CC"), "cc", "gcc", "clang"):
        if not name:
            continue
        exe = shutil.which(str(name).split()[0])
        if exe and exe not in out:
            out.append(exe)
    return out


def _cpu_id() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith(("flags", "Features")):
                    return line
    except OSError:
        pass
    return platform.processor() + platform.machine()


def _build() -> NativeStatus:
    """Compile (or find in the cache) the shared library; never raises."""
    try:
        source = SOURCE.read_bytes()
    except OSError as exc:
        return NativeStatus(False, f"source missing: {exc}")
    cache = _cache_dir()
    if cache is None:
        return NativeStatus(False, "no writable cache folder for the compiled library")
    compilers = _compilers()
    if not compilers:
        return NativeStatus(False, "no C compiler found ($CC, cc, gcc, clang)")
    errors = []
    for cc in compilers:
        for flags in (["-O3", "-march=native"], ["-O3"], ["-O2"]):
            key = hashlib.sha256(source + repr((cc, flags, platform.platform(), _cpu_id()))
                                 .encode()).hexdigest()[:20]
            target = cache / f"search_core-{key}.so"
            if target.exists():
                return NativeStatus(True, "cached", str(target))
            fd, tmp = tempfile.mkstemp(suffix=".so", dir=cache)
            os.close(fd)
            cmd = [cc, *flags, "-std=c99", "-shared", "-fPIC", str(SOURCE), "-o", tmp, "-lm"]
            try:
                run = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            except (OSError, subprocess.SubprocessError) as exc:
                run = None
                errors.append(f"{Path(cc).name}: {exc}")
            if run is not None and run.returncode == 0:
                os.replace(tmp, target)
                return NativeStatus(True, "compiled", str(target))
            if run is not None:
                first = (run.stderr.strip().splitlines() or [f"exit {run.returncode}"])[0]
                errors.append(f"{Path(cc).name} {' '.join(flags)}: {first}")
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return NativeStatus(False, "compile failed: " + "; ".join(errors[:3]))


def _declare(lib: Any) -> Any:
    P, Int, D = ctypes.c_void_p, ctypes.c_int, ctypes.c_double
    dp, ip = ctypes.POINTER(D), ctypes.POINTER(Int)
    bp = ctypes.POINTER(ctypes.c_byte)
    lib.qs_new.restype = P
    lib.qs_new.argtypes = [Int, Int, dp, dp, dp, dp, dp, Int, Int, Int, ip, ip, dp, dp, dp, ip,
                           ip, dp, dp, Int, Int, D]
    lib.qs_free.argtypes = [P]
    lib.qs_free.restype = None
    lib.qs_start.argtypes = [P, bp, bp]
    lib.qs_start.restype = Int
    lib.qs_run.argtypes = [P, bp, bp, Int, bp, ip, Int, ip, ip]
    lib.qs_run.restype = Int
    lib.qs_stats.argtypes = [P, ctypes.POINTER(ctypes.c_longlong), dp]
    lib.qs_stats.restype = None
    lib.qs_solve_node.argtypes = [P, bp, bp, dp]
    lib.qs_solve_node.restype = Int
    return lib


def native_status() -> NativeStatus:
    """Build or load the native core once per process (thread-safe) and say whether it is
    usable."""
    global _STATUS, _LIB
    with _LOCK:
        if _STATUS is None:
            status = _build()
            if status.available:
                try:
                    _LIB = _declare(ctypes.CDLL(status.path))
                except OSError as exc:
                    status = NativeStatus(False, f"cannot load {status.path}: {exc}")
            _STATUS = status
        return _STATUS


def _ptr(a: np.ndarray, kind: Any) -> Any:
    return a.ctypes.data_as(ctypes.POINTER(kind))


@lru_cache(maxsize=16)
def _size_table(n_c: int, k: int) -> np.ndarray:
    """``subtree_count(n_free, n_con, rows_left)`` for every argument (float: only compared
    with the batch sizes and zero; exact below 2^53)."""
    t = np.zeros((n_c + 1, n_c + 1, k + 1))
    for nf in range(n_c + 1):
        for nco in range(n_c + 1 - nf):
            for left in range(k + 1):
                t[nf, nco, left] = float(subtree_count(nf, nco, left))
    t.setflags(write=False)
    return t


class NativeTree:
    """One system's search tree in the native core (a C context holding the LP, the bounds of
    every contact state and the depth-first stack).  :meth:`search` runs it from a node."""

    def __init__(self, pruner: Pruner, k: int, batch_size: int, lp_min_size: int) -> None:
        status = native_status()
        if not status.available:
            raise RuntimeError(f"native search core unavailable: {status.reason}")
        self.lib = _LIB
        n_c = pruner.n_c
        self.n_c, self.k = n_c, k
        self.batch_size = int(batch_size)
        nrows = np.zeros((n_c, len(KEY_ORDER)), np.int32)
        rows = np.zeros((n_c, len(KEY_ORDER), MAX_ROWS), np.int32)
        lo = np.zeros((n_c, len(KEY_ORDER), MAX_ROWS))
        hi = np.zeros((n_c, len(KEY_ORDER), MAX_ROWS))
        col = np.zeros((n_c, len(KEY_ORDER), 2))
        for i in range(n_c):
            for q, (state, xi) in enumerate(KEY_ORDER):
                rr, cc = pruner.contact_bounds(i, state, xi)
                nrows[i, q] = len(rr)
                for j, (r, a, b) in enumerate(rr):
                    rows[i, q, j], lo[i, q, j], hi[i, q, j] = r, a, b
                col[i, q] = cc
        A = np.ascontiguousarray(pruner.A, dtype=float)
        m, n = A.shape
        self.n_cols = n
        arrays = dict(
            A=A, rl=np.ascontiguousarray(pruner.row_lower, dtype=float),
            ru=np.ascontiguousarray(pruner.row_upper, dtype=float),
            cl=np.full(n, -np.inf), cu=np.full(n, np.inf), nrows=nrows, rows=rows, lo=lo, hi=hi,
            col=col, cn=np.ascontiguousarray(pruner.cn, dtype=np.int32),
            ct=np.ascontiguousarray(pruner.ct, dtype=np.int32),
            mu=np.ascontiguousarray(pruner.mu, dtype=float),
            sizes=np.ascontiguousarray(_size_table(n_c, k)))
        D, Int = ctypes.c_double, ctypes.c_int
        a = arrays
        self.ctx = self.lib.qs_new(
            m, n, _ptr(a["A"], D), _ptr(a["rl"], D), _ptr(a["ru"], D), _ptr(a["cl"], D),
            _ptr(a["cu"], D), n_c, pruner.nz, k, _ptr(a["nrows"], Int), _ptr(a["rows"], Int),
            _ptr(a["lo"], D), _ptr(a["hi"], D), _ptr(a["col"], D), _ptr(a["cn"], Int),
            _ptr(a["ct"], Int), _ptr(a["mu"], D), _ptr(a["sizes"], D), self.batch_size,
            int(lp_min_size), ZERO_FORCE)
        if not self.ctx:
            raise MemoryError("native search core: out of memory building the LP")
        self._states = np.zeros((CODES_PER_CALL, n_c), np.int8)
        self._xi = np.zeros((CODES_PER_CALL, n_c), np.int8)
        self._codes = np.zeros((CODES_PER_CALL, n_c), np.int8)
        self._leaf = np.zeros(CODES_PER_CALL, np.int32)

    def close(self) -> None:
        if getattr(self, "ctx", None):
            self.lib.qs_free(self.ctx)
            self.ctx = None

    def __del__(self) -> None:
        self.close()

    def search(self, states: np.ndarray, xi: np.ndarray, leaves: LeafBatches) -> NativeStats:
        """Search the subtree of the node ``(states, xi)`` (from a cold LP start) and queue every
        leaf candidate in ``leaves``; the statistics of this search."""
        B = ctypes.c_byte
        st = np.ascontiguousarray(states, dtype=np.int8)
        x = np.ascontiguousarray(xi, dtype=np.int8)
        if not self.lib.qs_start(self.ctx, _ptr(st, B), _ptr(x, B)):
            raise MemoryError("native search core: out of memory")
        n_out, n_codes = ctypes.c_int(0), ctypes.c_int(0)
        while True:
            ret = self.lib.qs_run(self.ctx, _ptr(self._states, B), _ptr(self._xi, B),
                                  len(self._states), _ptr(self._codes, B),
                                  _ptr(self._leaf, ctypes.c_int), len(self._codes),
                                  ctypes.byref(n_out), ctypes.byref(n_codes))
            if ret < 0:
                raise MemoryError("native search core: out of memory in the search")
            nc = n_codes.value
            if nc:
                leaf = self._leaf[:nc]
                leaves.add(self._codes[:nc].copy(), self._states[leaf], self._xi[leaf])
            if ret == 0:
                break
        out = (ctypes.c_longlong * 8)()
        cands = ctypes.c_double()
        self.lib.qs_stats(self.ctx, out, ctypes.byref(cands))
        v = [int(x) for x in out]
        return NativeStats(lp_solves=v[0], pivots=v[1], inherited=v[2], unknown=v[3],
                           refactors=v[4], cold_starts=v[5], nodes=v[6], leaves=v[7],
                           leaf_candidates=int(cands.value))

    def solve_node(self, states: np.ndarray, xi: np.ndarray) -> tuple[str, np.ndarray]:
        """One LP from a cold start (for tests): ``("feasible", x)``, ``("infeasible", x)`` or
        ``("unknown", x)``, ``x`` the dual simplex's last point."""
        B = ctypes.c_byte
        st = np.ascontiguousarray(states, dtype=np.int8)
        xv = np.ascontiguousarray(xi, dtype=np.int8)
        out = np.zeros(self.n_cols)
        code = self.lib.qs_solve_node(self.ctx, _ptr(st, B), _ptr(xv, B),
                                      _ptr(out, ctypes.c_double))
        return ("feasible", "infeasible", "unknown")[code], out
