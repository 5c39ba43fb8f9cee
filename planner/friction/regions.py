"""Names of friction-map regions by what happens (docs/conventions.md, "Statuses")."""

from __future__ import annotations

#: Name of the empty mode set of a driven system: no mode is feasible, it jams (Fig. 3).
JAM = "jam"
#: Name of the empty mode set of an undriven system (no static equilibrium: the load moves it).
SLIPS = "slips"


def region_words(name: str, driven: bool = True) -> str:
    """What happens in a region, in words: ``jams``, ``slips``, ``stays (R1 R2)`` or
    ``moves: S+1 R2`` (several modes: ``ambiguous: ...``)."""
    if name == JAM:
        return "jams: no mode is feasible"
    if name == SLIPS:
        return "slips: no static equilibrium, the load moves it"
    if not driven:
        return f"stays: {name}"
    return f"{'ambiguous' if ' | ' in name else 'moves'}: {name}"
