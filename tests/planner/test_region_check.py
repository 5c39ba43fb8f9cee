"""The region benchmark in short: guaranteed regions of random hands under dense friction sampling.

benchmarks/region_check.py draws random hands (:mod:`planner.sweeps.random_hands`), plans them
and checks, with the independent full mode enumeration (``feasible_modes``), that inside each
region the claimed mode is the only feasible one at every friction sample.  Here: two hands and
a handful of samples, the mirror map, and a mutation test -- a deliberately widened region must
be caught by the same check; the whole-set mode's probes and its results file.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
from campaign_module import benchmark

from planner.files.hand_file import hand_file_from_dict
from planner.plan.intervals import Interval
from planner.plan.model import Segment
from planner.sweeps.random_hands import mirror_hand, random_hand

ROOT = Path(__file__).resolve().parents[2]
rc = benchmark("region_check")


def _plan(name: str, seed: int):
    rng = np.random.default_rng(seed)
    d = random_hand(rc.template(name), rng, mu_range=(0.0, 0.3))
    return (*rc.plan_hand(d), rng)


@pytest.fixture(scope="module")
def three_finger():
    return _plan("three_finger_hand", 0)


def test_random_hands_are_seeded_and_differ_from_the_template():
    t = rc.template("two_link_finger_hand")
    a = random_hand(t, np.random.default_rng(3))
    b = random_hand(t, np.random.default_rng(3))
    c = random_hand(t, np.random.default_rng(4))
    assert a == b and a != c
    assert a["workpiece"]["vertices"] != t["workpiece"]["vertices"]
    assert a["mu"] != t["mu"]
    hand_file_from_dict(a)  # the contacts close


def test_mirror_is_an_involution_and_flips_the_drive():
    t = rc.template("two_link_finger_hand")
    m = mirror_hand(t)
    assert m["segment"]["speed"] == [-0.02, -0.01]
    hf, hm = hand_file_from_dict(t), hand_file_from_dict(m)
    # the workpiece's x is mirrored at the closed configuration
    assert hm.q0[0] == pytest.approx(-hf.q0[0], abs=1e-9)
    mm = mirror_hand(m)
    assert np.allclose(mm["workpiece"]["vertices"], t["workpiece"]["vertices"])
    assert [c.get("edge") for c in mm["contacts"]] == [c.get("edge") for c in t["contacts"]]


@pytest.mark.parametrize("name,seed", [
    ("three_finger_hand", 0),
    # 3-4 minutes of dense sampling: by hand (-m slow); the three-finger draw keeps it in CI
    pytest.param("two_link_finger_hand", 1, marks=pytest.mark.slow)])
@pytest.mark.long
def test_regions_of_random_hands_hold_under_friction_sampling(name, seed):
    hand, rp, lo, hi, rng = _plan(name, seed)
    rp = dataclasses.replace(rp, waypoints=rp.waypoints[::5], regions=rp.regions[::5])
    row = rc.check_plan(hand, rp, lo, hi, rng, n_tau=2, n_mu=8, outside=False)
    assert row["samples"] >= 8 * 3 * len(rp.waypoints)
    assert row["violations"] == []


@pytest.mark.long
def test_a_widened_region_is_caught(three_finger):
    """Mutation: every face of the region pushed out by twice the margin (the centre stays);
    the check must then find a friction sample where the claimed mode is not the only one."""
    hand, rp, lo, hi, rng = three_finger
    w = rp.waypoints[0]
    reg = rp.regions[0]
    norms = np.linalg.norm(reg.A, axis=1)
    wide = dataclasses.replace(reg, b=reg.b + 2.0 * reg.margin * norms)
    mutant: Segment = dataclasses.replace(rp, waypoints=(w,), regions=(wide,))
    row = rc.check_plan(hand, mutant, lo, hi, rng, n_tau=6, n_mu=8, outside=False)
    assert row["violations"], "a widened region passed the check"
    # ... and the outside probe of the real region finds a rival or a lost mode just past a face
    real = rc.check_plan(hand, dataclasses.replace(rp, waypoints=(w,), regions=(reg,)), lo, hi,
                         rng, n_tau=0, n_mu=8)
    assert real["violations"] == [] and real["outside_factor"][0] is not None


def test_results_file_shape():
    path = ROOT / "benchmarks" / "results" / "region_check.json"
    res = json.loads(path.read_text())
    s = res["summary"]
    assert s["violations"] == 0 and s["plans"] > 0 and s["friction_samples"] > 0


def test_set_sizes_are_read_and_bad_ones_named():
    assert rc.set_sizes("0.05,0.001,0.0005") == (0.05, 0.001, 0.0005)
    for text in ("0.05,1mm,0", "0.05,0.001", "1.2,0,0", "0.1,-0.001,0"):
        with pytest.raises(argparse.ArgumentTypeError, match=re.escape(
                "expected MASS,COM,CONTACTS (a fraction below 1, metres, metres; each >= 0), "
                f"got {text!r}")):
            rc.set_sizes(text)


def test_band_probes_sit_inside_and_mutations_outside():
    inside = rc.band_probes(Interval(1.0, 3.0), 0.5)
    assert inside == pytest.approx([1.0 + 2e-6, 2.0, 3.0 - 2e-6])
    assert rc.band_probes(Interval(0.0, np.inf), 0.5) == pytest.approx([5e-7, 0.5])
    assert rc.band_probes(Interval(-np.inf, -2.0), 0.5) == pytest.approx([-2.0 - 2e-6, -4.0])
    assert rc.widened_probes([Interval(1.0, 3.0)], 0.5) == pytest.approx([0.98, 3.02])
    assert rc.widened_probes([Interval(0.0, np.inf)], 0.5) == pytest.approx([-0.005])


def test_set_results_file_shape():
    """The whole-set run (``--set``): nothing violated, every widened band caught."""
    res = json.loads((ROOT / "benchmarks" / "results" / "region_check_set.json").read_text())
    s = res["summary"]
    assert s["violations"] == 0 and s["plans"] > 0 and s["samples"] > 0
    widened = s["mutations"]["widened_1pct"]
    assert widened["checked"] > 0 and widened["caught"] == widened["checked"]
