"""Command policies: which effort, inside the guaranteed set, each waypoint commands
(docs/planning.md, "Command policies").

Each waypoint ``k`` holds its command until ``k + 1``; the efforts that keep the guarantee over
that hold interval are the *hold set* ``H_k = {tau : A_k tau <= b_k}`` (the sets guaranteed at
both ends of the interval, eq. 28 over the friction set, intersected with the joints' effort
limits; :class:`HoldSet`).  Rows are normalised, so ``b_k - A_k tau`` is the distance of
``tau`` to each face (the margin, in the efforts' units).

The **required margin** ``m_k = MARGIN_KEPT * min(r_k, s_k)``: ``r_k`` the radius of the largest
ball in ``H_k`` (what the maximum-margin command keeps), ``s_k`` the load's torque scale
(:func:`planner.plan.polytope.torque_scale`: the effort at which the contacts carry forces of
the load's size).  The share is the one the waypoint spacing budgets for the set's change over
one hold interval (:data:`MARGIN_KEPT`, docs/planning.md, "Waypoint spacing"): a command that
keeps it stays guaranteed under the variation the spacing admits.  The cap at ``s_k``: what
threatens the mode in execution is the contact forces being off by a share of the load (a
state off the plan, compliant contacts), which scales with the load, not with how far away the
set's other face is -- a one-sided band, or a band whose far end a rival sets hundreds of N m
away, needs no more.  The *safe set* ``S_k`` is ``H_k`` shrunk by ``m_k`` (never empty when
``H_k`` has an interior: it keeps the ball of radius ``r_k - m_k >= r_k / 2``).

Policies (``p`` effort joints, one LP each, HiGHS):

* ``least-effort`` -- per waypoint the point of ``S_k`` with the smallest ``sum_j |tau_j|``
  (the least squeeze that keeps the margin); ``least-effort:M`` with the margin ``M`` instead;
* ``max-margin`` (``midband``: with one effort joint the middle of the hold band of Figure 13)
  -- the centre of the largest ball in ``H_k``;
* ``smooth`` (the default) -- the commands in ``S_k`` whose largest change between consecutive
  waypoints, ``D = max_k |tau_k+1 - tau_k|_inf``, is the smallest possible (``D*``, one LP over
  the segment), and among those the least total effort; with effort-rate limits also
  ``|tau_k+1,j - tau_k,j| <= rate_j (t_k+1 - t_k)``.  **Its bound**: no other commands that keep
  the required margin change by less than ``D*`` -- in particular it never changes more than the
  least-effort or constant commands would, and ``D* = 0`` whenever one command fits every
  waypoint.

Units: efforts N m (revolute) or N (prismatic); times s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from planner.errors import DegenerateError, InputError

#: Share of its size the guaranteed set may move by over one hold interval (the waypoint
#: spacing's rule, :mod:`planner.plan.spacing`) and share of the hold set's radius (capped at
#: the load's torque scale) a command keeps as its required margin.
MARGIN_KEPT = 0.5

DEFAULT_POLICY = "smooth"
#: The policies a user may name (``least-effort:M`` with a margin; ``rival:MODE`` is the
#: negative control of :mod:`planner.plan.commands`).
POLICIES = ("smooth", "least-effort", "max-margin", "midband", "constant")


def parse_policy(policy: str) -> tuple[str, float | None]:
    """``(name, margin)``: ``"least-effort:0.05"`` -> ``("least-effort", 0.05)``; ``rival:MODE``
    -> ``("rival", None)``.  Raises :class:`InputError` naming the policies."""
    name, _, arg = str(policy).partition(":")
    if name == "rival" and arg:
        return "rival", None
    if name == "least-effort" and arg:
        try:
            m = float(arg)
        except ValueError:
            m = math.nan
        if not (math.isfinite(m) and m > 0):
            raise InputError(f"policy {policy!r}: expected least-effort:M with a positive "
                             f"margin M (N m or N), got {arg!r}")
        return name, m
    if name in POLICIES and not arg:
        return name, None
    raise InputError(f"policy: expected one of {POLICIES}, 'least-effort:M' or 'rival:MODE', "
                     f"got {policy!r}")


@dataclass(frozen=True, eq=False)
class HoldSet:
    """The efforts that keep the guarantee over one hold interval: ``{tau : A tau <= b}``,
    ``A (m, p)`` with unit rows, ``b (m,)``; ``radius`` of its largest ball (``inf``:
    unbounded), ``scale`` the load's torque scale there, ``t`` the waypoint's time (s)."""

    A: np.ndarray
    b: np.ndarray
    radius: float
    scale: float
    t: float

    def margin_at(self, tau: np.ndarray) -> float:
        """Distance of ``tau`` to the nearest face (negative outside; ``inf`` without rows)."""
        return float(np.min(self.b - self.A @ tau)) if len(self.b) else math.inf

    def required(self, margin: float | None = None) -> float:
        """The required margin (module docstring), or ``margin`` when given."""
        if margin is not None:
            return margin
        return MARGIN_KEPT * min(self.radius, self.scale)


def hold_set(A: np.ndarray, b: np.ndarray, scale: float, t: float) -> HoldSet:
    """A :class:`HoldSet` from rows ``A tau <= b`` (any scale; zero rows dropped after checking
    they hold)."""
    from planner.plan.polytope import chebyshev_centre

    A = np.asarray(A, dtype=float).reshape(len(b), -1)
    b = np.asarray(b, dtype=float)
    norms = np.linalg.norm(A, axis=1)
    keep = (norms > 0) & np.isfinite(b)
    An, bn = A[keep] / norms[keep, None], b[keep] / norms[keep]
    p = A.shape[1]
    if np.any(~(norms > 0) & (b < 0)):
        return HoldSet(An, bn, -math.inf, scale, t)
    if p == 1:  # an interval: its half-width (inf when one-sided)
        up = bn[An[:, 0] > 0]
        lo = -bn[An[:, 0] < 0]
        hi_v = float(np.min(up)) if up.size else math.inf
        lo_v = float(np.max(lo)) if lo.size else -math.inf
        radius = 0.5 * (hi_v - lo_v) if hi_v >= lo_v else -math.inf
    else:
        radius = chebyshev_centre(An, bn)[1] if len(bn) else math.inf
    return HoldSet(An, bn, float(radius), scale, t)


def least_effort(h: HoldSet, margin: float | None = None) -> np.ndarray:
    """The point of ``h`` shrunk by the required margin with the smallest ``sum |tau_j|``."""
    m = h.required(margin)
    if margin is not None and not h.radius >= m:
        raise DegenerateError(f"policy least-effort:{margin:g}: at t = {h.t:.4g} s the "
                              f"guaranteed efforts keep a margin of at most {h.radius:.4g}, "
                              f"less than {margin:g}")
    p = h.A.shape[1]
    eye = np.eye(p)
    A_ub = np.vstack([np.hstack([h.A, np.zeros((len(h.b), p))]),
                      np.hstack([eye, -eye]), np.hstack([-eye, -eye])])
    b_ub = np.concatenate([h.b - m, np.zeros(2 * p)])
    res = linprog(np.r_[np.zeros(p), np.ones(p)], A_ub=A_ub, b_ub=b_ub,
                  bounds=[(None, None)] * (2 * p), method="highs")
    if res.status != 0:
        raise DegenerateError(f"least-effort LP at t = {h.t:.4g} s failed: {res.message}")
    return np.asarray(res.x[:p])


@dataclass(frozen=True)
class Smoothest:
    """The smooth policy's result: ``taus (n, p)``, ``bound`` ``D*`` (the smallest largest
    change of commands in the safe sets, within the rate limits)."""

    taus: np.ndarray
    bound: float


def smoothest(holds: Sequence[HoldSet], rates: np.ndarray, names: Sequence[str],
              unit: str) -> Smoothest:
    """The smooth policy (module docstring): ``holds`` one per waypoint, ``rates (p,)`` the
    effort-rate limits of the effort joints (``inf``: none), ``names`` their words for
    messages.  Raises :class:`DegenerateError` when the rate limits cannot follow the safe sets
    (naming the joint, the interval and the change needed)."""
    n, p = len(holds), holds[0].A.shape[1]
    times = np.array([h.t for h in holds])
    rows, rhs = _set_rows(holds)
    diff = _diff_matrix(n, p)  # ((n-1) p, n p): tau_k+1 - tau_k
    dt = np.repeat(np.diff(times), p)
    cap = np.tile(np.asarray(rates, dtype=float), n - 1) * dt
    fin = np.isfinite(cap)
    # LP 1: min D  s.t.  tau_k in S_k,  |diff| <= D,  |diff| <= rate dt.
    ones = sparse.csr_matrix(np.ones((diff.shape[0], 1)))
    A1 = sparse.vstack([sparse.hstack([rows, sparse.csr_matrix((rows.shape[0], 1))]),
                        sparse.hstack([diff, -ones]), sparse.hstack([-diff, -ones]),
                        sparse.hstack([diff[fin], sparse.csr_matrix((int(fin.sum()), 1))]),
                        sparse.hstack([-diff[fin], sparse.csr_matrix((int(fin.sum()), 1))])])
    b1 = np.concatenate([rhs, np.zeros(2 * diff.shape[0]), cap[fin], cap[fin]])
    c1 = np.r_[np.zeros(n * p), 1.0]
    res = linprog(c1, A_ub=A1.tocsr(), b_ub=b1, bounds=[(None, None)] * (n * p) + [(0, None)],
                  method="highs")
    if res.status == 2:
        raise DegenerateError(_rate_words(rows, rhs, diff, dt, rates, names, unit, times, p))
    if res.status != 0:
        raise DegenerateError(f"smooth policy LP failed: {res.message}")
    d_star = float(res.x[-1])
    # LP 2: the least total effort among the commands that change by at most D*.
    scale = max(max(h.scale for h in holds), d_star)
    d_cap = d_star * (1 + 1e-7) + 1e-9 * scale
    eye = sparse.identity(n * p, format="csr")
    A2 = sparse.vstack([sparse.hstack([rows, sparse.csr_matrix((rows.shape[0], n * p))]),
                        sparse.hstack([diff, sparse.csr_matrix(diff.shape)]),
                        sparse.hstack([-diff, sparse.csr_matrix(diff.shape)]),
                        sparse.hstack([eye, -eye]), sparse.hstack([-eye, -eye])])
    lim = np.minimum(d_cap, np.where(fin, cap, np.inf))
    b2 = np.concatenate([rhs, lim, lim, np.zeros(2 * n * p)])
    res2 = linprog(np.r_[np.zeros(n * p), np.ones(n * p)], A_ub=A2.tocsr(), b_ub=b2,
                   bounds=[(None, None)] * (2 * n * p), method="highs")
    x = res2.x[:n * p] if res2.status == 0 else res.x[:n * p]
    return Smoothest(np.asarray(x).reshape(n, p), d_star)


def _set_rows(holds: Sequence[HoldSet]) -> tuple[sparse.csr_matrix, np.ndarray]:
    """Block rows ``A_k tau_k <= b_k - m_k`` of every waypoint's safe set."""
    blocks = [sparse.csr_matrix(h.A) for h in holds]
    rhs = np.concatenate([h.b - h.required() for h in holds])
    return sparse.block_diag(blocks, format="csr"), rhs


