"""Input checks shared by every public entry point ("validate at the boundary").

Each helper returns a float ndarray of the expected shape or raises
:class:`planner.errors.InputError` with a message naming what was expected and what came.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from planner.errors import InputError

#: Tolerance for unit normals and rotated tangents given in a wrench matrix.  The paper prints
#: W (eqs. 37 and 42) rounded to three digits, so a column pair is accepted when ``|n| = 1`` and
#: ``t = rot90(n)`` hold to this tolerance.
WRENCH_COLUMN_TOL = 2e-3

#: Tolerance for unit normals given geometrically (after which they are normalised exactly).
NORMAL_TOL = 1e-6


def describe_value(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape}"
    try:
        text = repr(value)
    except RecursionError:  # absurdly deep nesting: describe it instead of crashing
        return f"a {type(value).__name__} nested too deeply to print"
    return text if len(text) <= 60 else text[:57] + "..."


def as_array(value: Any, shape: Sequence[int | None], name: str) -> np.ndarray:
    """Convert ``value`` to a finite float array of ``shape`` (``None`` = any length)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(
            f"{name}: expected numbers of shape {_shape_text(shape)}, got {describe_value(value)}"
        ) from exc
    if arr.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(arr.shape, shape)
    ):
        raise InputError(
            f"{name}: expected shape {_shape_text(shape)}, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, got NaN or inf in {arr.tolist()}")
    return arr


def _shape_text(shape: Sequence[int | None]) -> str:
    inner = ", ".join("n" if s is None else str(s) for s in shape)
    return "(" + inner + ("," if len(shape) == 1 else "") + ")"


def is_numeric(value: Any) -> bool:
    """True when ``value`` converts to a float array (nested lists of numbers)."""
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError, RecursionError):
        return False
    return True


def as_friction(value: Any, n_c: int, name: str = "mu") -> np.ndarray:
    """Friction coefficients: a scalar (broadcast) or ``(n_c,)``, each finite and ``>= 0``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(
            f"{name}: expected {n_c} friction coefficients, got {describe_value(value)}"
        ) from exc
    if arr.ndim == 0:
        arr = np.full(n_c, float(arr))
    if arr.shape != (n_c,):
        raise InputError(
            f"{name}: expected {n_c} friction coefficients (one per contact), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite friction coefficients, got {arr.tolist()}")
    if np.any(arr < 0):
        raise InputError(
            f"{name}: expected friction coefficients >= 0, got {arr.tolist()}"
        )
    return arr


def friction_interval(value: Any, n_c: int, name: str = "mu") -> tuple[np.ndarray, np.ndarray]:
    """A friction box: ``(lo, hi)`` for every contact, ``[(lo, hi), ...]`` per contact, or one
    number (a point).  Returns ``(mu_lo, mu_hi)``, each ``(n_c,)``, every end checked by
    :func:`as_friction`; errors name what was expected and what came.
    """
    if isinstance(value, (str, bytes)):
        raise InputError(
            f"{name}: expected a number or (lo, hi) pairs, got {describe_value(value)}"
        )
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(
            f"{name}: expected a number or (lo, hi) pairs, got {describe_value(value)}"
        ) from exc
    if arr.ndim == 0:
        arr = np.array([float(arr), float(arr)])
    if arr.shape == (2,):
        arr = np.broadcast_to(arr, (n_c, 2))
    if arr.shape != (n_c, 2):
        raise InputError(
            f"{name}: expected one (lo, hi) interval or {n_c} of them, got shape {arr.shape}"
        )
    lo = as_friction(arr[:, 0], n_c, name)
    hi = as_friction(arr[:, 1], n_c, name)
    if np.any(lo > hi):
        raise InputError(f"{name}: expected lo <= hi in every interval, got {arr.tolist()}")
    return lo.copy(), hi.copy()


def unit_normal(value: Any, name: str) -> np.ndarray:
    """A 2-vector of unit length (to :data:`NORMAL_TOL`), returned exactly normalised."""
    n = as_array(value, (2,), name)
    norm = float(np.hypot(n[0], n[1]))
    if norm == 0.0:
        raise InputError(f"{name}: expected a unit normal, got the zero vector")
    if abs(norm - 1.0) > NORMAL_TOL:
        raise InputError(f"{name}: expected a unit normal (|n| = 1), got |n| = {norm:.6g}")
    return n / norm


#: One simulation's friction: one coefficient for every contact, or one per contact.
FrictionValue = float | tuple[float, ...]


def validation_frictions(listed: Sequence[FrictionValue], lo: Any, hi: Any
                         ) -> tuple[FrictionValue, ...]:
    """Friction values to simulate a plan at, each a number (every contact) or a per-contact
    tuple.

    ``listed``: the hand file's ``mu.validate`` values; ``lo``, ``hi``: the planned interval per
    contact (arrays ``(n_c,)``). The listed values that lie in every contact's interval; when
    none does (none listed, or the plan was made for another interval with ``--mu``): with one
    interval for all contacts its ends and middle, else the friction box's lower corner, centre
    and upper corner (per-contact tuples): every one is covered by the plan's guarantee.
    """
    lo_a, hi_a = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)

    def inside(m: FrictionValue) -> bool:
        v = np.broadcast_to(np.asarray(m, dtype=float), lo_a.shape)
        return bool(np.all(v >= lo_a - 1e-12) and np.all(v <= hi_a + 1e-12))

    kept = tuple(m if isinstance(m, (int, float)) else tuple(float(x) for x in m)
                 for m in listed if inside(m))
    if kept:
        return tuple(float(m) if isinstance(m, (int, float)) else m for m in kept)
    if np.all(lo_a == lo_a[0]) and np.all(hi_a == hi_a[0]):
        a, b = float(lo_a[0]), float(hi_a[0])
        return tuple(sorted({a, 0.5 * (a + b), b}))
    mid = 0.5 * (lo_a + hi_a)
    return tuple(tuple(float(x) for x in v) for v in (lo_a, mid, hi_a))
