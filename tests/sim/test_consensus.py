"""Engine artefacts measured per run and the consensus of several engines (sim.consensus).

Thresholds (docs/simulation.md, "Engines side by side"): each effect is named when it alone
takes more judged steps out of the predicted mode than the judge allows, or is below what the
classifier resolves -- checked here just below and just above each threshold on constructed
recordings, on recorded traces of every engine (tests/data/sim_trace_*.npz) and on recorded
summaries of one system in the three engines, where MuJoCo creeps.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from sim_traces import load_trace

from planner.files.schema import load_schema
from planner.model.modes import BREAK, ROLL, SLIDE, Mode
from sim.classify import Thresholds
from sim.consensus import (
    OFF_MODE_FRACTION,
    consensus,
    consensus_of,
    engine_measures,
    segment_consensus,
)
from sim.expectation import ModeSet
from sim.judge import judge
from sim.run import Recording
from sim.scene import preload_depth

DATA = Path(__file__).parents[1] / "data"
T, DT = 1000, 1e-3
SLIP = 1e-3
TH = Thresholds(slip_speed=SLIP, force_floor=1e-3, window=0.1, settle=0.0)
LENGTH = 0.1


class _Mode:
    """A predicted mode as the expectation holds it (only ``mode`` is read)."""

    def __init__(self, codes: tuple[int, ...]) -> None:
        self.mode = Mode(codes, tuple(0 for _ in codes))


def _expect(codes: tuple[int, ...]) -> ModeSet:
    return ModeSet((_Mode(codes),), None, 1.0, ("workpiece",), 0.02, LENGTH, 1.0)  # type: ignore[arg-type]


def _rec(vt: np.ndarray | None = None, fn: np.ndarray | None = None,
         depth: np.ndarray | None = None, P: int = 2) -> Recording:
    times = DT * np.arange(1, T + 1)
    z = np.zeros((T, P))
    return Recording(
        engine="test", pair_names=tuple(f"c{i + 1}" for i in range(P)),
        body_names=("workpiece",), times=times, poses=np.zeros((T, 1, 3)),
        present=np.ones((T, P), dtype=bool), points=np.zeros((T, P, 2)),
        normals=np.zeros((T, P, 2)), normal_force=np.ones((T, P)) if fn is None else fn,
        tangent_force=z, slip_velocity=z.copy() if vt is None else vt,
        depth=np.full((T, P), preload_depth(LENGTH)) if depth is None else depth, mu_used=z)


def _kinds(m: dict) -> list[str]:
    return [a["kind"] for a in m["artefacts"]]


def test_a_sticking_contact_that_slips_on_more_than_the_judges_allowance_is_creep():
    # contact 1 predicted to stick slides at 3 x the slip threshold on a block of steps
    codes = (ROLL, SLIDE)
    for frac, named in ((OFF_MODE_FRACTION - 0.02, False), (OFF_MODE_FRACTION + 0.02, True)):
        vt = np.zeros((T, 2))
        vt[: int(frac * T), 0] = 3 * SLIP
        vt[:, 1] = 5 * SLIP  # the sliding contact: no creep
        m = engine_measures(_rec(vt), _expect(codes), TH, length_scale=LENGTH)
        assert ("creep" in _kinds(m)) is named, m["creep"]
        assert set(m["creep"]) == {"c1"}
        if named:
            art = m["artefacts"][0]
            # the median window-mean speed of the steps above the threshold (the window
            # blurs the block's ends)
            assert art["contact"] == "c1" and SLIP < art["value"] <= 3 * SLIP
            assert "predicted to stick" in art["text"]


def test_creep_below_the_slip_threshold_is_no_artefact():
    vt = np.full((T, 2), 0.9 * SLIP)
    m = engine_measures(_rec(vt), _expect((ROLL, ROLL)), TH, length_scale=LENGTH)
    assert m["artefacts"] == [] and m["creep"]["c1"]["fraction"] == 0.0


def test_a_frictionless_contact_has_no_stiction_to_creep_against():
    from planner.model.system import System

    system = System.from_contacts(points=[[0, 0], [1, 0]], normals=[[0, 1], [0, 1]],
                                  mu=[0.0, 0.5], external_wrench=(0, -1, 0),
                                  contact_velocities=[[0, 0], [0, 0]])
    exp = ModeSet((_Mode((ROLL, ROLL)),), system, 1.0, ("workpiece",), 0.02, LENGTH, 1.0)  # type: ignore[arg-type]
    m = engine_measures(_rec(np.full((T, 2), 3 * SLIP)), exp, TH, length_scale=LENGTH)
    assert set(m["creep"]) == {"c2"}


def test_lift_off_of_a_contact_predicted_closed():
    fn = np.ones((T, 2))
    fn[: int(0.2 * T), 1] = 0.0  # contact 2 carries no load for 0.2 s
    m = engine_measures(_rec(fn=fn), _expect((ROLL, ROLL)), TH, length_scale=LENGTH)
    assert _kinds(m) == ["lift_off"] and m["artefacts"][0]["contact"] == "c2"
    assert m["lift_off"]["c2"] == pytest.approx(0.15, abs=0.03)  # the window blurs 0.05 s
    # predicted to break: its lifting is the prediction, no artefact
    m = engine_measures(_rec(fn=fn), _expect((ROLL, BREAK)), TH, length_scale=LENGTH)
    assert "c2" not in m["lift_off"] and m["artefacts"] == []


@pytest.mark.parametrize("period, named", [(200, False), (40, True)])
def test_chatter_is_more_than_one_per_step_mode_change_per_classifier_window(period, named):
    # the slip flips sign every `period` steps: changes = T / period; limit = judged span /
    # window = 0.999 s / 0.1 s
    vt = np.zeros((T, 2))
    vt[:, 0] = 2 * SLIP * np.where((np.arange(T) // period) % 2, 1.0, -1.0)
    m = engine_measures(_rec(vt), _expect((SLIDE, ROLL)), TH, length_scale=LENGTH)
    assert m["chatter"]["c1"] == T // period - 1
    assert ("chatter" in _kinds(m)) is named
    assert m["thresholds"]["chatter_changes"] == pytest.approx(9.99)


def test_penetration_beyond_the_rest_allowance():
    limit = 2 * preload_depth(LENGTH) + SLIP * TH.window
    for d, named in ((0.9 * limit, False), (1.1 * limit, True)):
        m = engine_measures(_rec(depth=np.full((T, 2), d)), _expect((ROLL, ROLL)), TH,
                            length_scale=LENGTH)
        assert m["thresholds"]["depth_m"] == pytest.approx(limit)
        assert ("penetration" in _kinds(m)) is named


def test_capped_solves_of_an_engine_that_counts_them():
    m = engine_measures(_rec(), _expect((ROLL, ROLL)), TH, length_scale=LENGTH,
                        capped_solves=40, solves=1000)
    assert m["capped_fraction"] == 0.04 and m["artefacts"] == []
    m = engine_measures(_rec(), _expect((ROLL, ROLL)), TH, length_scale=LENGTH,
                        capped_solves=60, solves=1000)
    assert _kinds(m) == ["capped_solves"]
    m = engine_measures(_rec(), _expect((ROLL, ROLL)), TH, length_scale=LENGTH)
    assert m["capped_solves"] is None and m["capped_fraction"] is None


# ---- recorded traces of every engine --------------------------------------------------------
@pytest.mark.parametrize("name, kinds", [
    ("pymunk_ex41_3s", set()),
    ("dart_ex41_3s", set()),
    # MuJoCo's soft contacts flicker while the workpiece moves as predicted, and sink in
    ("mujoco_ex41_3s_flicker", {"chatter", "penetration"}),
    ("mujoco_ex41_3s_flicker_b", {"chatter", "penetration"}),
    # pymunk wedges Example 4.3 at mu = 3 (forces 30-110 x the load) and flickers
    ("pymunk_ex43_mu3_wedge", {"chatter", "penetration"}),
])
def test_artefacts_of_recorded_runs(name, kinds):
    t = load_trace(name)
    exp = t.expectation(t.prediction().all_modes)
    m = engine_measures(t.rec, exp, t.thresholds(), length_scale=t.meta["length_scale"])
    assert {a["kind"] for a in m["artefacts"]} == kinds, m["artefacts"]


def test_consensus_of_recorded_traces_names_the_flickering_engine():
    """The same 3S run of Example 4.1 in three engines, judged by the judge, measured by
    engine_measures; verdicts and causes from the recordings only."""
    runs = {"pymunk": "pymunk_ex41_3s", "mujoco": "mujoco_ex41_3s_flicker",
            "dart": "dart_ex41_3s"}
    verdicts, causes = {}, {}
    for engine, name in runs.items():
        t = load_trace(name)
        exp = t.expectation(t.prediction().all_modes)
        verdicts[engine] = judge(t.rec, exp, t.thresholds()).verdict.outcome.value
        m = engine_measures(t.rec, exp, t.thresholds(), length_scale=t.meta["length_scale"])
        causes[engine] = [a["text"] for a in m["artefacts"]]
    # every engine agrees here (the judge reads MuJoCo's flicker through its window); make
    # MuJoCo the odd one to check the consensus names its measured flicker
    verdicts["mujoco"] = "inconclusive"
    c = consensus_of(verdicts, causes)
    assert c.majority == "agreed" and c.odd == ("mujoco",) and c.explained
    assert "odd engine: MuJoCo" in c.text and "changed its per-step mode" in c.text
    assert "an engine artefact" in c.text


# ---- recorded summaries of one system in three engines ---------------------------------------
def _summaries() -> list[dict]:
    return json.loads((DATA / "consensus_stacked_mujoco_creeps.json").read_text())["runs"]


def test_recorded_summaries_are_valid_run_summaries():
    import jsonschema

    schema = load_schema("run-summary")["properties"]["observed"]["properties"][
        "engine_measures"]
    for s in _summaries():
        jsonschema.validate(s["observed"]["engine_measures"], schema)


def test_consensus_of_recorded_summaries_names_the_creeping_engine():
    """Three blocks stacked on their corners (tests/data/stacked_corners_mujoco_creeps.json),
    predicted B1 R2 R3 R4 R5 R6 S-7: pymunk and DART hold it; in MuJoCo the light top block
    loses contact and slips on the middle one (docs/simulation-measurements.md, "MuJoCo:
    stacked blocks")."""
    c = consensus(_summaries())
    assert c.verdicts == {"pymunk": "agreed", "mujoco": "disagreed", "dart": "agreed"}
    assert c.majority == "agreed" and c.odd == ("mujoco",) and c.explained
    assert any("predicted to stick, slipped" in t for t in c.causes["mujoco"])
    assert "odd engine: MuJoCo" in c.text and "an engine artefact" in c.text
    d = c.to_dict()
    assert d["odd"] == ["mujoco"] and d["explained"] is True


def test_odd_engine_without_a_measured_artefact_is_unexplained():
    c = consensus_of({"pymunk": "agreed", "mujoco": "disagreed", "dart": "disagreed"},
                     {"pymunk": [], "mujoco": ["x"], "dart": []})
    assert c.majority == "disagreed" and c.odd == ("pymunk",) and not c.explained
    assert "unexplained (a model error is not excluded)" in c.text
    assert "The majority's runs measured artefacts too (MuJoCo: x)" in c.text


def test_two_engines_that_differ_have_no_majority():
    c = consensus_of({"pymunk": "agreed", "dart": "disagreed"}, {"dart": ["y"]})
    assert c.majority is None and c.odd == () and not c.unanimous
    assert "no majority" in c.text and "DART measured: y" in c.text


def test_unanimous_and_fault_causes():
    assert consensus_of({"pymunk": "agreed", "dart": "agreed"}).text == "all engines agreed"
    s = [{"engine": "pymunk", "status": "agreed", "observed": {"fault": None}},
         {"engine": "mujoco", "status": "agreed", "observed": {"fault": None}},
         {"engine": "dart", "status": "fault", "reason": "nan at t=1",
          "observed": {"fault": "nan at t=1"}}]
    c = consensus(s)
    assert c.odd == ("dart",) and c.causes["dart"] == ("fault: nan at t=1",)


def test_segment_consensus_matches_segments_by_number():
    s = [{"engine": e, "status": "agreed", "observed": {},
          "segments": [{"segment": 1, "status": "agreed"},
                       {"segment": 2, "status": st}]}
         for e, st in (("pymunk", "agreed"), ("mujoco", "agreed"), ("dart", "disagreed"))]
    c1, c2 = segment_consensus(s)
    assert c1.unanimous and c2.odd == ("dart",) and not c2.explained


@pytest.mark.long
@pytest.mark.slow
def test_the_recorded_summaries_are_what_the_three_engines_do_now():
    """The recorded file's runs again, through the pipeline (``qsplan simulate``'s): whether the
    recorded summaries the tests above read are still what the engines do (by hand, with the
    recordings: three engines' runs of a stacked system)."""
    pytest.importorskip("dartpy")
    from planner.files.system_file import load_system
    from scenarios.runs import simulate_system

    system = load_system(DATA / "stacked_corners_mujoco_creeps.json")
    runs = [simulate_system(system, e).summary.to_dict() for e in ("pymunk", "mujoco", "dart")]
    c = consensus(runs)
    assert c.majority == "agreed" and c.odd == ("mujoco",) and c.explained
    assert any("predicted to stick, slipped" in t for t in c.causes["mujoco"])


def test_a_contact_a_force_indeterminate_mode_may_unload_is_no_lift_off():
    """A body resting on three table contacts at x = 0, 0.5, 1 with its weight at x = 0.25:
    ``R1 R2 R3`` is force-indeterminate -- a certificate with no load at contact 2 (or 3)
    exists, none with no load at contact 1."""
    from planner.model.system import System
    from planner.predict.feasibility import feasible_modes

    system = System.from_contacts(points=[[0, 0], [0.5, 0], [1, 0]],
                                  normals=[[0, 1], [0, 1], [0, 1]], mu=[0.5, 0.5, 0.5],
                                  external_wrench=(0, -1, -0.25),
                                  contact_velocities=[[0, 0], [0, 0], [0, 0]])
    modes = feasible_modes(system).all_modes
    assert [m.label for m in modes] == ["R1 R2 R3"]
    exp = ModeSet(tuple(modes), system, 1.0, ("workpiece",), 0.0, 1.0, 1.0, static=True)
    for k, named in ((1, True), (2, False), (3, False)):
        fn = np.ones((T, 3))
        fn[:, k - 1] = 0.0
        m = engine_measures(_rec(fn=fn, P=3), exp, TH, length_scale=LENGTH)
        assert ("lift_off" in _kinds(m)) is named, (k, m["lift_off"])
        assert set(m["lift_off"]) == {"c1"}
