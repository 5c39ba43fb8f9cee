"""The judge on soft contacts, on constructed recordings of the two tall boxes of
tests/sim/test_mujoco_support_limits.py (docs/simulation.md, "Judging a run"): the recordings
follow the planner's certificate exactly except for the one soft-engine effect under test, so
each verdict turns on that effect alone. No simulator runs here.

* A support the predicted mode opens, sunk in a soft table: it may read loaded until the
  predicted motion has lifted it out of the depth the engine measured there (the clearing
  time, :func:`sim.judge_soft.clearing_times`), and not longer; a measured depth of zero excuses
  nothing.
* A box rocking in a stick-slip cycle shorter than the compared stretch: the twist over the
  stretch in which the certificate's configuration holds (:func:`sim.judge.twist_stretch`)
  averages the cycle out; a box that really turns is still a twist miss.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from planner.files.system_file import load_system
from planner.model.system import System
from planner.predict.feasibility import feasible_modes
from planner.predict.stages import FeasibleMode
from sim.classify import Thresholds, twist_error
from sim.expectation import ModeSet
from sim.judge import judge_modes, twist_stretch
from sim.judge_soft import clearing_times
from sim.run import Recording
from sim.scenes.system import commanded_contact_speed, system_size
from sim.verdict import FORCE_DRIFT_LIMIT, TWIST_TOLERANCE, Outcome

DATA = Path(__file__).parents[1] / "data"
TIPS = load_system(DATA / "tall_box_on_3_supports_tips.json")
SLIDES = load_system(DATA / "tall_box_on_8_supports_slides.json")
SETTLE, DURATION, DT = 1.0, 2.5, 1e-3


def _setup(system: System) -> tuple[FeasibleMode, ModeSet, Thresholds]:
    """The system's one predicted mode, its expectation at the file's speed, and thresholds
    for a run of :data:`DURATION` judged after :data:`SETTLE` whose drive moves the box
    0.005 sizes per second (MuJoCo's system rate: the stretch is the whole second after it)."""
    (mode,) = feasible_modes(system).all_modes
    size = system_size(system)
    drive = 0.005 * size
    factor = drive / commanded_contact_speed(system)
    load = float(np.linalg.norm(system.g_obj[:2]))
    exp = ModeSet((mode,), system, factor, ("workpiece",), drive, size, load, load=load)
    th = Thresholds.for_drive(drive, load, creep_floor=1e-8, settle=SETTLE, length_scale=size)
    return mode, exp, th


def _recording(mode: FeasibleMode, factor: float, rotation: np.ndarray | None = None
               ) -> Recording:
    """A run that shows ``mode`` on every step: poses along its twist (``rotation`` (T,)
    replaces the angle), contacts it keeps closed loaded with its certificate forces and
    sliding at its contact velocities, sunk 10 um, touching at the model's contact points
    (carried with the box); contacts it opens absent."""
    t = np.arange(0.0, DURATION + DT / 2, DT)
    T, P = len(t), len(mode.mode.codes)
    q = np.asarray(mode.qdot, dtype=float) * factor
    poses = (t[:, None] * q[None, :])[:, None, :].copy()
    if rotation is not None:
        poses[:, 0, 2] = rotation
    closed = np.array([c != "B" for c in mode.mode.tokens], dtype=bool)
    present = np.tile(closed, (T, 1))
    f = np.asarray(mode.contact_forces, dtype=float)
    v = np.asarray(mode.contact_velocities, dtype=float) * factor
    system = TIPS if P == TIPS.n_contacts else SLIDES
    c, s = np.cos(poses[:, 0, 2]), np.sin(poses[:, 0, 2])
    r = np.asarray(system.points, dtype=float)  # (P, 2) at the start
    points = np.stack([c[:, None] * r[:, 0] - s[:, None] * r[:, 1] + poses[:, 0, :1],
                       s[:, None] * r[:, 0] + c[:, None] * r[:, 1] + poses[:, 0, 1:2]], axis=2)
    return Recording(
        engine="constructed", pair_names=tuple(f"c{i + 1}" for i in range(P)),
        body_names=("workpiece",), times=t, poses=poses, present=present,
        points=points, normals=np.zeros((T, P, 2)),
        normal_force=np.where(present, f[:, 0], 0.0), tangent_force=np.where(present, f[:, 1], 0.0),
        slip_velocity=np.where(present, v[:, 1], 0.0), depth=np.where(present, 1e-5, 0.0),
        mu_used=np.tile(np.asarray(system.mu), (T, 1)))


def _sunk_middle_support(depth: float, lifted: bool) -> tuple[Recording, ModeSet, Thresholds]:
    """The tipping box (predicted ``B1 B2 R3 S+4``) whose middle support (contact 2) is sunk by
    ``depth`` [m] at the settling time and carries 20 % of the load until the predicted motion
    lifts it out (``lifted``) -- or for the whole run."""
    mode, exp, th = _setup(TIPS)
    assert mode.label == "B1 B2 R3 S+4"
    rec = _recording(mode, exp.velocity_factor)
    vn = float(mode.contact_velocities[1, 0]) * exp.velocity_factor
    assert vn > 0  # the mode opens contact 2: the turn lifts it
    left = depth - vn * (rec.times - SETTLE) if lifted else np.full(len(rec.times), depth)
    loaded = left > 0
    rec.present[:, 1] = loaded
    rec.depth[:, 1] = np.where(loaded, left, 0.0)
    rec.normal_force[:, 1] = np.where(loaded, 0.2 * exp.load, 0.0)
    return rec, exp, th


def test_a_sunk_support_is_judged_open_once_lifted_out_of_its_depth() -> None:
    """Sunk 5 um at a predicted lift of ``omega d``: it reads loaded for depth / v_n after the
    settling time (a sixth of the judged steps here), and the run agrees; the clearing time is
    the measured depth over the predicted opening speed plus half the classifier's window."""
    rec, exp, th = _sunk_middle_support(5e-6, lifted=True)
    mask = rec.times >= SETTLE - 1e-12
    vn = float(exp.modes[0].contact_velocities[1, 0]) * exp.velocity_factor
    clear = clearing_times(rec, exp, th, mask)
    assert np.isclose(clear[0, 1], SETTLE + 5e-6 / vn + 0.5 * th.window)
    assert np.all(np.isneginf(clear[0, [0, 2, 3]]))  # contact 1 absent, 3 and 4 kept closed
    loaded = np.mean(rec.present[mask, 1])
    assert 0.1 < loaded < 0.3 < 1 - 0.95 + 0.3
    verdict, _ = judge_modes(rec, exp, th)
    assert verdict.outcome is Outcome.AGREED, verdict.reasons
    assert any("lifted them out of their measured depth" in r for r in verdict.reasons)


def test_a_contact_without_depth_is_not_excused() -> None:
    """The same loads with a measured depth of zero: nothing excuses the loaded
    support, and the run disagrees."""
    rec, exp, th = _sunk_middle_support(5e-6, lifted=True)
    rec.depth[:, 1] = 0.0
    verdict, _ = judge_modes(rec, exp, th)
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons
    assert verdict.agreement < 0.95


def test_a_support_that_stays_loaded_disagrees() -> None:
    """Sunk 5 um but never lifted: once the predicted motion would have lifted it out, its load
    is a miss, and the run disagrees."""
    rec, exp, th = _sunk_middle_support(5e-6, lifted=False)
    verdict, _ = judge_modes(rec, exp, th)
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons


def _rocking(amplitude_error: float, turns: bool) -> tuple[Recording, ModeSet, Thresholds]:
    """The sliding tall box (predicted to slide on its 8 supports without turning) pitching by
    a rotation whose mean rate over the first 0.2 s of judged steps misses by
    ``amplitude_error`` of the drive: in a 0.12 s cycle, or (``turns``) steadily."""
    mode, exp, th = _setup(SLIDES)
    assert mode.label.startswith("S-1") and abs(mode.qdot[2]) < 1e-12
    t = np.arange(0.0, DURATION + DT / 2, DT)
    rate = amplitude_error * exp.drive / exp.length  # [rad/s] over the early 0.2 s
    if turns:
        theta = rate * t
    else:
        phase = lambda s: (1.0 - np.cos(2 * np.pi * s / 0.12)) / 2  # noqa: E731
        amplitude = rate * 0.2 / abs(phase(SETTLE + 0.2) - phase(SETTLE))
        theta = amplitude * phase(t)
    return _recording(mode, exp.velocity_factor, rotation=theta), exp, th


def test_stick_slip_rocking_averages_out_over_the_stretch() -> None:
    """A 0.12 s rocking whose first 0.2 s turns the box at 25 % of the drive (the early twist
    misses) agrees: the stretch lasts while the box stays within the drift limit of 1 % of its
    size of its start (1 s here), over which the cycle averages out."""
    rec, exp, th = _rocking(0.25, turns=False)
    judged = rec.times >= SETTLE - 1e-12
    t, pose = rec.times[judged], rec.poses[judged, 0]
    # the box is 0.5 % of its size from its start at the settling time and reaches the 1 %
    # drift limit one second later
    end = twist_stretch(t, rec.poses[judged][:, :1], rec.poses[0][:1], exp.length, th.early)
    assert abs(t[end] - t[0] - (FORCE_DRIFT_LIMIT - 0.005) / 0.005) < 0.01
    k = int(np.searchsorted(t, t[0] + 0.2 + 1e-9)) - 1
    early = (pose[k] - pose[0]) / (t[k] - t[0])
    assert twist_error(early, exp.twists()[0], exp.length, exp.drive) > TWIST_TOLERANCE
    verdict, _ = judge_modes(rec, exp, th)
    assert verdict.outcome is Outcome.AGREED, verdict.reasons
    assert verdict.motion.twist_error <= TWIST_TOLERANCE


def test_a_box_that_turns_is_a_twist_miss() -> None:
    """The same early rotation kept up (the box turns): a twist miss over the stretch too."""
    rec, exp, th = _rocking(0.25, turns=True)
    verdict, _ = judge_modes(rec, exp, th)
    assert verdict.outcome is Outcome.DISAGREED, verdict.reasons
    assert verdict.motion.twist_error > TWIST_TOLERANCE
