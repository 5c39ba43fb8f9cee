"""Hand model, quasistatic trajectory and torque bounds (planning side)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from planner.errors import DegenerateError, FileFormatError, InputError
from planner.files.hand_file import hand_from_dict, load_hand
from planner.model.validation import friction_interval
from planner.plan.bounds import intervals, mode_bands, mode_rows
from planner.plan.guarantee import guarantee
from planner.plan.trajectory import integrate_segment
from planner.predict.feasibility import Status, feasible_modes
from scenarios.registry import DATA_DIR, shipped_file

HAND_FILE = DATA_DIR / "two_finger_hand.json"
CLAIM = "S+1 S+2 S-3 S-4"
R2S = "R1 B2 S-3 S-4"


@pytest.fixture(scope="module")
def hand():
    h, q0, data = load_hand(HAND_FILE)
    return h, q0, data


@pytest.fixture(scope="module")
def segment(hand):
    h, q0, data = hand
    s = data["segment"]
    return integrate_segment(h, q0, drive=s["drive"], speed=s["speed"], mode=s["mode"],
                             max_time=s["max_time"], steps=200)


def _system(h, q, tau=0.0, rate=0.02):
    return h.system(q, 0.0, [{"effort": tau}, {"velocity": rate}])


# ---- hand geometry ----------------------------------------------------------------------
def test_initial_configuration_touches_every_contact(hand):
    h, q0, _ = hand
    assert np.max(np.abs(h.gaps(q0))) < 1e-12
    assert min(h.clearances(q0).values()) > 1e-3  # nothing else touches


def test_gap_jacobian_is_the_derivative_of_the_gaps(hand):
    h, q0, _ = hand
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = q0 + rng.normal(scale=[1e-3, 1e-3, 0.02, 0.02, 0.02])
        G = h.gap_jacobian(q)
        eps = 1e-7
        fd = np.array([(h.gaps(q + eps * e) - h.gaps(q - eps * e)) / (2 * eps)
                       for e in np.eye(5)]).T
        assert np.allclose(G, fd, atol=1e-7)


def test_relative_normal_velocity_is_the_gap_rate(hand):
    """eq. (5): v_n = W^T qdot - J_n thetadot equals d(gap)/dt for any motion."""
    h, q0, _ = hand
    rng = np.random.default_rng(1)
    pose_rates, thetadot = rng.normal(size=3) * 1e-2, rng.normal(size=2) * 1e-2
    system = h.system(q0, 0.0, [{"velocity": thetadot[0]}, {"velocity": thetadot[1]}])
    qdot = h.twist_from_pose_rates(q0, pose_rates)
    v = qdot @ system.W - system.J @ thetadot
    eps = 1e-7
    dq = np.concatenate([pose_rates, thetadot])
    rate = (h.gaps(q0 + eps * dq) - h.gaps(q0 - eps * dq)) / (2 * eps)
    assert np.allclose(v[0::2], rate, atol=1e-9)
    assert np.allclose(h.pose_rates_from_twist(q0, qdot), pose_rates)


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d.pop("palm"), "expected key 'palm'"),
    (lambda d: d["workpiece"]["vertices"].reverse(), "counter-clockwise"),
    (lambda d: d["contacts"][0].update(vertex=9), r"vertex: expected an integer in \[0, 4\]"),
    (lambda d: d["contacts"][2].update(kind="glue"), "kind: expected one of"),
    (lambda d: d["fingers"][0].update(length=-1), "length: expected a positive number"),
    (lambda d: d.update(version=7), "version 1"),
    (lambda d: d["palm"].update(edge=[[0.09, 0.0], [-0.06, 0.0]]), "inward side"),
])
def test_bad_hand_files_are_rejected(hand, mutate, match):
    data = copy.deepcopy(hand[2])
    mutate(data)
    with pytest.raises(FileFormatError, match=match):
        hand_from_dict(data)


def test_hand_file_errors(tmp_path):
    bad = tmp_path / "h.json"
    bad.write_text('{"palm": NaN}')
    with pytest.raises(FileFormatError, match="NaN"):
        load_hand(bad)
    bad.write_text("{" * 100000)
    with pytest.raises(FileFormatError):
        load_hand(bad)
    with pytest.raises(InputError, match="existing file"):
        load_hand(tmp_path / "missing.json")
    with pytest.raises(InputError, match="two_finger_hand"):
        shipped_file("no_such_hand")


# ---- trajectory -------------------------------------------------------------------------
def test_segment_keeps_every_contact_and_ends_edge_to_edge(hand, segment):
    h, _, _ = hand
    assert segment.mode == CLAIM
    assert segment.event.kind == "new contact"
    assert segment.event.detail == "vertex 4 meets the left finger"
    for q in segment.q:
        assert np.max(np.abs(h.gaps(q))) < 1e-10
    _, _, s = h.contact_geometry(segment.q[-1])
    assert np.all((s >= 0) & (s <= 1))
    # The left finger's side is now parallel to the long edge (vertex 4 -> 3): edge-to-edge.
    q = segment.q[-1]
    V = h.world_vertices(q)
    edge = V[3] - V[4]
    d = h.axis(q, 0)
    assert abs(edge[0] * d[1] - edge[1] * d[0]) / np.linalg.norm(edge) < 1e-6
    # 4S on a flat palm is a pure translation to the left (Sec. 5.2).
    assert np.allclose(segment.q[:, 1:3], 0.0, atol=1e-9)
    assert segment.q[-1, 0] < -0.01


def test_integration_agrees_with_the_predicted_velocities(hand, segment):
    """The RK4 steps integrate the kinematic stage's velocities: the projection back onto the
    contact manifold only removes round-off (it would hide a wrong velocity otherwise)."""
    h, _, _ = hand
    dq = np.diff(segment.q, axis=0)
    dt = np.diff(segment.t)[:, None]
    rates = np.concatenate([
        np.array([h.pose_rates_from_twist(q, qd) for q, qd in zip(segment.q, segment.qdot)]),
        segment.thetadot], axis=1)
    mid = 0.5 * (rates[1:] + rates[:-1])
    assert np.max(np.abs(dq / dt - mid)) < 1e-5 * np.max(np.abs(rates))


def test_segment_input_errors(hand):
    h, q0, _ = hand
    with pytest.raises(InputError, match="drive"):
        integrate_segment(h, q0, drive=5, speed=0.02, max_time=1.0)
    with pytest.raises(InputError, match="speed"):
        integrate_segment(h, q0, drive=1, speed=0.0, max_time=1.0)
    with pytest.raises(DegenerateError, match="exactly one kinematically admissible"):
        integrate_segment(h, q0, drive=1, speed=0.02, mode="4R", max_time=1.0)


# ---- torque bounds -----------------------------------------------------------------------
def _sampled(system, mus, union=False):
    """Intersection (or union hull) over sampled mu of each mode's interval (the paper's
    0.01-step method)."""
    rows = mode_rows(system, np.repeat(np.asarray(mus, float)[:, None], system.n_contacts, 1))
    lo, hi = intervals(rows)
    if not union:
        return {m.label: (float(np.max(lo[:, j])), float(np.min(hi[:, j])))
                for j, m in enumerate(rows.modes)}
    out = {}
    for j, m in enumerate(rows.modes):
        ok = lo[:, j] <= hi[:, j]
        if np.any(ok):
            out[m.label] = (float(np.min(lo[ok, j])), float(np.max(hi[ok, j])))
    return out


@pytest.mark.parametrize("k", [0, 20, 40])
def test_exact_bounds_match_sampling_at_0_01_and_are_never_looser(hand, segment, k):
    h, _, _ = hand
    q = segment.resample(h, 41).q[k]
    system = _system(h, q)
    exact = {b.label: b.guaranteed for b in mode_bands(system, (0.0, 0.2))}
    sampled = _sampled(system, np.round(np.arange(0.0, 0.2001, 0.01), 10))
    band = exact[CLAIM]
    lo_s, hi_s = sampled[CLAIM]
    assert band.lower >= lo_s - 1e-12 and band.upper <= hi_s + 1e-12  # never looser
    width = hi_s - lo_s
    assert band.lower - lo_s <= 0.02 * width and hi_s - band.upper <= 0.02 * width


@pytest.mark.long
def test_exact_bounds_catch_extrema_between_samples():
    """On random systems the exact guaranteed band equals dense sampling (2001 points) and is
    never looser; in some cases the binding friction lies strictly inside the interval, where
    evaluating only the ends would be too loose -- the critical points find it."""
    from planner.model.system import System

    rng = np.random.default_rng(3)
    checked = interior = unions = union_close = 0
    for _ in range(120):
        pts = rng.uniform(-1, 1, size=(3, 2))
        ang = rng.uniform(0, 2 * np.pi, size=3)
        nrm = np.stack([np.cos(ang), np.sin(ang)], 1)
        jac = rng.normal(size=(3, 2, 2))
        system = System.from_contacts(points=pts, normals=nrm, mu=0.0,
                                      external_wrench=rng.normal(size=3), jacobian=jac,
                                      joints=[{"effort": 0.0}, {"velocity": 1.0}])
        a = rng.uniform(0.0, 0.6)
        b_ = a + rng.uniform(0.05, 0.3)
        bands = [b for b in mode_bands(system, (a, b_)) if b.mode.family != "3R"]
        if not bands:
            continue
        mus = np.linspace(a, b_, 1601)
        dense = _sampled(system, mus)
        dense_u = _sampled(system, mus, union=True)
        ends = _sampled(system, [a, b_])
        for b in bands:
            if b.label in dense_u and b.exact:
                lo_u, hi_u = dense_u[b.label]
                p = b.possible
                assert p.lower <= lo_u or p.lower <= lo_u + 1e-9 * abs(lo_u)  # covers samples
                assert p.upper >= hi_u or p.upper >= hi_u - 1e-9 * abs(hi_u)
                # The hull may be larger than the samples only at isolated friction values (a
                # one-point interval where two bounds cross, or a pole): count, don't fail.
                close = all(abs(e - v) <= 1e-2 * max(1.0, abs(v))
                            for e, v in ((p.lower, lo_u), (p.upper, hi_u))
                            if np.isfinite(v) and np.isfinite(e))
                unions += 1
                union_close += close
            if b.label not in dense or b.guaranteed.empty:
                continue
            lo_s, hi_s = dense[b.label]
            g = b.guaranteed
            assert g.lower >= lo_s or g.lower >= lo_s - 1e-9 * abs(lo_s)  # never looser
            assert g.upper <= hi_s or g.upper <= hi_s + 1e-9 * abs(hi_s)
            for e, v in ((g.lower, lo_s), (g.upper, hi_s)):
                if np.isfinite(v):
                    assert abs(e - v) <= 1e-3 * max(1.0, abs(v))
            checked += 1
            lo_e, hi_e = ends[b.label]
            if (g.lower > lo_e + 1e-6 * max(1, abs(lo_e))
                    or g.upper < hi_e - 1e-6 * max(1, abs(hi_e))):
                interior += 1
    assert checked >= 10 and interior >= 1 and unions >= 20, (checked, interior, unions)
    assert union_close >= 0.8 * unions, (union_close, unions)


def test_bounds_agree_with_the_general_feasibility_test(hand, segment):
    """Independent check with feasible_modes (eqs. 13-32 incl. indeterminate modes): inside
    the guaranteed band 4S is the only feasible mode at every sampled mu; just below its lower
    end at mu = 0.2 early in the segment the R2S mode of Fig. 12 is feasible."""
    h, _, _ = hand
    q = segment.q[0]
    g = guarantee(_system(h, q), "4S", (0.0, 0.2))
    assert g.claim == CLAIM and R2S in g.rivals
    piece = g.best()
    assert np.isfinite(piece.lower) and np.isfinite(piece.upper) and piece.lower < piece.upper
    for tau in np.linspace(piece.lower, piece.upper, 7)[1:-1]:
        for mu in (0.0, 0.05, 0.1, 0.15, 0.2):
            pred = feasible_modes(_system(h, q, tau).with_mu(np.full(4, mu)))
            assert pred.status == Status.UNIQUE and pred.labels == [CLAIM], (tau, mu, pred.labels)
    r2s = {b.label: b for b in mode_bands(_system(h, q), 0.2)}[R2S].possible
    tau = 0.5 * (r2s.lower + r2s.upper)
    pred = feasible_modes(_system(h, q, tau).with_mu(np.full(4, 0.2)))
    assert R2S in pred.labels and CLAIM not in pred.labels
    # A torque outside the guaranteed band is not claimed as guaranteed.
    assert not any(p.contains(tau) for p in g.pieces)


def test_r2s_is_feasible_only_in_the_first_half(hand, segment):
    """Fig. 12: the R2S bounds cross about half way through the segment (mu = 0.2)."""
    h, _, _ = hand
    seg = segment.resample(h, 21)
    feas = []
    for q in seg.q:
        bands = {b.label: b for b in mode_bands(_system(h, q), 0.2)}
        feas.append(R2S in bands and not bands[R2S].possible.empty)
    feas = np.array(feas)
    assert feas[0] and not feas[-1]
    switch = np.flatnonzero(~feas)[0] / (len(feas) - 1)
    assert 0.3 <= switch <= 0.7
    assert not np.any(feas[np.flatnonzero(~feas)[0]:])  # stays infeasible afterwards


@pytest.mark.parametrize("mu, match", [
    ((0.3, 0.2), "lo <= hi"),
    ((-0.1, 0.2), ">= 0"),
    ((0.0, float("nan")), "finite"),
    ([[0, 0.1]] * 3, "interval or 4"),
])
def test_mu_interval_errors(mu, match):
    with pytest.raises(InputError, match=match):
        friction_interval(mu, 4)


def test_independent_box_is_at_least_as_conservative_as_common(hand, segment):
    h, _, _ = hand
    system = _system(h, segment.q[0])
    common = guarantee(system, "4S", (0.0, 0.2), model="common").best()
    box = guarantee(system, "4S", [(0.0, 0.2)] * 4, model="independent").best()
    assert box.lower >= common.lower - 1e-12 and box.upper <= common.upper + 1e-12


def test_bounds_need_exactly_one_effort_joint(hand):
    h, q0, _ = hand
    system = h.system(q0, 0.0, [{"velocity": 0.0}, {"velocity": 0.02}])
    with pytest.raises(InputError, match="exactly one effort-controlled joint"):
        mode_bands(system, 0.1)


def test_hand_file_is_json_and_documented():
    data = json.loads(HAND_FILE.read_text())
    assert data["format"] == "qsplan-hand" and "note" in data["load"]
