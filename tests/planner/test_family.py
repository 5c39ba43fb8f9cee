"""The certificate family of a mode with some contacts (nearly) unloaded
(:func:`planner.predict.family.admits_unloaded`), derived by hand."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import InputError
from planner.model.system import System
from planner.predict.family import admits_unloaded, nearest_certificate
from planner.predict.feasibility import feasible_modes


def bar_on_two_supports() -> System:
    """A bar resting on supports at x = -1 and x = +1 (normals up, mu = 0.5), its 1 N weight at
    x = 0.8, nothing driven. By hand (moments about each support): ``N1 = (1 - 0.8) / 2 = 0.1``,
    ``N2 = (1 + 0.8) / 2 = 0.9`` in every certificate of ``R1 R2``; the tangential forces are
    indeterminate (any ``c_1t = -c_2t`` inside both cones)."""
    return System.from_contacts(points=[[-1.0, 0.0], [1.0, 0.0]], normals=[[0, 1], [0, 1]],
                                mu=0.5, external_wrench=[0.0, -1.0, -0.8],
                                contact_velocities=[[0, 0], [0, 0]])


def test_a_light_contact_is_unloaded_only_within_its_allowance() -> None:
    system = bar_on_two_supports()
    (m,) = [m for m in feasible_modes(system, [0.5, 0.5]).all_modes if m.mode.label == "R1 R2"]
    np.testing.assert_allclose(m.contact_forces[:, 0], [0.1, 0.9], atol=1e-9)
    assert not admits_unloaded(system, m.mode, [0])
    assert not admits_unloaded(system, m.mode, [0], at_most=0.09)
    assert admits_unloaded(system, m.mode, [0], at_most=0.1 + 1e-9)
    assert not admits_unloaded(system, m.mode, [1], at_most=0.5)  # 0.9 N there
    fit = nearest_certificate(system, m.mode, unloaded=[0], at_most=0.2)
    assert fit is not None and fit.forces[0, 0] == pytest.approx(0.1, abs=1e-9)


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_the_allowance_is_checked(bad: float) -> None:
    system = bar_on_two_supports()
    m = feasible_modes(system, [0.5, 0.5]).all_modes[0]
    with pytest.raises(InputError, match="at_most: expected a finite force >= 0 N"):
        nearest_certificate(system, m.mode, unloaded=[0], at_most=bad)
