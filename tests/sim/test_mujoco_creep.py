"""MuJoCo's friction creep predicted from its soft-constraint parameters
(:func:`sim.backends.mujoco_impedance.creep_impratio`; docs/simulation.md, "MuJoCo: friction
creep").

A 0.2 kg block rests on a table (frictional ``support`` pair, no noslip so the soft friction
row is seen alone) under its weight and a sideways push below the Coulomb limit. MuJoCo's
friction row makes its steady slip ``R_t f_t / b``: the test reads ``R_n`` and ``b`` from the
model's constraint rows and checks the measured creep against that prediction (within 1 %)
at two impratios and two pushes (it scales with the force and with ``1 / impratio``), then that the
impratio derived for a creep speed keeps the block below it.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.backends.mujoco_impedance import creep_impratio
from sim.scene import Body, BodyKind, Capsule, ContactPair, Load, Polygon, Scene
from sim.settings import EngineSettings, with_stick_limits

mujoco = pytest.importorskip("mujoco")

WEIGHT, MU = 1.962, 0.6


def block_scene(push: float) -> Scene:
    """A 0.04 m block on a table: weight ``WEIGHT`` down, ``push`` [N] to the right."""
    table = Body("table", (Capsule((-0.2, -0.002), (0.2, -0.002), 0.002),),
                 kind=BodyKind.STATIC)
    h = 0.02
    block = Body("workpiece", (Polygon(((-h, -2e-6), (h, -2e-6), (h, 2 * h), (-h, 2 * h))),),
                 mass=0.2, com=(0.0, h), inertia=0.2 * (2 * h) ** 2 / 6)
    return Scene(bodies=(table, block), pairs=(ContactPair("c1", "table", "workpiece", MU),),
                 loads=(Load("workpiece", (push, -WEIGHT)),), length_scale=0.04,
                 bounds=(-1, -1, 1, 1), only_pairs=True)


def creep(push: float, impratio: float) -> tuple[float, float]:
    """(measured steady slip [m/s], predicted ``R_t push / b`` [m/s]) of the block."""
    from sim.backends.mujoco_engine import MujocoBackend

    b = MujocoBackend(noslip_iterations=0, solref=(0.01, 1.0), impratio=impratio)
    b.build(block_scene(push))
    m, d = b.model, b.data
    m.opt.impratio = impratio  # a support pair keeps the constructor's impratio otherwise
    for _ in range(1500):
        b.step(1e-3)
    v = [b.state()["workpiece"].twist[0] for _ in range(200) if b.step(1e-3) is None]
    a = int(d.contact[0].efc_address)
    r_t, damping = float(d.efc_R[a + 1]), float(d.efc_KBIP[a, 1])
    # a flat face gives several MuJoCo contacts sharing the friction force
    share = push / max(d.ncon, 1)
    return float(np.mean(v)), r_t * share / damping


@pytest.mark.parametrize("push, impratio", [(0.6, 1.0), (0.3, 1.0), (0.6, 10.0)])
def test_sticking_contact_creeps_as_its_friction_row_predicts(push: float,
                                                              impratio: float) -> None:
    measured, predicted = creep(push, impratio)
    assert push < MU * WEIGHT  # the block sticks in Coulomb's law
    assert measured > 0  # it creeps toward the push
    assert measured == pytest.approx(predicted, rel=0.01)  # measured: within 0.04 %


def test_derived_impratio_keeps_the_creep_below_the_speed() -> None:
    from sim.backends.mujoco_engine import MujocoBackend

    speed, push = 1e-5, 0.6
    measured_at_1, _ = creep(push, 1.0)
    assert measured_at_1 > speed  # the default creeps faster: the check can fail
    b = MujocoBackend(noslip_iterations=0, solref=(0.01, 1.0), contact_force=push / MU,
                      stick_speed=speed)
    b.build(block_scene(push))
    need = creep_impratio(b.model, b.data, {"c1": list(range(b.model.npair))}, push / MU,
                          speed)
    assert b.impratio_used == pytest.approx(need) and need > 1.0
    for _ in range(1500):
        b.step(1e-3)
    v = [b.state()["workpiece"].twist[0] for _ in range(200) if b.step(1e-3) is None]
    assert 0 < float(np.mean(v)) <= speed


def test_stick_limits_are_checked() -> None:
    with pytest.raises(ValueError, match=r"stick limits: expected a finite force >= 0 \[N\] "
                                         r"and a speed > 0 \[m/s\], got 1.0 and 0.0"):
        with_stick_limits(EngineSettings(), 1.0, 0.0)
    es = with_stick_limits(EngineSettings(), 2.0, 1e-4)
    assert (es.contact_force, es.stick_speed) == (2.0, 1e-4)


def test_a_plan_run_hands_mujoco_its_contacts_force_and_creep_speed() -> None:
    """The flip's plan at its box's upper corner: the load plus the squeeze as the contact
    force, half the slip threshold as the creep speed (at the simulated size), and the built
    model's impratio the creep bound of its soft wall and table pairs."""
    from pathlib import Path

    from planner.plan.plan_file import load_plan
    from sim.backends import make_backend
    from sim.jobs import job_for_plan
    from sim.similarity import scaled_masses, scaled_scene

    plan = load_plan(Path(__file__).resolve().parents[1] / "data" / "plan_flip_against_wall.json")
    job = job_for_plan(plan, "mujoco", (0.4, 0.4, 1.0))
    es = job.settings
    assert es.contact_force == pytest.approx(job.parameters["load_N"]
                                             + job.parameters["squeeze_N"])
    assert es.stick_speed == pytest.approx(0.5 * job.thresholds.slip_speed * job.scale)
    b = make_backend("mujoco", es)
    b.build(scaled_masses(scaled_scene(job.scene, job.scale), es.mass_scale))
    need = creep_impratio(b.model, b.data, {"all": list(range(b.model.npair))},
                          es.contact_force, es.stick_speed)
    assert b.impratio_used == pytest.approx(need) and need > 10.0
    frictionless = job_for_plan(plan, "mujoco", (0.0, 0.0, 0.7))
    b0 = make_backend("mujoco", frictionless.settings)
    b0.build(scaled_masses(scaled_scene(frictionless.scene, frictionless.scale),
                           frictionless.settings.mass_scale))
    assert b0.impratio_used < b.impratio_used  # frictionless wall and table need none



