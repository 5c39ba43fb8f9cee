"""Golden results from the paper: Table 1, Examples 4.1 and 4.3, the rod of Section 5.1."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from certify import check_certificate

from planner import System, candidate_count, enumerate_modes, feasible_modes
from planner.model.modes import Mode

TABLE_1 = {
    -1: [6, 16, 45, 126, 357, 1016],
    0: [7, 19, 51, 141, 393, 1107],
    +1: [6, 16, 45, 126, 357, 1016],
}


@pytest.mark.parametrize("offset", sorted(TABLE_1))
def test_table_1_counts(offset):
    got = [candidate_count(n_c, n_c + offset) for n_c in range(3, 9)]
    assert got == TABLE_1[offset]


@pytest.mark.parametrize("n_c", range(3, 9))
@pytest.mark.parametrize("offset", [-1, 0, 1])
def test_enumeration_matches_eq_49(n_c, offset):
    dof = n_c + offset
    cand = enumerate_modes(n_c, dof)
    assert len(cand) == candidate_count(n_c, dof)
    n_r = (cand.codes == 2).sum(1)
    n_s = (cand.codes == 1).sum(1)
    assert np.all(2 * n_r + n_s == dof)
    assert len({tuple(c) for c in cand.codes}) == len(cand)  # no duplicates


def test_n12_count_is_73789():
    assert candidate_count(12, 12) == 73789


def _labels_over_cube(system, n=11):
    seen = {}
    for mu in itertools.product(np.linspace(0, 1, n), repeat=3):
        pred = feasible_modes(system, mu)
        for fm in pred.modes:
            check_certificate(system, fm, mu)
        seen[mu] = set(pred.labels)
    return seen


def test_example_41_modes(example_41):
    seen = _labels_over_cube(example_41)
    union = set().union(*seen.values())
    assert union == {"S+1 S-2 S-3", "R1 S-2 B3"}
    assert {Mode.parse(m).family for m in union} == {"3S", "RS"}
    assert any(not s for s in seen.values()), "part of the cube must be jammed"
    grid = np.linspace(0, 1, 11)

    def area(label, mu3):
        return sum(label in seen[(a, b, mu3)] for a in grid for b in grid)

    s3 = [area("S+1 S-2 S-3", m3) for m3 in grid]
    rs = [area("R1 S-2 B3", m3) for m3 in grid]
    assert all(x >= y for x, y in zip(s3, s3[1:])) and s3[0] > s3[-1], s3  # 3S shrinks with mu_3
    assert len(set(rs)) == 1 and rs[0] > 0  # R1 S2 unaffected by mu_3


def test_example_43_modes(example_43):
    seen = _labels_over_cube(example_43)
    union = set().union(*seen.values())
    families = sorted((Mode.parse(m).family, m) for m in union)
    assert len(union) == 4, families
    parsed = {Mode.parse(m).tokens for m in union}
    expected_patterns = {("S", "S", "S"), ("R", "B", "S"), ("S", "R", "B"), ("S", "B", "R")}
    assert {tuple(t[0] for t in p) for p in parsed} == expected_patterns  # 3S, R1S3, R2S1, R3S1
    triples = sum(len(s) == 3 for s in seen.values())
    assert triples > 0.3 * len(seen), triples  # three at once over a large region
    for mu, labels in seen.items():
        if max(mu) <= 0.1:
            assert not labels, (mu, labels)  # nothing near the origin


def rod(l1, l2, mu1, mu2, speed=1.0):
    """Thin rod on two supports approaching each other (Sec. 5.1, Fig. 7)."""
    return System.from_contacts(
        points=[[-l1, 0.0], [l2, 0.0]], normals=[[0.0, 1.0], [0.0, 1.0]], mu=[mu1, mu2],
        external_wrench=[0.0, -1.0, 0.0],
        # support 1 moves +x, support 2 moves -x; t = rot90(n) = (-1, 0)
        contact_velocities=[[0.0, -speed], [0.0, speed]],
    )


@pytest.mark.parametrize("l1,l2", [(0.4, 0.25), (0.1, 0.3), (0.2, 0.2)])
def test_rod_modes_follow_line(l1, l2):
    for mu1, mu2 in itertools.product(np.linspace(0.05, 1, 12), repeat=2):
        pred = feasible_modes(rod(l1, l2, mu1, mu2), tol=1e-9)
        families = {tuple(t[0] for t in m.mode.tokens) for m in pred.modes}
        lhs, rhs = l1 * mu2, l2 * mu1
        if lhs > rhs * (1 + 1e-6):
            assert families == {("S", "R")}  # R2 S1: far support slides
        elif lhs < rhs * (1 - 1e-6):
            assert families == {("R", "S")}
        else:
            assert families == {("S", "R"), ("R", "S")}


def test_rod_sliding_support_moves_toward_centre():
    pred = feasible_modes(rod(0.4, 0.25, 0.3, 0.3))
    (fm,) = pred.modes
    # the support farther from the centre of mass slides; relative to it the rod moves -x,
    # i.e. +t with t = rot90(n) = (-1, 0), so xi = +1
    assert fm.label == "S+1 R2"
    assert fm.qdot[0] < 0  # the rod moves with the sticking support (-x)
