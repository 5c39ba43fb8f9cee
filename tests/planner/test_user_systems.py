"""The validation campaign's system files of the kinds a user writes
(:mod:`planner.sweeps.user_systems`): every draw is a valid, loadable geometry-first file whose
prediction is what its hand derivation claims; a mirrored file predicts the mirrored modes; the
closed forms behind the claims against the planner on files written out by hand. No simulation.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from planner.errors import InputError
from planner.files.system_file import load_system, system_from_dict
from planner.predict.feasibility import feasible_modes
from planner.sweeps.user_files import mirror_label, mirror_system
from planner.sweeps.user_systems import (
    KINDS,
    draw_user_system,
    ladder_stands,
    slide_height,
)
from scenarios.registry import DATA_DIR

DRAWS = 16


def labels(system) -> set[str]:
    return set(feasible_modes(system).labels)


def load(data: dict) -> object:
    """As ``qsplan simulate FILE`` reads it: JSON text through the system-file loader."""
    return system_from_dict(json.loads(json.dumps(data)), "drawn file")


@pytest.mark.parametrize("kind", KINDS)
def test_drawn_files_load_and_predict_what_they_claim(kind: str) -> None:
    jsonschema = pytest.importorskip("jsonschema")
    from planner.files.schema import load_schema

    validator = jsonschema.Draft202012Validator(load_schema("system"))
    claimed = 0
    for i in range(DRAWS):
        d = draw_user_system(kind, np.random.default_rng([123, i]))
        assert d.kind == kind
        assert not list(validator.iter_errors(d.data)), (i, d.params)
        system = load(d.data)
        got = labels(system)
        c = d.claim
        for lab in c.contains:
            assert lab in got, (i, c.why, sorted(got), d.params)
        for lab in c.excludes:
            assert lab not in got, (i, c.why, sorted(got), d.params)
        if c.empty is not None:
            assert c.empty == (not got), (i, c.why, sorted(got), d.params)
        claimed += bool(c.contains or c.excludes or c.empty is not None)
        assert set(d.groups) == {name for name, _ in system.friction_groups}
    assert claimed >= 2, f"{kind}: only {claimed} of {DRAWS} draws carry a claim"


@pytest.mark.parametrize("kind", KINDS)
def test_the_mirror_image_predicts_the_mirrored_modes(kind: str) -> None:
    for i in range(6):
        d = draw_user_system(kind, np.random.default_rng([321, i]))
        original, mirrored = load(d.data), load(mirror_system(d.data))
        assert labels(mirrored) == {mirror_label(lab) for lab in labels(original)}
        pts, mpts = np.asarray(original.points), np.asarray(mirrored.points)
        assert np.allclose(mpts, pts * [-1.0, 1.0])
        assert np.allclose(np.asarray(mirrored.g_obj).reshape(-1, 3),
                           np.asarray(original.g_obj).reshape(-1, 3) * [-1.0, 1.0, -1.0])


def test_mirror_label_swaps_only_the_sliding_signs() -> None:
    assert mirror_label("S+1 S-2 R3 B4") == "S-1 S+2 R3 B4"
    assert mirror_label(mirror_label("S-1 S-2 R3")) == "S-1 S-2 R3"


def box_file(height: float, mu_table: float, mu_finger: float, supports: int = 2) -> dict:
    """A 0.08 m x 0.12 m box of 0.1 kg on ``supports`` table contacts, pushed horizontally on
    its left face at ``height``."""
    inner = [{"edge": 0, "at": a, "surface": "table", "mu": "table"}
             for a in np.linspace(0, 1, supports)[1:-1]]
    return {"gravity": [0.0, -9.81],
            "workpiece": {"polygon": [[0, 0], [0.08, 0], [0.08, 0.12], [0, 0.12]], "mass": 0.1},
            "friction": {"table": mu_table},
            "surfaces": [{"name": "table", "edge": [[-1, 0], [1, 0]]}],
            "fingers": [{"name": "pusher", "velocity": [0.001, 0.0]}],
            "contacts": [{"vertex": 0, "surface": "table", "mu": "table"}, *inner,
                         {"vertex": 1, "surface": "table", "mu": "table"},
                         {"point": [0.0, height], "finger": "pusher", "mu": mu_finger}]}


@pytest.mark.parametrize("mu_finger", [0.0, 0.4])
@pytest.mark.parametrize("supports", [2, 7])
def test_slide_height_is_where_sliding_gives_way(mu_finger: float, supports: int) -> None:
    # h* = w (1 + mu_f mu_t) / (2 mu_t): 0.08 m frictionless, 0.096 m with mu_f = 0.4
    h_star = slide_height(0.08, 0.5, mu_finger)
    assert h_star == pytest.approx(0.08 * (1 + 0.5 * mu_finger) / 1.0)
    slide = " ".join([f"S-{i + 1}" for i in range(supports)] + [f"R{supports + 1}"])
    assert slide in labels(load(box_file(0.95 * h_star, 0.5, mu_finger, supports)))
    assert slide not in labels(load(box_file(1.05 * h_star, 0.5, mu_finger, supports)))
    assert slide_height(0.08, 0.5, 2.0) == float("inf")  # the finger can hold it down


@pytest.mark.parametrize(("mu_wall", "threshold"), [(0.0, 0.375), (0.5, 1 / (8 / 3 + 0.5))])
def test_ladder_stands_from_the_closed_form(mu_wall: float, threshold: float) -> None:
    # the shipped ladder: foot (0.3, 0), top (0, 0.4), tan beta = 4/3
    data = json.loads((DATA_DIR / "geometry_ladder.json").read_text())
    beta = np.arctan2(0.4, 0.3)
    assert ladder_stands(beta, threshold, mu_wall) == pytest.approx(1.0)
    for mu_floor, stands in ((threshold + 0.02, True), (threshold - 0.02, False)):
        data["friction"] = {"floor": mu_floor, "wall": mu_wall}
        assert (ladder_stands(beta, mu_floor, mu_wall) >= 1.0) is stands
        assert bool(labels(load(data))) is stands
    assert load_system(DATA_DIR / "geometry_ladder.json").n_contacts == 2


def test_an_unknown_kind_is_refused_by_name() -> None:
    with pytest.raises(InputError, match="kind: expected one of acute, supports, stacked, "
                                         "static, got 'cube'"):
        draw_user_system("cube", np.random.default_rng(0))


def test_mirror_system_keeps_features_on_the_same_material_points() -> None:
    d = draw_user_system("acute", np.random.default_rng([5, 0]))
    m = mirror_system(d.data)
    poly, mpoly = d.data["workpiece"]["polygon"], m["workpiece"]["polygon"]
    assert mpoly == [[-x, y] for x, y in reversed(poly)]  # counter-clockwise again
    assert m["contacts"][2]["at"] == pytest.approx(1.0 - d.data["contacts"][2]["at"])
    twice = load(mirror_system(m))
    assert np.allclose(np.asarray(twice.points), np.asarray(load(d.data).points))
