"""The planner's diagnoses in plain words: contacts named by their features, the workpiece's
motion by its direction, no empty fields (docs/planning.md, "Reading a plan")."""

from __future__ import annotations

import numpy as np
import pytest

from planner.files.hand_file import load_hand_file
from planner.model.hand import ContactSpec
from planner.plan.wording import (
    clearance_words,
    contact_label,
    contact_words,
    drive_words,
    effort_unit,
    meets_words,
    mode_change_words,
    motion_words,
    runs_off_words,
)
from qsplan.commands.plan import diagnosis_lines
from scenarios.registry import DATA_DIR


@pytest.fixture(scope="module")
def two_finger():
    return load_hand_file(DATA_DIR / "two_finger_hand.json")


@pytest.fixture(scope="module")
def two_link():
    return load_hand_file(DATA_DIR / "two_link_finger_hand.json")


def test_contacts_are_named_by_their_features(two_finger, two_link):
    hand = two_finger.hand
    assert [contact_words(hand, c) for c in hand.contacts] == [
        "vertex 0 on the palm", "vertex 1 on the palm", "vertex 3 on the left finger",
        "the right finger's tip on edge 1"]
    assert contact_label(hand, 2) == "contact 3 (vertex 3 on the left finger)"
    assert meets_words(hand, ContactSpec("side", vertex=4, finger=0, side=-1)) == (
        "vertex 4 meets the left finger")
    assert meets_words(hand, ContactSpec("tip", edge=3, finger=0)) == (
        "the left finger's tip meets edge 3")
    chain = two_link.hand
    assert contact_words(chain, ContactSpec("side", vertex=2, finger=1, side=1, link=1)) == (
        "vertex 2 on link 1 of the right finger")
    table = load_hand_file(DATA_DIR / "table_push_hand.json").hand
    assert contact_words(table, table.contacts[0]).endswith(f"on the {table.environment[0][0]}")


def test_a_contact_running_off_its_feature_says_where(two_finger):
    hand = two_finger.hand
    assert runs_off_words(hand, 2, 1.003) == "vertex 3 runs off the left finger at its tip end"
    assert runs_off_words(hand, 2, -0.01) == "vertex 3 runs off the left finger at its base end"
    assert runs_off_words(hand, 0, 1.2) == "vertex 0 runs off the end of the palm"
    assert runs_off_words(hand, 3, 1.01) == "the right finger's tip runs off edge 1 past vertex 2"
    assert runs_off_words(hand, 3, -0.01) == "the right finger's tip runs off edge 1 past vertex 1"


def test_new_contacts_named_by_the_hand_model_read_in_words(two_finger, two_link):
    hand, q = two_finger.hand, two_finger.q0
    assert clearance_words(hand, "vertex 4 - left", q) == "vertex 4 meets the left finger"
    assert clearance_words(hand, "vertex 2 - palm", q) == "vertex 2 meets the palm"
    tip = clearance_words(hand, "left tip - workpiece", q)
    assert tip.startswith("the left finger's tip meets ") and ("edge" in tip or "vertex" in tip)
    chain = two_link.hand
    assert clearance_words(chain, "vertex 2 - right link 1", two_link.q0) == (
        "vertex 2 meets link 1 of the right finger")


@pytest.mark.parametrize("end, words", [
    ((-0.0152, 0.0, 0.0), "moves 15.2 mm left, without turning"),
    ((0.01, 0.01, -0.3346), "moves 14.1 mm up and to the right, turning 19.2 deg clockwise"),
    ((0.0, -2.0, 0.1), "moves 2 m down, turning 5.73 deg counter-clockwise"),
    ((1e-9, 0.0, 0.0), "stays in place"),
    ((0.0, 0.0, 0.2), "turns 11.5 deg counter-clockwise about its frame origin"),
])
def test_which_way_the_workpiece_moves(end, words):
    assert motion_words(np.zeros(3), np.array(end), 0.05) == words


def test_drives_and_units(two_finger, two_link):
    assert drive_words(two_finger.hand, 1, 0.02) == (
        "the right finger turning counter-clockwise at 0.02 rad/s")
    assert drive_words(two_finger.hand, 0, -0.02) == (
        "the left finger turning clockwise at 0.02 rad/s")
    assert drive_words(two_link.hand, 2, 0.01) == (
        "joint 1 of the right finger turning counter-clockwise at 0.01 rad/s")
    prism = load_hand_file(DATA_DIR / "prismatic_finger_hand.json").hand
    assert drive_words(prism, 1, 0.002) == "the slider finger extending at 0.002 m/s"
    assert effort_unit(prism, (1,)) == "N" and effort_unit(prism, (0,)) == "N m"
    assert effort_unit(prism, (0, 1)) == "" and effort_unit(prism, ()) == ""


def test_a_mode_change_names_the_contact_that_changes(two_finger):
    hand = two_finger.hand
    claim = "S+1 S+2 S-3 S-4"
    text = mode_change_words(hand, claim, [claim, "S+1 S+2 R3 S-4", "R1 B2 R3 S-4"])
    assert text == ("contact 3 (vertex 3 on the left finger) stops sliding (next admissible "
                    "mode: S+1 S+2 R3 S-4)")
    assert "lifts off" in mode_change_words(hand, claim, ["S+1 B2 S-3 S-4"])
    assert "reverses its sliding direction" in mode_change_words(hand, claim,
                                                                  ["S-1 S+2 S-3 S-4"])
    assert mode_change_words(hand, claim, [claim]) == (
        "no other mode of these contacts is kinematically admissible there")


@pytest.mark.long
def test_the_three_finger_segment_end_names_its_contacts_not_a_failed_step():
    from planner.plan.trajectory import integrate_segment

    hf = load_hand_file(DATA_DIR / "three_finger_hand.json")
    s = hf.segment
    tr = integrate_segment(hf.hand, hf.q0, drive=s.drives, speed=s.speeds, mode=s.mode,
                           max_time=s.max_time, steps=s.steps)
    assert tr.event.kind == "mode change"
    assert "step failed" not in tr.event.detail
    assert tr.event.detail.startswith("past this point the constraints of the contacts vertex 0 "
                                      "on the palm, vertex 1 on the palm, vertex 3 on the left "
                                      "finger, the right finger's tip on edge 1, the top "
                                      "finger's tip on edge 2 become singular")


@pytest.mark.parametrize("diag", [
    {"distance_to_goal": 0.5, "notes": [], "after_segments": 0, "failed": None},
    {"distance_to_goal": 0.5, "notes": ["max_expansions 2 spent"], "after_segments": 1,
     "failed": {"what": "", "why": "", "t": None, "rival": None, "mu": None,
                "widest_mu": None}},
    {"notes": ["the search is exhausted"], "failed": {"what": "drive x", "why": None}},
    {},
])
def test_a_diagnosis_never_prints_empty_fields(diag):
    lines = diagnosis_lines(diag)
    text = "\n".join(lines)
    assert lines[0].startswith("stops short of the goal after")
    assert ": :" not in text and "()" not in text and not any(
        line.rstrip().endswith(":") for line in lines)
    assert "None" not in text
