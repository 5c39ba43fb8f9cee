"""Contact modes: enumeration under the utility conditions (29)-(32) and notation.

A contact mode assigns each contact one interaction: rolling ``R`` (eq. 9), sliding ``S``
(eq. 10; its direction ``xi = sgn(v_t)`` (eq. 16) is fixed by the kinematics, written ``S+`` or
``S-``), or breaking ``B`` (eq. 11).  The paper's implementation (Section 4.7) tests the modes
with exactly ``2 n_R + n_S = 3 + |tau_I|`` kinematic constraints; their number is eq. (49).

Mode strings: one token per contact in contact order, e.g. ``"R1 S-2 B3"``.

References
----------
Trinkle & Zeng (1994), eqs. (12), (14), (29)-(32), (49), Table 1.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property, lru_cache
from math import comb

import numpy as np

from planner.errors import InputError

BREAK, SLIDE, ROLL = 0, 1, 2
_CODE_LETTER = {BREAK: "B", SLIDE: "S", ROLL: "R"}


@lru_cache(maxsize=1024)
def candidate_count(n_contacts: int, dof: int) -> int:
    """Number of contact modes tested, eq. (49).

    ``sum_{n_R=0}^{floor(dof/2)} C(n_c, n_R) C(n_c - n_R, dof - 2 n_R)`` with
    ``dof = 3 + |tau_I|``.  Zero when ``n_c < dof / 2`` (no mode meets the utility conditions).
    """
    if n_contacts < 0 or dof < 0:
        raise InputError(
            f"candidate_count: expected n_c >= 0 and dof >= 0, got {n_contacts}, {dof}"
        )
    total = 0
    for n_r in range(dof // 2 + 1):
        n_s = dof - 2 * n_r
        if n_r + n_s <= n_contacts:
            total += comb(n_contacts, n_r) * comb(n_contacts - n_r, n_s)
    return total


@dataclass(frozen=True)
class CandidateSet:
    """All candidate modes with ``2 n_R + n_S = n_rows`` as arrays (read-only).

    Attributes
    ----------
    codes : (M, n_c) int8
        ``ROLL``/``SLIDE``/``BREAK`` per contact.
    rows : (M, n_rows) int
        Applicable constraint rows in the paper's order ``[n_R rows; t_R rows; n_S rows]``
        (eq. 14): row ``2i`` is the normal of contact ``i``, ``2i + 1`` its tangent.
    sliding : (M, n_rows) bool
        True where the row is the normal of a sliding contact (its column of ``W_Amu``
        is ``w_n - mu xi w_t``, eq. 18-19).
    contact : (M, n_rows) int
        Contact index of each row.
    """

    n_contacts: int
    n_rows: int
    codes: np.ndarray
    rows: np.ndarray
    sliding: np.ndarray
    contact: np.ndarray

    def __len__(self) -> int:
        return self.codes.shape[0]

    @cached_property
    def masks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(breaking, sliding, rolling)``: ``(M, n_c)`` bool masks of :attr:`codes` (computed
        once per candidate set; :func:`enumerate_modes` sets are shared)."""
        return self.codes == BREAK, self.codes == SLIDE, self.codes == ROLL

    @cached_property
    def tangent_rows(self) -> np.ndarray:
        """``(M, n_rows)``: the tangent row ``2 i + 1`` of each row's contact ``i``."""
        return 2 * self.contact + 1

    @cached_property
    def strict_rows(self) -> np.ndarray:
        """``(M, 2 n_c)`` bool over ``v = [v_1n, v_1t, ...]``: the normal of a breaking
        contact (``v_n > 0``, eq. 25) and the tangent of a sliding one (``|v_t| > 0``, eq. 16),
        the strict kinematic constraints."""
        breaking, sliding, _ = self.masks
        out = np.empty((len(self), 2 * self.n_contacts), bool)
        out[:, 0::2], out[:, 1::2] = breaking, sliding
        out.setflags(write=False)
        return out