def _diff_matrix(n: int, p: int) -> sparse.csr_matrix:
    eye = sparse.identity((n - 1) * p, format="csr")
    zero = sparse.csr_matrix(((n - 1) * p, p))
    return (sparse.hstack([zero, eye]) - sparse.hstack([eye, zero])).tocsr()


def _rate_words(rows: sparse.csr_matrix, rhs: np.ndarray, diff: sparse.csr_matrix,
                dt: np.ndarray, rates: np.ndarray, names: Sequence[str], unit: str,
                times: np.ndarray, p: int) -> str:
    """Why the rate limits are too low: the smallest factor ``s`` on every limit that makes the
    safe sets followable, and the interval and joint where it binds."""
    n = len(times)
    r = np.tile(np.asarray(rates, dtype=float), n - 1) * dt
    fin = np.isfinite(r)
    col = sparse.csr_matrix(-r[fin][:, None])
    A = sparse.vstack([sparse.hstack([rows, sparse.csr_matrix((rows.shape[0], 1))]),
                       sparse.hstack([diff[fin], col]), sparse.hstack([-diff[fin], col])])
    b = np.concatenate([rhs, np.zeros(2 * int(fin.sum()))])
    res = linprog(np.r_[np.zeros(n * p), 1.0], A_ub=A.tocsr(), b_ub=b,
                  bounds=[(None, None)] * (n * p) + [(0, None)], method="highs")
    if res.status != 0:
        return "the effort-rate limits cannot follow the guaranteed efforts"
    s = float(res.x[-1])
    d = diff @ res.x[:n * p]
    ratio = np.where(fin, np.abs(d) / np.where(fin, r, 1.0), 0.0)
    i = int(np.argmax(ratio))
    k, j = divmod(i, p)
    rate_unit = f"{unit}/s" if unit else "per s"
    return (f"the effort-rate limit of {names[j]} ({rates[j]:.4g} {rate_unit}) cannot follow "
            f"the guaranteed efforts: between t = {times[k]:.4g} and {times[k + 1]:.4g} s its "
            f"command must change by at least {abs(d[i]):.4g} {unit}, {s:.3g} times what the "
            f"limit allows; raise the limit to {s * rates[j]:.4g} {rate_unit} or slow the "
            "segment down")


def change_report(taus: np.ndarray, times: np.ndarray, names: Sequence[str], unit: str,
                  policy: str, bound: float | None) -> dict[str, object]:
    """The largest change of the effort commands between consecutive waypoints against the
    smooth policy's bound ``D*`` (``bound``; None when not computed): a segment's
    ``extra["commands"]`` (docs/plan-format.md)."""
    taus = np.asarray(taus, dtype=float).reshape(len(times), -1)
    out: dict[str, object] = {"policy": policy, "unit": unit, "largest_change": 0.0,
                              "joint": None, "between_s": None,
                              "bound": bound, "within_bound": True}
    if taus.shape[1] == 0 or len(times) < 2:
        return out
    d = np.abs(np.diff(taus, axis=0))
    k, j = (int(x) for x in np.unravel_index(int(np.argmax(d)), d.shape))
    big = float(d[k, j])
    out.update(largest_change=big, joint=names[j],
               between_s=[float(times[k]), float(times[k + 1])])
    if bound is not None:
        scale = max(float(np.max(np.abs(taus))), bound, 1e-300)
        out["within_bound"] = bool(big <= bound + 1e-6 * scale)
    return out
