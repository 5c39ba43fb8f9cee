"""MuJoCo's sliding lift-off and the soft squeeze impedance that removes it (docs/simulation.md,
"MuJoCo: the sliding lift-off").

A sliding contact in MuJoCo's elliptic cone is pushed apart by its friction rows' velocity
reference: it stays closed only while its lift ratio ``rho = friction B_t |v_t| / ((1 + mu^2)
f_n R_n)`` is below 1. With the stiff squeeze impedance (``solimp`` 0.99, the default) Example
4.3 at mu = .213 .36 .341 (campaign point ex43 / 133, seed 1) has its sliding finger at ``rho``
2-8: it is missing on 30 % of the judged steps, the rolling contact slips and MuJoCo shows
``S-1 S-2 B3``. With the system scenes' settings (:data:`sim.settings.SETTINGS`:
``squeeze_d0``, ``squeeze_solref``) squeeze pairs start soft and stiffen to
the default over the load width (:func:`load_width`), with twice the default's damping at the
same stiffness (``SQUEEZE_SOLREF``).
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from campaign_module import campaign

from scenarios.runs import simulate_system
from sim.settings import SQUEEZE_D0, SQUEEZE_SOLREF, EngineSettings, SceneKind, settings_for
from sim.verdict import Outcome

pytest.importorskip("mujoco")
from sim.backends.mujoco_engine import MujocoBackend  # noqa: E402
from sim.backends.mujoco_impedance import load_width  # noqa: E402

SOFT = replace(EngineSettings(), squeeze_d0=SQUEEZE_D0, squeeze_solref=SQUEEZE_SOLREF)
#: The backend's defaults: stiff squeeze pairs, driven bodies 1e6 x the workpiece's mass
STIFF = EngineSettings()


def test_load_width_is_the_penetration_that_carries_the_load() -> None:
    load, d0, d_far, solref, diag_a = 0.981, SQUEEZE_D0, 0.99, (0.004, 1.0), 10.0
    w = load_width(load, d0, d_far, solref, diag_a)
    k = 1.0 / (d_far * solref[0] * solref[1]) ** 2
    r_n = (1 - d0) / d0 * diag_a
    assert k * d0 * w / r_n == pytest.approx(load)  # MuJoCo's resting f_n = K imp |pos| / R_n
    assert 1e-5 < w < 3e-5  # the campaign's scenes: about 20 um
    assert load_width(2 * load, d0, d_far, solref, diag_a) == pytest.approx(2 * w)


def _run(case: str, index: int, settings: EngineSettings | None):
    system, mu, _ = campaign().point(case, index, 1)
    return simulate_system(system, "mujoco", mu=mu, settings=settings)


def test_squeeze_pairs_get_the_soft_impedance_only_when_asked() -> None:
    from planner.files.system_file import load_system
    from scenarios.registry import DATA_DIR
    from sim.scenes.system import system_scene

    scene = system_scene(load_system(DATA_DIR / "example_4_3.json"))
    for d0, solref in ((None, (0.004, 1.0)), (SQUEEZE_D0, SQUEEZE_SOLREF)):
        be = MujocoBackend(squeeze_d0=d0, squeeze_solref=SQUEEZE_SOLREF)
        be.build(scene)
        assert set(be.roles.values()) == {"squeeze"}
        for i in range(be.model.npair):
            imp = be.model.pair_solimp[i]
            assert tuple(imp[:2]) == pytest.approx((0.99, 0.999) if d0 is None else (d0, 0.99))
            assert tuple(be.model.pair_solref[i]) == pytest.approx(solref)
        assert bool(be.squeeze_widths) == (d0 is not None)
        assert be.model.opt.impratio == 1.0
    # the same stiffness K = 1 / (d_width timeconst dampratio)^2, twice the damping 2 / timeconst
    assert SQUEEZE_SOLREF[0] * SQUEEZE_SOLREF[1] == pytest.approx(0.004 * 1.0)
    assert SQUEEZE_SOLREF[0] == pytest.approx(0.004 / 2)


@pytest.mark.long
@pytest.mark.slow  # 40-70 s: by hand; the stiff runs of ex41 / 13 below miss the same way
def test_sliding_finger_chatters_with_the_stiff_impedance() -> None:
    res = _run("ex43", 133, STIFF)
    assert res.verdict.outcome != Outcome.AGREED
    assert "S-1 S-2 B3" in res.summary.observed["counts"]


@pytest.mark.parametrize("case,index", [
    pytest.param("ex43", 133, marks=pytest.mark.slow),  # 30-70 s each: by hand; one stays in CI
    ("ex41", 13), pytest.param("system", 39, marks=pytest.mark.slow)])
@pytest.mark.long
def test_soft_squeeze_agrees_where_the_stiff_one_did_not(case, index) -> None:
    """ex43 / 133: the sliding finger's lift-off; ex41 / 13: Example 4.1 in the 3S region
    (forces off the certificate under flicker with the stiff impedance); system / 39: a box at
    table friction 0.85 whose pushing finger chattered. Each missed with the default impedance
    and agrees with the soft, damped one -- and with the system scenes' settings (the default
    of ``simulate_system``). The box's stiff run agrees too since the judge compares the twist
    over the stretch the certificate's configuration holds (docs/simulation.md, "Judging a
    run"): its chatter averages out there."""
    if case != "system":
        assert _run(case, index, STIFF).verdict.outcome != Outcome.AGREED
    res = _run(case, index, SOFT)
    assert res.verdict.outcome == Outcome.AGREED, res.verdict.reason
    res = _run(case, index, None)
    assert res.verdict.outcome == Outcome.AGREED, res.verdict.reason


@pytest.mark.long
def test_system_scenes_use_the_lighter_driven_bodies() -> None:
    """ex41 / 61 (Example 4.1 in 3S at mu = .44 .95 .21, seed 1): with the soft squeeze but driven
    bodies 1e6 x the workpiece's mass, MuJoCo's solver (stopping tests scaled by the mean
    inertia, the driven bodies') leaves the forces off the certificate; at
    :data:`sim.settings.SYSTEM_HEAVY_RATIO` the run agrees (docs/simulation.md, "MuJoCo: the
    driven bodies' mass")."""
    from sim.settings import HEAVY_RATIO, SYSTEM_HEAVY_RATIO

    assert settings_for(SceneKind.SYSTEM, "mujoco").heavy_ratio == SYSTEM_HEAVY_RATIO < HEAVY_RATIO
    assert settings_for(SceneKind.SYSTEM, "mujoco").squeeze_d0 == SQUEEZE_D0
    assert _run("ex41", 61, SOFT).verdict.outcome != Outcome.AGREED
    res = _run("ex41", 61, None)
    assert res.verdict.outcome == Outcome.AGREED, res.verdict.reason
