"""Problems written by their geometry (docs/file-formats.md, "Geometry first"): the answers
derived by hand, the checks of points and normals against the body, the weight-moment
warning, friction groups, and that every file with normals and wrench written out keeps its
answers."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from planner import System, feasible_modes
from planner.errors import GeometryWarning, InputError
from planner.files.system_file import load_system, system_from_dict
from planner.model.layout import FeatureContact, finger, surface
from planner.model.workpiece import WorkpieceGeometry
from planner.predict.feasibility import Status

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "scenarios" / "data"


def qsplan(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "qsplan.cli", *args], capture_output=True,
                          text=True, cwd=cwd)


def box(width: float, height: float, push_at: float, mu_table: float, *, mass: float = 0.1,
        speed: float = 0.001) -> System:
    """A box on a table pushed on its left face at ``push_at`` by a frictionless finger."""
    return System.from_geometry(
        WorkpieceGeometry([[0, 0], [width, 0], [width, height], [0, height]], mass),
        [FeatureContact("table", vertex=0, surface="table"),
         FeatureContact("table", vertex=1, surface="table"),
         FeatureContact(0.0, point=[0.0, push_at], finger="pusher")],
        surfaces=[surface("table", [[-1, 0], [1, 0]]), finger("pusher", velocity=(speed, 0))],
        gravity=(0, -9.81), friction={"table": mu_table})


def test_box_pushed_low_slides_and_high_tips():
    """A frictionless finger pushing at height y needs F = mu W to slide the box; the push
    tips it about its front corner first when F y > W w / 2, i.e. mu y > w / 2. With w = 0.08:
    y = 0.06, mu = 0.3 (0.018 < 0.04) slides, S-1 S-2 R3; y = 0.1, mu = 0.9 (0.09 > 0.04) tips,
    the finger sliding up the face, B1 R2 S+3.  The files carry no wrench, normal or contact
    velocity."""
    low, high = load_system(DATA / "geometry_box_low.json"), load_system(
        DATA / "geometry_box_high.json")
    assert feasible_modes(low).labels == ["S-1 S-2 R3"]
    assert feasible_modes(high).labels == ["B1 R2 S+3"]
    for path in ("geometry_box_low.json", "geometry_box_high.json"):
        text = (DATA / path).read_text()
        assert "external_wrench" not in text and "normal" not in text
        assert "contact_velocities" not in text
    # the same box with normals and wrench written out (shipped) gives the same answer, bit for bit
    old = load_system(DATA / "box_on_table_low.json")
    a, b = feasible_modes(low).all_modes[0], feasible_modes(old).all_modes[0]
    assert np.array_equal(a.qdot, b.qdot) and np.allclose(low.g_obj, old.g_obj, atol=1e-12)


@pytest.mark.parametrize("mu,height,expected", [
    (0.6, 0.06, "S-1 S-2 R3"),   # 0.036 < 0.04
    (0.7, 0.06, "B1 R2 S+3"),    # 0.042 > 0.04
    (0.3, 0.14, "S-1 S-2 R3"),   # 0.042 > 0.04 but above the box: refused below
    (0.5, 0.09, "B1 R2 S+3"),    # 0.045 > 0.04
    (0.5, 0.07, "S-1 S-2 R3"),   # 0.035 < 0.04
])
def test_box_tipping_boundary_is_mu_y_equal_w_over_2(mu, height, expected):
    """The boundary mu y = w / 2 (w = 0.08 m, h = 0.12 m) at other frictions and heights,
    mirrored boxes included (a finger on the right face moving left)."""
    if height > 0.12:
        with pytest.raises(InputError, match="expected a point on the boundary"):
            box(0.08, 0.12, height, mu)
        return
    assert feasible_modes(box(0.08, 0.12, height, mu)).labels == [expected]
    mirrored = System.from_geometry(
        WorkpieceGeometry([[0, 0], [0.08, 0], [0.08, 0.12], [0, 0.12]], 0.1),
        [FeatureContact(mu, vertex=1, surface="table"), FeatureContact(mu, vertex=0,
                                                                        surface="table"),
         FeatureContact(0.0, point=[0.08, height], finger="pusher")],
        surfaces=[surface("table", [[-1, 0], [1, 0]]), finger("pusher", velocity=(-0.001, 0))],
        gravity=(0, -9.81))
    want = expected.replace("S-1 S-2", "S+1 S+2").replace("S+3", "S-3")
    assert feasible_modes(mirrored).labels == [want]


def test_ladder_stands_or_slips():
    """Ladder from (0.3, 0) to (0, 0.4) against a frictionless wall, weight W at its middle.
    Moments about the foot: W a/2 = H b, so the floor must hold H = 0.375 W with N = W: it
    stands (at rest, R1 R2) for mu_floor >= 0.375 and slips below.  Slipping, nothing drives it:
    the status is "moving" (not at rest) and the load left unbalanced pushes the foot away from
    the wall (+x) and turns the ladder counter-clockwise (it falls)."""
    ladder = load_system(DATA / "geometry_ladder.json")
    assert "normal" not in (DATA / "geometry_ladder.json").read_text()
    for mu, status in ((0.5, Status.AT_REST), (0.38, Status.AT_REST), (0.37, Status.MOVING),
                       (0.3, Status.MOVING)):
        pred = feasible_modes(ladder, [mu, 0.0])
        assert pred.status is status, (mu, pred.reason)
    stands = feasible_modes(ladder, [0.5, 0.0])
    assert stands.labels == ["R1 R2"]
    c = stands.modes[0].contact_forces if stands.modes else stands.all_modes[0].contact_forces
    assert c[1, 0] == pytest.approx(0.375 * 9.81, rel=1e-6)  # wall reaction H
    slips = feasible_modes(ladder, [0.3, 0.0])
    r = slips.unbalanced
    assert r is not None and r[0] > 0 and r[1] < 0
    assert "counter-clockwise" in slips.reason and "down and right" in slips.reason
    res = qsplan("modes", str(DATA / "geometry_ladder.json"), "--mu", "floor=0.3")
    assert res.returncode == 0 and "status: moving" in res.stdout


def test_stacked_blocks_written_by_geometry():
    """Block 1 (1 N) on block 0 (2 N) on a table: pushing block 1, its interface slides first
    when mu_34 * 1 N < mu_12 * 3 N; at 0.3 vs 0.5 it does (R1 R2 S-3 S-4 R5); with an
    interface of 1.6 (1.6 N > 1.5 N) both slide together (S-1 S-2 R3 R4 R5)."""
    stacked = load_system(DATA / "geometry_stacked_blocks.json")
    assert stacked.n_bodies == 2 and np.allclose(stacked.g_obj, [0, -2, 0, 0, -1, 0])
    assert feasible_modes(stacked).labels == ["R1 R2 S-3 S-4 R5"]
    from planner.model.layout import group_mu

    mu = group_mu(stacked.mu, stacked.friction_groups, {"interface": 1.6})
    assert feasible_modes(stacked, mu).labels == ["S-1 S-2 R3 R4 R5"]


def test_box_pivoted_by_a_finger_on_its_top_face():
    """The finger on the top face's midpoint (0.05, 0.1) follows the circle of a tip about the
    front corner (0.1, 0).  Pivoting (B1 R2 R3), moments about the pivot: W 0.05 + N 0.05 =
    F 0.1, so F = W/2 + N/2 <= mu_f N needs mu_f > 1/2 (then N >= W / (2 mu_f - 1)).  The
    finger also rises, so the box may as well stay while the finger lifts off (R1 R2 B3):
    ambiguous at mu_f = 0.8, only R1 R2 B3 at mu_f = 0.3."""
    pivot = load_system(DATA / "geometry_box_pivot.json")
    v = pivot.joint_inputs.reshape(-1, 2)[2]
    # u = -0.01 rot90((-0.05, 0.1)) = (0.001, 0.0005); n = (0, -1), t = rot90(n) = (1, 0)
    assert np.allclose(v, [-0.0005, 0.001])
    assert sorted(feasible_modes(pivot).labels) == ["B1 R2 R3", "R1 R2 B3"]
    assert feasible_modes(pivot, [0.6, 0.6, 0.3]).labels == ["R1 R2 B3"]


def write(tmp_path: Path, name: str, data: dict) -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


OLD_BOX = {
    "workpiece": {"polygon": [[0, 0], [0.2, 0], [0.2, 0.1], [0, 0.1]], "mass": 0.102},
    "contacts": [{"point": [0, 0], "normal": [0, 1], "mu": 0.3, "environment": True},
                 {"point": [0.2, 0], "normal": [0, 1], "mu": 0.3, "environment": True},
                 {"point": [0, 0.03], "normal": [1, 0], "mu": 0.5}],
    "external_wrench": [0, -1, -0.1],
    "manipulator": {"contact_velocities": [[0, 0], [0, 0], [0.001, 0]]},
}


@pytest.mark.long
def test_normal_out_of_the_body_and_point_off_the_boundary_are_exit_2(tmp_path):
    bad = json.loads(json.dumps(OLD_BOX))
    bad["contacts"][2]["normal"] = [-1, 0]
    res = qsplan("modes", str(write(tmp_path, "out.json", bad)))
    assert res.returncode == 2
    assert ("contact 3: expected a normal pointing into the workpiece, got [-1, 0], which "
            "points out of it: 180 deg from the nearest inward normal [1, 0] at edge 3") \
        in res.stderr
    off = json.loads(json.dumps(OLD_BOX))
    off["contacts"][2]["point"] = [0.05, 0.03]
    res = qsplan("modes", str(write(tmp_path, "off.json", off)))
    assert res.returncode == 2
    assert ("contact 3: expected a point on the boundary of the workpiece, got [0.05, 0.03], "
            "0.03 m off it") in res.stderr
    # a table normal tilted by 10 degrees at an edge point: not into the body
    tilt = json.loads(json.dumps(OLD_BOX))
    tilt["contacts"][2]["normal"] = [math.cos(0.1745), math.sin(0.1745)]
    res = qsplan("modes", str(write(tmp_path, "tilt.json", tilt)))
    assert res.returncode == 2 and "which points not into it: 10 deg" in res.stderr


def test_weight_without_its_moment_warns(tmp_path):
    """A box whose centre of mass is (0.05, 0.1) with external_wrench [0, -1, 0]: the weight's
    moment about the origin is -0.05 N m, forgotten; the warning says so and how to fix it."""
    wrong = json.loads(json.dumps(OLD_BOX))
    wrong["workpiece"]["com"] = [0.05, 0.1]
    wrong["external_wrench"] = [0, -1, 0]
    res = qsplan("modes", str(write(tmp_path, "w.json", wrong)))
    assert res.returncode == 0
    assert ("qsplan modes: warning: workpiece: external_wrench [0, -1, 0] looks like the weight "
            "of the workpiece") in res.stderr
    assert "the weight's moment -0.05 N m" in res.stderr and '"gravity": [0, -9.81]' in res.stderr
    with pytest.warns(GeometryWarning, match="looks like the weight"):
        system_from_dict(wrong)
    with warnings.catch_warnings():  # the right moment: silent
        warnings.simplefilter("error", GeometryWarning)
        system_from_dict(OLD_BOX)
    twice = {"gravity": [0, -9.81], **{k: v for k, v in OLD_BOX.items()}}
    with pytest.warns(GeometryWarning, match="the weight counts twice"):
        system_from_dict(twice)


@pytest.mark.parametrize("change,message", [
    ({"contacts": [{"vertex": 9, "surface": "t", "mu": 0.3}]}, "vertex: expected an index in 0..3"),
    ({"contacts": [{"edge": 0, "at": 1.5, "mu": 0.3}]}, "at: expected a fraction in [0, 1]"),
    ({"contacts": [{"vertex": 2, "mu": 0.3}]}, "the normal does not follow from the geometry"),
    ({"contacts": [{"vertex": 0, "surface": "t", "mu": "rubber"}]},
     "mu: expected a number or one of the friction groups ['t']"),
    ({"contacts": [{"vertex": 2, "surface": "t", "mu": 0.3}]},
     "expected the contact point [0.1, 0.1] on surface 't'"),
    ({"contacts": [{"vertex": 0, "surface": "wall", "mu": 0.3}]},
     "surface: expected one of ['t'], got 'wall'"),
    ({"friction": {"t": 0.3, "unused": 0.1}},
     "friction: expected every group used by a contact, got ['unused']"),
])
def test_geometry_errors_name_the_contact_and_the_fix(change, message):
    base = {"gravity": [0, -9.81],
            "workpiece": {"polygon": [[0, 0], [0.1, 0], [0.1, 0.1], [0, 0.1]], "mass": 0.1},
            "friction": {"t": 0.3}, "surfaces": [{"name": "t", "edge": [[-1, 0], [1, 0]]}],
            "contacts": [{"vertex": 0, "surface": "t", "mu": "t"},
                         {"vertex": 1, "surface": "t", "mu": "t"}]}
    data = {**base, **change}
    with pytest.raises(InputError, match=None) as err:
        system_from_dict(data)
    assert message in str(err.value)


def test_world_motion_is_converted_to_contact_frame_velocities():
    """A finger rotating at omega about a pivot: u = v + omega rot90(p - pivot), and
    (v_n, v_t) = (n . u, t . u) with t = rot90(n) (docs/conventions.md)."""
    s = System.from_geometry(
        WorkpieceGeometry([[0, 0], [1, 0], [1, 1], [0, 1]], 1.0),
        [FeatureContact(0.2, edge=3, at=0.25, finger="f"),
         FeatureContact(0.2, vertex=0, surface="floor"),
         FeatureContact(0.2, vertex=1, surface="floor")],
        surfaces=[finger("f", velocity=(0.3, 0.1), omega=2.0, pivot=(-1.0, 0.5)),
                  surface("floor", [[0, 0], [2, 0]])])
    p = np.array([0.0, 0.75])  # edge 3 runs from (0, 1) to (0, 0)
    u = np.array([0.3, 0.1]) + 2.0 * np.array([-(p[1] - 0.5), p[0] + 1.0])
    n, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    assert np.allclose(s.points[0], p) and np.allclose(s.normals[0], n)
    assert np.allclose(s.joint_inputs[:2], [n @ u, t @ u])
    assert s.environment == (False, True, True)


def test_existing_files_keep_their_answers():
    """Every shipped system file with normals and wrench written out: the same wrench matrix,
    load, commands and answers as recorded in tests/data/golden_answers.json by a reader
    without geometry-first input (``part_tool_wall.json``'s part weight carries its moment
    about the origin, ``-0.5`` N m for its centre of mass at ``(0.5, 0.5)``)."""
    golden = json.loads((ROOT / "tests" / "data" / "golden_answers.json").read_text())
    assert len(golden) >= 8
    for name, want in golden.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", GeometryWarning)
            s = load_system(DATA / name)
        assert s.W.tolist() == want["W"] and s.g_obj.tolist() == want["g_obj"], name
        assert s.joint_inputs.tolist() == want["inputs"], name
        p = feasible_modes(s)
        assert p.labels == want["labels"], name
        expected_status = want["status"]
        if expected_status == "at_rest" and not p.labels:
            expected_status = "moving"
        assert p.status.value == expected_status, name
        for m, q, f in zip(p.all_modes, want["qdot"], want["forces"]):
            assert m.qdot.tolist() == q, name
            if f is not None:
                assert m.contact_forces.tolist() == f, name


def test_simulate_prints_the_weight_warning_as_one_line(tmp_path):
    """``qsplan simulate`` reports the forgotten moment as ``modes`` does: one clean line on
    stderr, not a Python warnings line with a file name and a source line."""
    wrong = json.loads(json.dumps(OLD_BOX))
    wrong["workpiece"]["com"] = [0.05, 0.1]
    wrong["external_wrench"] = [0, -1, 0]
    res = qsplan("simulate", str(write(tmp_path, "w.json", wrong)), "--duration", "0.4",
                 "--no-render")
    assert res.returncode in (0, 1), res.stderr
    lines = [ln for ln in res.stderr.splitlines() if "looks like the weight" in ln]
    assert len(lines) == 1 and lines[0].startswith(
        "qsplan simulate: warning: workpiece: external_wrench [0, -1, 0] looks like the weight")
    assert "GeometryWarning" not in res.stderr and "warnings.warn" not in res.stderr