@pytest.mark.parametrize("noslip", [20, 0])
def test_noslip_holds_a_system_scenes_sticking_contact(noslip: int) -> None:
    """A block at rest on a 20 deg incline at friction 0.4 (``qsplan simulate``'s job, its
    workpiece a free body with MuJoCo's out-of-plane slide): the job carries no stick limits and
    runs at the roles' impratio, at which the soft friction row alone lets a contact holding
    ``mu`` times the load creep past the slip threshold (the impratio :func:`creep_impratio`
    asks for half of it is higher). MuJoCo's noslip pass re-solves the friction rows without
    that regulariser and holds both contacts (measured 0.000 x the threshold); without noslip
    they creep at 2.8 x the threshold (docs/simulation.md, "MuJoCo: friction creep")."""
    from dataclasses import replace
    from pathlib import Path

    from planner.files.system_file import load_system
    from planner.predict.feasibility import feasible_modes
    from sim.backends import make_backend
    from sim.jobs import CREEP_OF_SLIP, job_for_system
    from sim.run import run_scene
    from sim.similarity import scaled_masses, scaled_scene

    data = Path(__file__).resolve().parents[1] / "data"
    system = load_system(data / "incline_20deg_mu04.json")
    prediction = feasible_modes(system)
    assert [m.label for m in prediction.all_modes] == ["R1 R2"]
    job = job_for_system(system, "mujoco", prediction)
    es, s = job.settings, job.scale
    assert es.contact_force is None and es.stick_speed is None
    b = make_backend("mujoco", es)
    b.noslip_iterations = noslip
    run = replace(job.run, slip_speed=job.run.slip_speed * s,
                  penetration_tol=job.run.penetration_tol * s)
    rec = run_scene(scaled_masses(scaled_scene(job.scene, s), es.mass_scale), b, run)
    threshold = job.thresholds.slip_speed * s
    need = creep_impratio(b.model, b.data, {"all": list(range(b.model.npair))},
                          job.parameters["force_scale_N"], CREEP_OF_SLIP * threshold)
    assert rec.fault is None and need > 10.0 * b.impratio_used
    slip = np.abs(rec.slip_velocity[rec.times >= es.settle]).mean(axis=0) / threshold
    if noslip:
        assert np.all(slip < CREEP_OF_SLIP)  # measured: 0.000
    else:
        assert np.all(slip > 1.0)  # measured: 2.8
