"""Decomposition of a box of friction space into regions labelled by their feasible-mode set.

Implements the friction-space maps of Trinkle & Zeng (1994), Figures 3, 6 and 8:

* :func:`mu_grid` labels a grid over one, two or three varied coefficients (the others fixed)
  by the general feasibility test (eqs. 26-28): the friction-independent kinematic stage (eqs.
  13-16, 23-25) runs once, then the force stage runs for all grid points at once (``mu``
  shaped ``(L, n_c)``).  ``"jam"`` marks points where no mode holds (Fig. 3), several labels
  joined by ``" | "`` mark ambiguity (Sec. 4.3).
* :func:`closed_form_regions` gives, for a noncompliant system (no effort joints), the
  closed-form region of every kinematically admissible candidate (all are 3S or RS; eqs.
  34-36, 39-41 with App. A/B, see :mod:`planner.friction.closed_form`).
* :class:`MuSpaceMap` bundles the 2-D slices (or a 3-D grid) with the closed forms; its JSON
  form (``to_dict`` / ``from_dict``) carries the labelled grids and the per-mode polynomial
  inequalities, and :meth:`MuSpaceMap.closed_form_mode_sets` re-labels any ``mu`` from the
  inequalities alone.

Differences to the paper: labels carry the sliding direction (``S+``/``S-``) as in
``docs/conventions.md``; modes within ``tol`` of a strict kinematic constraint are excluded.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.friction.closed_form import ClosedFormRegion, closed_form_region
from planner.friction.regions import JAM, SLIPS
from planner.model.modes import Mode, enumerate_modes
from planner.model.system import System
from planner.model.validation import as_friction
from planner.predict.indeterminate import DEFAULT_MAX_ROW_SUBSETS, row_subset_count
from planner.predict.stages import DEFAULT_TOL, force_stage, kinematic_stage

#: Friction vectors per batched force-stage call: keeps the ``(L, m, k, q)`` working set of
#: :func:`planner.predict.stages.force_stage` small (2-4x faster than one call over 160 000
#: vectors, measured with benchmarks/muspace_bench.py).
MU_CHUNK = 8192
FORMAT = "qsplan-muspace"
VERSION = 1


def mode_set_name(labels: list[str] | tuple[str, ...], driven: bool = True) -> str:
    """Name of a mode set: labels joined by ``" | "``; when empty ``"jam"`` (something is
    driven: it jams) or ``"slips"`` (nothing is driven: no static equilibrium holds)."""
    return " | ".join(labels) if labels else (JAM if driven else SLIPS)


@dataclass(frozen=True, eq=False)
class MuGrid:
    """A labelled grid of friction space.

    Attributes
    ----------
    vary : tuple[int, ...]        0-based contact indices varied (1, 2 or 3), axis order.
    axes : tuple[(n_a,), ...]     grid values of each varied coefficient [-].
    base_mu : (n_c,)              values of the coefficients not varied.
    labels : tuple[str, ...]      feasible mode labels (the union over the grid).
    feasible : (L, n_modes) bool  mode j feasible at grid point l (C order over the axes).
    """

    vary: tuple[int, ...]
    axes: tuple[np.ndarray, ...]
    base_mu: np.ndarray
    labels: tuple[str, ...]
    feasible: np.ndarray
    groups: tuple[tuple[int, ...], ...] = ()
    names: tuple[str, ...] = ()
    driven: bool = True

    @property
    def axis_contacts(self) -> tuple[tuple[int, ...], ...]:
        """The contacts (0-based) each axis sets: its friction group, or ``vary[j]`` alone."""
        return self.groups or tuple((i,) for i in self.vary)

    def axis_name(self, j: int) -> str:
        """Axis label: ``mu_<i>`` (1-based contact) or ``mu(<group>)``."""
        return f"mu({self.names[j]})" if self.names else f"mu_{self.vary[j] + 1}"

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)

    def points(self) -> np.ndarray:
        """All grid points as friction vectors, ``(L, n_c)`` (C order over the axes)."""
        mesh = np.meshgrid(*self.axes, indexing="ij")
        mu = np.tile(self.base_mu, (mesh[0].size, 1))
        for j, members in enumerate(self.axis_contacts):
            mu[:, list(members)] = mesh[j].ravel()[:, None]
        return mu

    def mode_sets(self) -> np.ndarray:
        """Mode-set label per grid point, shape ``self.shape``; ``"jam"`` where none holds."""
        out = np.empty(self.feasible.shape[0], dtype=object)
        for i, row in enumerate(self.feasible):
            out[i] = mode_set_name([lab for lab, f in zip(self.labels, row) if f], self.driven)
        return out.reshape(self.shape)

    def region_fractions(self) -> dict[str, float]:
        """Fraction of grid points per mode set (the decomposition's region sizes)."""
        counts = Counter(self.mode_sets().ravel().tolist())
        total = self.feasible.shape[0]
        return {k: counts[k] / total for k in sorted(counts)}

    def slice(self, axis: int, index: int) -> MuGrid:
        """The grid with varied axis ``axis`` fixed at its ``index``-th value (one dimension
        fewer); e.g. a 2-D panel of a 3-D decomposition."""
        if not 0 <= axis < len(self.vary):
            raise InputError(f"slice: expected axis in 0..{len(self.vary) - 1}, got {axis}")
        if not 0 <= index < self.shape[axis]:
            raise InputError(f"slice: expected index in 0..{self.shape[axis] - 1}, got {index}")
        base = self.base_mu.copy()
        base[list(self.axis_contacts[axis])] = self.axes[axis][index]
        feas = np.take(self.feasible.reshape(*self.shape, -1), index, axis=axis)

        def drop(t: tuple[Any, ...]) -> tuple[Any, ...]:
            return t[:axis] + t[axis + 1:]

        return MuGrid(drop(self.vary), drop(self.axes), base, self.labels,
                      feas.reshape(-1, len(self.labels)), drop(self.groups), drop(self.names),
                      self.driven)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (compact labelled grid).

        ``vary`` is 1-based; ``mode_sets`` names each distinct set of feasible modes
        (``"jam"`` for none) and ``set_members`` lists its modes as indices into ``labels``;
        ``cells`` holds one string per row of the grid (C order over all axes but the last),
        each the space-separated set indices along the last axis."""
        rows = self.feasible
        uniq, inverse = (np.unique(rows, axis=0, return_inverse=True) if rows.size
                         else (np.zeros((1, 0), bool), np.zeros(rows.shape[0], int)))
        inverse = np.asarray(inverse).reshape(self.shape)
        members = [np.flatnonzero(u).tolist() for u in uniq]
        last = self.shape[-1]
        cells = [" ".join(map(str, r)) for r in inverse.reshape(-1, last).tolist()]
        return {
            "vary": [i + 1 for i in self.vary],
            "axes": [a.tolist() for a in self.axes],
            "base_mu": self.base_mu.tolist(),
            "labels": list(self.labels),
            "mode_sets": [mode_set_name([self.labels[j] for j in m], self.driven)
                          for m in members],
            "set_members": members,
            "cells": cells,
            **({"groups": [{"name": n, "contacts": [i + 1 for i in g]}
                           for n, g in zip(self.names, self.groups)]} if self.groups else {}),
            **({} if self.driven else {"driven": False}),
        }

    @staticmethod
    def from_dict(d: dict[str, Any]) -> MuGrid:
        """Inverse of :meth:`to_dict`."""
        try:
            labels = tuple(d["labels"])
            axes = tuple(np.asarray(a, float) for a in d["axes"])
            members = d["set_members"]
            table = np.zeros((len(members), len(labels)), bool)
            for k, m in enumerate(members):
                table[k, [int(j) for j in m]] = True
            idx = np.array([[int(x) for x in row.split()] for row in d["cells"]], int)
            g = MuGrid(
                vary=tuple(int(i) - 1 for i in d["vary"]),
                axes=axes,
                base_mu=np.asarray(d["base_mu"], float),
                labels=labels,
                feasible=table[idx.reshape(-1)],
                groups=tuple(tuple(int(i) - 1 for i in g["contacts"])
                             for g in d.get("groups", ())),
                names=tuple(str(g["name"]) for g in d.get("groups", ())),
                driven=bool(d.get("driven", True)),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise InputError(f"mu grid: expected keys vary, axes, base_mu, labels, set_members, "
                             f"cells; got {exc!r}") from exc
        if g.feasible.shape[0] != int(np.prod(g.shape)):
            raise InputError(f"mu grid: expected {int(np.prod(g.shape))} cells, "
                             f"got {g.feasible.shape[0]}")
        return g


def _check_range(lo: float, hi: float) -> None:
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise InputError(f"mu range: expected finite bounds, got {lo}:{hi}")
    if lo > hi:
        raise InputError(f"mu range: expected min <= max, got min {lo} > max {hi}")
    if lo < 0:
        raise InputError(f"mu range: expected mu >= 0, got min {lo}")


def _check_vary(vary: tuple[int, ...], n_c: int) -> tuple[int, ...]:
    vary = tuple(int(i) for i in vary)
    if not 1 <= len(vary) <= 3 or len(set(vary)) != len(vary):
        raise InputError(f"vary: expected 1 to 3 distinct contacts, got {[i + 1 for i in vary]}")
    for i in vary:
        if not 0 <= i < n_c:
            raise InputError(f"vary: expected contact index in 1..{n_c}, got {i + 1}")
    return vary


def mu_grid(
    system: System,
    vary: tuple[int | tuple[int, ...], ...],
    base_mu: Any,
    mu_range: tuple[float, float] = (0.0, 1.0),
    n: int = 100,
    *,
    tol: float = DEFAULT_TOL,
    indeterminate: bool | None = None,
    names: tuple[str, ...] = (),
) -> MuGrid:
    """Label an ``n^len(vary)`` grid of the coefficients ``vary`` (0-based) by the general test
    (eqs. 26-28; kinematic stage once, force stage batched over all grid points).

    Parameters
    ----------
    system : System
    vary : 0-based contact indices (1, 2 or 3 of them) whose coefficient spans ``mu_range``;
        an entry may be a tuple of indices, a friction group whose contacts share the axis
        (``names`` then names the axes).
    base_mu : (n_c,) values of all coefficients; entries in ``vary`` are overwritten.
    mu_range : (min, max), ``0 <= min <= max``.
    n : grid points per axis (``n**3`` points for three varied coefficients).
    indeterminate : include force-indeterminate modes (relaxed utility, Sec. 3.2) by linear
        programs; default as :func:`planner.predict.feasibility.feasible_modes` (while
        ``C(2 n_c, 3 + |tau_I|)`` is within its row-subset budget).
    """
    n_c = system.n_contacts
    groups = axis_groups(vary, n_c)
    firsts = tuple(g[0] for g in groups)
    if all(len(g) == 1 for g in groups) and not names:
        groups = ()
    base = as_friction(base_mu, n_c, "base_mu")
    _check_range(*mu_range)
    if n < 1:
        raise InputError(f"n: expected >= 1 grid points per axis, got {n}")
    axes = tuple(np.linspace(mu_range[0], mu_range[1], n) for _ in firsts)
    cand = enumerate_modes(n_c, system.dof)
    kin = kinematic_stage(system, cand, tol=tol)
    grid = MuGrid(firsts, axes, base, (), np.zeros((n ** len(firsts), 0), bool), groups,
                  tuple(names), kin.velocity_scale != 0.0)
    mu = grid.points()
    index = np.flatnonzero(kin.ok)
    labels = tuple(
        Mode(tuple(int(c) for c in cand.codes[i]), tuple(int(x) for x in kin.xi[i])).label
        for i in index
    )
    if index.size:
        parts = []
        for a in range(0, mu.shape[0], MU_CHUNK):
            fs = force_stage(system, cand, index, kin.xi[index], mu[a:a + MU_CHUNK], tol=tol)
            parts.append(fs.nonsingular & (fs.margin >= -tol))
        feas = np.concatenate(parts)
    else:
        feas = np.zeros((mu.shape[0], 0), bool)
    if indeterminate is None:
        indeterminate = row_subset_count(system) <= DEFAULT_MAX_ROW_SUBSETS
    if indeterminate:
        extra_labels, extra = _indeterminate_grid(system, grid, mu, tol)
        labels = labels + extra_labels
        feas = np.concatenate([feas, extra], axis=1)
    keep = np.any(feas, axis=0)
    return MuGrid(firsts, axes, base, tuple(lab for lab, k in zip(labels, keep) if k),
                  feas[:, keep], grid.groups, grid.names, grid.driven)


def axis_groups(vary: Any, n_c: int) -> tuple[tuple[int, ...], ...]:
    """The contacts of each varied axis: an index, or a tuple of indices (a friction group);
    checked: 1 to 3 axes, indices in range, no contact on two axes."""
    groups = tuple(tuple(int(i) for i in v) if isinstance(v, (tuple, list)) else (int(v),)
                   for v in vary)
    flat = [i for g in groups for i in g]
    if any(not g for g in groups) or len(set(flat)) != len(flat) or not 1 <= len(groups) <= 3:
        raise InputError(f"vary: expected 1 to 3 distinct contacts (or groups of them), got "
                         f"{[[i + 1 for i in g] for g in groups]}")
    _check_vary(tuple(g[0] for g in groups), n_c)
    for i in flat:
        if not 0 <= i < n_c:
            raise InputError(f"vary: expected contact index in 1..{n_c}, got {i + 1}")
    return groups


def _indeterminate_grid(system: System, grid: MuGrid, mu: np.ndarray, tol: float
                        ) -> tuple[tuple[str, ...], np.ndarray]:
    """Force-indeterminate modes (relaxed utility, Sec. 3.2) on the grid, as in
    :func:`planner.predict.feasibility.feasible_modes`, by two linear programs per mode and grid
    line of a varied coefficient of one contact (:mod:`planner.friction.relaxed_map`: the
    feasible coefficients of a line form an interval), not one per point.  When every axis is a
    friction group of several contacts the interval argument does not hold and every point gets
    its own linear program (:func:`planner.friction.relaxed_map.relaxed_mode_at_points`)."""
    from planner.friction.relaxed_map import relaxed_mode_at_points, relaxed_mode_on_lines
    from planner.predict.indeterminate import indeterminate_kinematics

    kins = indeterminate_kinematics(system, tol=tol)
    if not kins:
        return (), np.zeros((mu.shape[0], 0), bool)
    shape = tuple(len(a) for a in grid.axes)
    single = [j for j, g in enumerate(grid.axis_contacts) if len(g) == 1]
    out = np.zeros((mu.shape[0], len(kins)), bool)
    if not single:
        for m, kin in enumerate(kins):
            out[:, m] = relaxed_mode_at_points(system, kin, mu, tol)
        return tuple(k.mode.label for k in kins), out
    ax = single[0]
    pts = np.moveaxis(mu.reshape(*shape, -1), ax, 0)
    moved = pts.shape[:-1]
    rests = list(np.ndindex(*moved[1:])) if len(moved) > 1 else [()]
    others = np.array([pts[(0,) + tuple(rest)] for rest in rests])
    for m, kin in enumerate(kins):
        lines = relaxed_mode_on_lines(system, kin, grid.axes[ax], others, grid.vary[ax], tol)
        col = np.zeros(moved, bool)
        for li, rest in enumerate(rests):
            col[(slice(None),) + tuple(rest)] = lines[li]
        out[:, m] = np.moveaxis(col, 0, ax).reshape(-1)
    return tuple(k.mode.label for k in kins), out


def closed_form_regions(system: System, *, tol: float = DEFAULT_TOL
                        ) -> tuple[ClosedFormRegion, ...]:
    """Closed-form regions (eqs. 34-36, 39-41; App. A/B) of every kinematically admissible
    candidate of a noncompliant system.

    Every candidate of a system without effort joints has ``2 n_R + n_S = 3`` (3S or RS), so
    the returned regions decide every mode.  Returns ``()`` for compliant systems (effort
    joints: modes 2R, R2S, 4S ..., decided by the general test only)."""
    if system.dof != 3:
        return ()
    cand = enumerate_modes(system.n_contacts, system.dof)
    kin = kinematic_stage(system, cand, tol=tol)
    return tuple(closed_form_region(system.W, system.g_obj, cand.codes[i], kin.xi[i])
                 for i in np.flatnonzero(kin.ok))


@dataclass(frozen=True, eq=False)
class MuSpaceMap:
    """Friction-space decomposition: labelled grids and the closed-form regions.

    Attributes
    ----------
    n_contacts : int
    grids : tuple[MuGrid, ...]      2-D slices (one per panel) or one 3-D grid.
    titles : tuple[str, ...]        one per grid.
    closed_forms : tuple[ClosedFormRegion, ...]
        Per-mode inequalities (empty for compliant systems).
    """

    n_contacts: int
    grids: tuple[MuGrid, ...]
    titles: tuple[str, ...]
    closed_forms: tuple[ClosedFormRegion, ...]

    def panels(self, count: int = 4) -> tuple[list[MuGrid], list[str]]:
        """2-D panels for plotting: the slices as they are, or ``count`` evenly spaced slices
        of a 3-D grid across its third varied coefficient."""
        panels, titles = [], []
        for g, title in zip(self.grids, self.titles):
            if len(g.vary) == 2:
                panels.append(g)
                titles.append(title)
            elif len(g.vary) == 3:
                n3 = g.shape[2]
                picks = np.unique(np.linspace(0, n3 - 1, max(1, min(count, n3))).round())
                for k in picks.astype(int):
                    panels.append(g.slice(2, int(k)))
                    titles.append(f"{g.axis_name(2)}={g.axes[2][k]:.3g}")
            else:
                raise InputError(f"panels: expected 2-D or 3-D grids, got {len(g.vary)}-D")
        return panels, titles

    def closed_form_mode_sets(self, mu: np.ndarray) -> np.ndarray:
        """Mode-set name per row of ``mu (L, n_c)`` from the closed-form inequalities alone."""
        mu = np.atleast_2d(np.asarray(mu, float))
        if not self.closed_forms:
            raise InputError("closed_form_mode_sets: expected a map with closed forms "
                             "(noncompliant system), got none")
        inside = np.stack([r.contains(mu) for r in self.closed_forms], axis=1)
        names = [r.label for r in self.closed_forms]
        return np.array([mode_set_name([n for n, f in zip(names, row) if f]) for row in inside],
                        dtype=object)

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``{"format", "version", "n_contacts", "slices": [grid...], "titles",
        "closed_forms": [region...]}`` (docs/muspace.md)."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "n_contacts": self.n_contacts,
            "slices": [g.to_dict() for g in self.grids],
            "titles": list(self.titles),
            "region_fractions": [g.region_fractions() for g in self.grids],
            "closed_forms": [r.to_dict() for r in self.closed_forms],
        }

    @staticmethod
    def from_dict(d: dict[str, Any]) -> MuSpaceMap:
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            got = d.get("format") if isinstance(d, dict) else type(d).__name__
            raise InputError(f"muspace map: expected format {FORMAT!r}, got {got!r}")
        grids = tuple(MuGrid.from_dict(s) for s in d["slices"])
        titles = tuple(d.get("titles", [""] * len(grids)))
        return MuSpaceMap(int(d["n_contacts"]), grids, titles,
                          tuple(ClosedFormRegion.from_dict(r) for r in d.get("closed_forms", [])))


def muspace_map(
    system: System,
    vary: tuple[int | tuple[int, ...], ...],
    base_mu: Any = None,
    mu_range: tuple[float, float] = (0.0, 1.0),
    n: int = 100,
    *,
    sliced: int | tuple[int, ...] | None = None,
    slice_values: tuple[float, ...] = (),
    tol: float = DEFAULT_TOL,
    names: tuple[str, ...] = (),
    slice_name: str = "",
) -> MuSpaceMap:
    """Decompose a box of friction space (Figs. 3, 6): one grid over ``vary`` (0-based, 1-3
    contacts) or, with ``sliced``, one 2-D grid per value of that coefficient.

    ``base_mu (n_c,)`` defaults to ``system.mu``.  A coefficient may not be both varied and
    sliced."""
    n_c = system.n_contacts
    flat = [i for g in axis_groups(vary, n_c) for i in g]
    base = as_friction(system.mu if base_mu is None else base_mu, n_c, "base_mu")
    grids, titles = [], []
    if sliced is None:
        grids.append(mu_grid(system, vary, base, mu_range, n, tol=tol, names=names))
        titles.append("")
    else:
        cut = list(sliced) if isinstance(sliced, (tuple, list)) else [int(sliced)]
        for c in cut:
            if not 0 <= c < n_c:
                raise InputError(f"slice: expected contact index in 1..{n_c}, got {c + 1}")
            if c in flat:
                raise InputError(f"slice: expected a contact not in vary, got {c + 1}")
        if not slice_values:
            raise InputError("slice: expected at least one value, got none")
        for v in slice_values:
            if not np.isfinite(v) or v < 0:
                raise InputError(f"slice: expected finite mu >= 0, got {list(slice_values)}")
            mu = base.copy()
            mu[cut] = v
            grids.append(mu_grid(system, vary, mu, mu_range, n, tol=tol, names=names))
            titles.append(f"mu({slice_name})={v:g}" if slice_name else f"mu_{cut[0] + 1}={v:g}")
    return MuSpaceMap(n_c, tuple(grids), tuple(titles), closed_form_regions(system, tol=tol))