@lru_cache(maxsize=64)
def enumerate_modes(n_contacts: int, n_rows: int) -> CandidateSet:
    """Enumerate the modes with ``2 n_R + n_S = n_rows`` (eq. 29 with the Sec. 4.7 partition).

    Ordered by ``n_R`` then lexicographically by the rolling and sliding sets.  The result
    is cached and read-only; its length is :func:`candidate_count` ``(n_contacts, n_rows)``.
    """
    if n_contacts < 1:
        raise InputError(f"enumerate_modes: expected n_c >= 1, got {n_contacts}")
    code_blocks, row_blocks = [], []
    contacts = range(n_contacts)
    for n_r in range(n_rows // 2 + 1):
        n_s = n_rows - 2 * n_r
        if n_r + n_s > n_contacts:
            continue
        r_list = list(itertools.combinations(contacts, n_r))
        r_sets = np.array(r_list, dtype=np.int64).reshape(len(r_list), n_r)
        block_codes, block_rows = [], []
        for r_set in r_sets:
            rest = [c for c in contacts if c not in set(r_set.tolist())]
            s_list = list(itertools.combinations(rest, n_s))
            s_sets = np.array(s_list, dtype=np.int64).reshape(len(s_list), n_s)
            m = s_sets.shape[0]
            codes = np.zeros((m, n_contacts), dtype=np.int8)
            codes[:, r_set] = ROLL
            np.put_along_axis(codes, s_sets, SLIDE, axis=1)
            rows = np.concatenate(
                [np.broadcast_to(2 * r_set, (m, n_r)), np.broadcast_to(2 * r_set + 1, (m, n_r)),
                 2 * s_sets],
                axis=1,
            )
            block_codes.append(codes)
            block_rows.append(rows)
        if block_codes:
            code_blocks.append(np.concatenate(block_codes))
            row_blocks.append(np.concatenate(block_rows))
    if code_blocks:
        codes = np.concatenate(code_blocks)
        rows = np.concatenate(row_blocks).astype(np.int64)
    else:
        codes = np.zeros((0, n_contacts), dtype=np.int8)
        rows = np.zeros((0, n_rows), dtype=np.int64)
    contact = rows // 2
    n_r_per = (codes == ROLL).sum(axis=1)
    col = np.arange(n_rows)[None, :]
    sliding = col >= 2 * n_r_per[:, None]
    for arr in (codes, rows, sliding, contact):
        arr.setflags(write=False)
    return CandidateSet(n_contacts, n_rows, codes, rows, sliding, contact)


def iter_candidate_codes(n_contacts: int, n_rows: int, chunk: int) -> Iterator[np.ndarray]:
    """The codes of :func:`enumerate_modes` ``(n_contacts, n_rows)``, in its order, as
    ``(<= chunk, n_contacts) int8`` blocks: memory bounded by ``chunk`` at any ``n_c``."""
    if chunk < 1:
        raise InputError(f"chunk: expected an integer >= 1, got {chunk}")
    contacts = range(n_contacts)
    buf: list[np.ndarray] = []
    filled = 0
    for n_r in range(n_rows // 2 + 1):
        n_s = n_rows - 2 * n_r
        if n_r + n_s > n_contacts:
            continue
        for r_set in itertools.combinations(contacts, n_r):
            rest = np.array([c for c in contacts if c not in set(r_set)], dtype=np.int64)
            s_iter = itertools.combinations(range(len(rest)), n_s)
            while True:
                picked = list(itertools.islice(s_iter, chunk - filled))
                if not picked:
                    break
                s_idx = np.array(picked, dtype=np.int64).reshape(len(picked), n_s)
                codes = np.zeros((len(picked), n_contacts), dtype=np.int8)
                codes[:, list(r_set)] = ROLL
                np.put_along_axis(codes, rest[s_idx], SLIDE, axis=1)
                buf.append(codes)
                filled += len(picked)
                if filled >= chunk:
                    yield np.concatenate(buf)
                    buf, filled = [], 0
    if buf:
        yield np.concatenate(buf)


def candidates_from_codes(codes: np.ndarray, n_rows: int) -> CandidateSet:
    """Build a :class:`CandidateSet` from mode codes ``(M, n_c)`` (each with ``n_rows`` rows).

    Rows follow :func:`planner.model.modes.enumerate_modes`: ``[n_R normals; t_R tangents; n_S
    normals]`` (eq. 14), each block in contact order, so the arithmetic per candidate is the
    same as on the exhaustive path.
    """
    codes = np.asarray(codes, dtype=np.int8)
    M, n_c = codes.shape
    if M == 0:  # e.g. no candidate at all (n_c < n_rows / 2, eq. 49 count 0)
        empty = np.zeros((0, n_rows), dtype=np.int64)
        return CandidateSet(n_c, n_rows, codes, empty, empty.astype(bool), empty.copy())
    if n_rows > 2 * n_c:
        raise InputError(
            f"n_rows: expected at most 2 n_c = {2 * n_c} constraint rows, got {n_rows}"
        )
    idx = np.arange(n_c)
    big = 4 * n_c
    key_n = np.where(codes == ROLL, idx, np.where(codes == SLIDE, 2 * n_c + idx, big))
    key_t = np.where(codes == ROLL, n_c + idx, big)
    keys = np.concatenate([key_n, key_t], axis=1)  # (M, 2 n_c)
    row_id = np.concatenate([np.broadcast_to(2 * idx, (M, n_c)),
                             np.broadcast_to(2 * idx + 1, (M, n_c))], axis=1)
    order = np.argsort(keys, axis=1, kind="stable")[:, :n_rows]
    rows = np.take_along_axis(row_id, order, axis=1).astype(np.int64)
    sel = np.take_along_axis(keys, order, axis=1)
    if M and np.any(sel >= big):
        raise InputError(f"codes: expected every mode to have {n_rows} constraint rows")
    sliding = sel >= 2 * n_c
    contact = rows // 2
    return CandidateSet(n_c, n_rows, codes, rows, sliding, contact)


@dataclass(frozen=True)
class Mode:
    """A contact mode with sliding directions.

    Attributes
    ----------
    codes : tuple of int
        ``ROLL``/``SLIDE``/``BREAK`` per contact.
    xi : tuple of int
        ``sgn(v_it)`` per contact (eq. 16); 0 for non-sliding contacts.
    """

    codes: tuple[int, ...]
    xi: tuple[int, ...]

    @property
    def tokens(self) -> tuple[str, ...]:
        """Per-contact tokens ``R``, ``S+``, ``S-``, ``B`` (no index)."""
        out = []
        for code, xi in zip(self.codes, self.xi):
            if code == SLIDE:
                out.append("S+" if xi > 0 else "S-" if xi < 0 else "S")
            else:
                out.append(_CODE_LETTER[code])
        return tuple(out)

    @property
    def label(self) -> str:
        """Mode string, e.g. ``"R1 S-2 B3"`` (1-based contact indices)."""
        return " ".join(f"{tok}{i + 1}" for i, tok in enumerate(self.tokens))

    @property
    def family(self) -> str:
        """The paper's class name: ``3S``, ``RS``, ``R2S``, ``4S``, ``2R`` ... (no ``B``)."""
        n_r = sum(1 for c in self.codes if c == ROLL)
        n_s = sum(1 for c in self.codes if c == SLIDE)
        parts = []
        if n_r:
            parts.append("R" if n_r == 1 else f"{n_r}R")
        if n_s:
            parts.append("S" if n_s == 1 else f"{n_s}S")
        if n_r == 1 and n_s > 1:
            return f"R{n_s}S"
        return "".join(parts) or "B"

    def __str__(self) -> str:
        return self.label

    @classmethod
    def parse(cls, text: str, n_contacts: int | None = None) -> Mode:
        """Parse a mode string such as ``"R1 S-2 B3"`` (tokens in contact order)."""
        tokens = text.split()
        if n_contacts is not None and len(tokens) != n_contacts:
            raise InputError(
                f"mode {text!r}: expected {n_contacts} tokens (one per contact), got {len(tokens)}"
            )
        codes, xis = [], []
        for i, tok in enumerate(tokens):
            idx = str(i + 1)
            if not tok.endswith(idx):
                raise InputError(
                    f"mode {text!r}: expected token {i + 1} to end with contact index {idx}, "
                    f"got {tok!r}"
                )
            head = tok[: -len(idx)]
            table = {"R": (ROLL, 0), "B": (BREAK, 0), "S+": (SLIDE, 1), "S-": (SLIDE, -1)}
            if head not in table:
                raise InputError(
                    f"mode {text!r}: expected R, S+, S- or B before {idx}, got {head!r}"
                )
            c, x = table[head]
            codes.append(c)
            xis.append(x)
        return cls(tuple(codes), tuple(xis))


def frictionless_duplicates_removed(boundary: tuple[Mode, ...], labels: set[str],
                                    mu: np.ndarray) -> tuple[Mode, ...]:
    """``boundary`` without the modes that differ from a feasible mode (``labels``) only by a
    frictionless contact "sliding" at zero speed (``S`` with ``xi = 0`` for ``R``): with
    ``mu_i = 0`` both carry no tangential force and move alike: no slip boundary exists."""
    out = []
    for b in boundary:
        zero = [i for i, (c, x) in enumerate(zip(b.codes, b.xi)) if c == SLIDE and x == 0]
        if zero and all(mu[i] == 0.0 for i in zero):
            codes = tuple(ROLL if i in zero else c for i, c in enumerate(b.codes))
            if Mode(codes, tuple(0 if i in zero else x for i, x in enumerate(b.xi))).label \
                    in labels:
                continue
        out.append(b)
    return tuple(out)


def family_names(n_contacts: int) -> tuple[str, ...]:
    """Every class name (:attr:`Mode.family`) a mode of ``n_contacts`` contacts can have, from
    ``B`` (every contact breaking) to ``nR`` (all rolling)."""
    out: list[str] = []
    for n_r in range(n_contacts + 1):
        for n_s in range(n_contacts + 1 - n_r):
            codes = (ROLL,) * n_r + (SLIDE,) * n_s + (BREAK,) * (n_contacts - n_r - n_s)
            name = Mode(codes, (0,) * n_contacts).family
            if name not in out:
                out.append(name)
    return tuple(out)


def check_mode_claim(text: str, n_contacts: int) -> str:
    """A claimed mode of ``n_contacts`` contacts: a class name of :func:`family_names` (kept
    as given) or a full mode string (docs/conventions.md, "Mode notation"; returned in its
    canonical spelling, single spaces).  Raises :class:`InputError` saying which of the two was
    expected and why ``text`` is neither."""
    families = family_names(n_contacts)
    if text in families:
        return text
    try:
        return Mode.parse(text, n_contacts).label
    except InputError as exc:
        shown = ", ".join(families[:8]) + (" ..." if len(families) > 8 else "")
        raise InputError(
            f"expected a mode family of {n_contacts} contacts ({shown}) or a mode string of "
            f"{n_contacts} tokens such as {Mode((SLIDE,) * n_contacts, (1,) * n_contacts).label!r}"
            f", got {text[:60]!r} ({exc})") from None
