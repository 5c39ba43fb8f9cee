"""The ``uncertainty`` section of a hand file: the workpiece's mass interval, centre-of-mass box
and the contacts' positions along their features (docs/file-formats.md, "Hand file"; the
guarantee over them: docs/planning.md, "Uncertainty beyond friction").  Errors are
:class:`FileFormatError` naming the field."""

from __future__ import annotations

from typing import Any

import numpy as np

from planner.errors import FileFormatError, InputError
from planner.files.fields import FREE_KEYS, as_object, check_keys, number, short
from planner.model.load_set import LoadSet


def _pair(raw: Any, where: str) -> tuple[float, float]:
    if not (isinstance(raw, list) and len(raw) == 2):
        raise FileFormatError(f"{where}: expected [lo, hi], got {short(raw)}")
    lo, hi = (number(x, where) for x in raw)
    if hi < lo:
        raise FileFormatError(f"{where}: expected lo <= hi, got [{lo:g}, {hi:g}]")
    return lo, hi


def contact_offsets(raw: Any, names: tuple[str, ...]) -> tuple[float, tuple[tuple[str, float],
                                                                              ...]]:
    """``uncertainty.contacts``: a half-width [m] for every contact, or an object body name
    (``palm``, an environment surface's or a finger's name, as ``mu.bodies``) -> half-width,
    with ``"*"`` for the bodies not listed [0].  Returns ``(every, per body)``."""
    if not isinstance(raw, dict):
        return number(raw, "uncertainty.contacts", minimum=0.0), ()
    every = 0.0
    own = []
    for key, val in raw.items():
        if key == "*":
            every = number(val, "uncertainty.contacts.*", minimum=0.0)
        elif key not in names:
            raise FileFormatError(f"uncertainty.contacts: expected body names among "
                                  f"{list(names)} (the palm, environment surfaces and fingers) "
                                  f"or '*', got {key!r}")
        else:
            own.append((str(key), number(val, f"uncertainty.contacts.{key}", minimum=0.0)))
    return every, tuple(own)


def uncertainty_section(raw: Any, mass: float, com: np.ndarray,
                        names: tuple[str, ...] = ()) -> LoadSet:
    """``uncertainty``: ``mass`` ``[lo, hi]`` [kg] (default the workpiece's mass) and ``com``
    ``[[x_lo, x_hi], [y_lo, y_hi]]`` [m, body frame] (default its ``com``), each containing the
    nominal value; ``contacts`` (:func:`contact_offsets`; ``names`` the hand's body names)
    [0: the contacts where the file puts them]."""
    obj = as_object(raw, "uncertainty")
    check_keys(obj, "uncertainty", optional=("mass", "com", "contacts"), free=FREE_KEYS)
    every, own = contact_offsets(obj["contacts"], names) if "contacts" in obj else (0.0, ())
    m = _pair(obj["mass"], "uncertainty.mass") if "mass" in obj else (mass, mass)
    c = (float(com[0]), float(com[1]))
    box = ((c[0], c[0]), (c[1], c[1]))
    if "com" in obj:
        rc = obj["com"]
        if not (isinstance(rc, list) and len(rc) == 2):
            raise FileFormatError(f"uncertainty.com: expected [[x_lo, x_hi], [y_lo, y_hi]], got "
                                  f"{short(rc)}")
        box = (_pair(rc[0], "uncertainty.com[0]"), _pair(rc[1], "uncertainty.com[1]"))
    try:
        return LoadSet(m, box, mass, c, every, own)
    except InputError as exc:
        raise FileFormatError(f"uncertainty: {exc}") from None
