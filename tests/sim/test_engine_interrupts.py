"""An interrupt that an engine callback swallows is raised again from the step, never recorded.

pymunk's cffi collision callbacks report every exception raised inside them to
``sys.unraisablehook`` and carry on: a Ctrl-C (``KeyboardInterrupt``) that arrives while a
post-solve callback runs would otherwise become an "engine swallowed" fault, a ``fault``
verdict, and the next run would start.  :class:`sim.run.EngineWatch` raises it again."""

from __future__ import annotations

import pytest
from sim_helpers import example_scene

from sim.backends.pymunk_engine import PymunkBackend
from sim.run import EngineWatch, FaultKind, RunSettings, run_scene, swallowed_interrupt

SPEED = 1e-3


class SignalInterrupt(KeyboardInterrupt):
    """Like the command line's SIGTERM / SIGHUP interrupt: a KeyboardInterrupt subclass."""


def _scene():
    return example_scene("example_4_1", 0.01, SPEED, (0.2, 0.3, 0.1), mass=0.01)


def _settings():
    return RunSettings(duration=0.3, dt=1e-3, slip_speed=0.05 * SPEED, penetration_tol=1e-3)


def _interrupting(exc_type, t_fail=0.1):
    class Interrupting(PymunkBackend):
        steps_interrupted = 0

        def _post_solve(self, arbiter, space, name):
            if self.t >= t_fail:
                raise exc_type("interrupted in a callback")
            super()._post_solve(arbiter, space, name)

        def step(self, dt):
            interrupted = self.t >= t_fail
            super().step(dt)
            Interrupting.steps_interrupted += interrupted

    return Interrupting


@pytest.mark.parametrize("exc_type", [KeyboardInterrupt, SignalInterrupt, SystemExit])
def test_interrupt_swallowed_by_a_callback_is_raised_from_the_step(exc_type, capsys):
    backend_type = _interrupting(exc_type)
    with pytest.raises(exc_type, match="interrupted in a callback"):
        run_scene(_scene(), backend_type(), _settings())
    assert backend_type.steps_interrupted == 1  # the loop stopped at the interrupted step
    assert "Exception ignored" not in capsys.readouterr().err


def test_an_ordinary_exception_is_still_a_fault():
    rec = run_scene(_scene(), _interrupting(RuntimeError)(), _settings())
    assert rec.fault is not None and rec.fault.kind == FaultKind.ENGINE_WARNING


def test_without_the_re_raise_the_interrupt_becomes_a_fault(monkeypatch):
    """What the run loop did before: the swallowed Ctrl-C became an engine-warning fault and the
    run ended "normally" with a verdict."""
    import sim.run

    monkeypatch.setattr(sim.run, "swallowed_interrupt", lambda swallowed: None)
    rec = run_scene(_scene(), _interrupting(KeyboardInterrupt)(), _settings())
    assert rec.fault is not None and "swallowed KeyboardInterrupt" in rec.fault.reason


def test_swallowed_interrupt_picks_base_exceptions_only():
    class U:
        def __init__(self, exc):
            self.exc_type, self.exc_value = type(exc), exc

    assert swallowed_interrupt([U(RuntimeError("x"))]) is None
    ki = KeyboardInterrupt()
    assert swallowed_interrupt([U(RuntimeError("x")), U(ki)]) is ki
    assert isinstance(swallowed_interrupt([U(SystemExit(3))]), SystemExit)
    assert EngineWatch  # the class that calls it
