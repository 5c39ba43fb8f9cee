"""The one way a file becomes a verdict: predict with the planner, build the job, run it through
the pipeline (:mod:`sim.jobs`), write the outputs.

A registered scenario is data (:class:`scenarios.registry.Scenario`: a shipped file, friction,
expectation) run through these functions, and so is a user's own file: ``qsplan simulate``
(:func:`simulate_system`), ``qsplan validate`` (:func:`validate_plan`), ``qsplan scenarios
run``, ``qsplan demo`` and the validation campaign all get the same scene, settings and judge.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from planner.model.system import System
from sim.jobs import RunResult, execute, job_for_plan, job_for_ruler, job_for_system
from sim.settings import EngineSettings
from sim.verdict import Expect


def simulate_system(system: System, engine: str, *, mu: Any = None, mu_kinetic: Any = None,
                    judge_mu: Any = None, judge_system: System | None = None,
                    duration: float | None = None, speed: float | None = None,
                    name: str | None = None, source: str | None = None,
                    expect: Expect | None = None,
                    settings: EngineSettings | None = None) -> RunResult:
    """Simulate ``system`` at friction ``mu`` (default the file's) in ``engine`` and judge the
    run against the planner's prediction at ``judge_mu`` (default ``mu``) of ``judge_system``
    (default ``system``, with the same contacts and bodies). Judging at another friction or
    system is a negative control: ``expect`` defaults to ``disagree`` then, else ``agree``.
    ``settings`` replaces the settings table's engine settings (measurements of other
    settings only)."""
    from planner.errors import InputError
    from planner.predict.feasibility import feasible_modes

    sim_sys = system if mu is None else system.with_mu(mu)
    judge = system if judge_system is None else judge_system
    if judge_system is not None and (judge.n_contacts, judge.n_bodies) != (
            system.n_contacts, system.n_bodies):
        raise InputError("judge system: expected the same number of contacts and bodies "
                         f"({system.n_contacts}, {system.n_bodies}), got "
                         f"({judge.n_contacts}, {judge.n_bodies})")
    if judge_mu is not None:
        judge = judge.with_mu(judge_mu)
    elif judge_system is not None or mu is not None:
        judge = judge.with_mu(sim_sys.mu)
    negative = judge_system is not None or not np.array_equal(np.asarray(judge.mu),
                                                              np.asarray(sim_sys.mu))
    muk = None if mu_kinetic is None else np.asarray(system.with_mu(mu_kinetic).mu, dtype=float)
    prediction = feasible_modes(judge)
    reference = prediction if not negative else feasible_modes(sim_sys)
    job = job_for_system(
        sim_sys, engine, prediction, judge_system=judge, reference=reference, mu_kinetic=muk,
        duration=duration, speed=speed, name=name or "simulate", source=source,
        expect=expect or (Expect.DISAGREE if negative else Expect.AGREE),
        parameters={"negative_control": negative})
    if settings is not None:
        from dataclasses import replace

        job = replace(job, settings=settings)
    return execute(job)


def validate_plan(plan: Any, engine: str, mu: Any, *, waypoints: int | None = None,
                  torques: np.ndarray | None = None,
                  name: str | None = None, source: str | None = None,
                  expect: Expect | str = Expect.AGREE,
                  parameters: dict[str, Any] | None = None) -> RunResult:
    """Run ``plan`` (a :class:`planner.plan.model.Plan` or one of its segments) in ``engine``
    at friction ``mu`` and judge every segment and the whole; ``torques`` replaces a
    one-segment plan's efforts and ``waypoints`` shortens it (negative controls and short
    runs); ``parameters`` are recorded in the summary's ``parameters``."""
    return execute(job_for_plan(plan, engine, mu, torques=torques,
                                waypoints=waypoints, name=name or "validate", source=source,
                                expect=Expect.parse(expect), parameters=parameters))


def run_ruler(engine: str, *, mu_s: float, mu_k: float, predict_mu_k: float | None = None,
              left: float = -0.4, right: float = 0.25, length: float = 0.1,
              speed: float | None = None, required: int = 5, tolerance: float = 0.02,
              reference: str = "planner", name: str = "ruler",
              expect: Expect | str = Expect.AGREE) -> RunResult:
    """The ruler (Sec. 5.1) at static / kinetic friction ``mu_s`` / ``mu_k``, judged against
    the switch positions the planner predicts (``reference="planner"``) or the closed form
    (``"closed form"``) at kinetic ``predict_mu_k`` (default ``mu_k``; another value is a
    negative control)."""
    from planner.errors import InputError
    from planner.predict.ruler import THICKNESS_RATIO, predicted_switches, theory_switches

    pk = mu_k if predict_mu_k is None else predict_mu_k
    weight = 1.0
    if reference == "planner":
        pos, who = predicted_switches(-left * length, right * length, weight,
                                      THICKNESS_RATIO * length, mu_s, pk,
                                      min_distance=0.015 * length)
    elif reference == "closed form":
        pos, who = theory_switches(-left * length, right * length, mu_s, pk, required)
    else:
        raise InputError(f"reference: expected 'planner' or 'closed form', got {reference!r}")
    return execute(job_for_ruler(
        engine, mu_s=mu_s, mu_k=mu_k, positions=pos, sliders=who, left=left, right=right,
        length=length, speed=speed, required=required, tolerance=tolerance, weight=weight,
        name=name, expect=Expect.parse(expect),
        parameters={"predict_mu_kinetic": pk, "reference": reference}))


def write_run(result: RunResult, out_dir: str | Path, *, render: bool = True,
              animation: bool = True, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write ``summary.json`` of ``result`` (plus ``extra`` keys) and, with ``render``, its
    pictures (:func:`sim.render.draw_run`) into ``out_dir``; returns the summary written."""
    from dataclasses import replace

    from planner.files.atomic import atomic_write_json

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = result.summary
    if render:
        from sim.render import draw_run

        files = draw_run(result, out, animation=animation)
        from planner.plots.draw_file import PROBLEM_PICTURE

        problem = draw_problem(summary.source, out / PROBLEM_PICTURE)
        if problem is not None:
            files = {"problem": problem, **files}
        summary = replace(summary, files={k: Path(v).name for k, v in files.items()})
    data = {**summary.to_dict(), **(extra or {})}
    atomic_write_json(out / "summary.json", data)
    return data


def draw_problem(source: str | None, out: Path) -> Path | None:
    """Draw the file a run came from (``source``: a path, or the name of a shipped file) into
    ``out`` with :func:`planner.plots.draw_file.draw_file`: the system, hand or plan as
    ``qsplan draw`` shows it.  None when there is no source or it cannot be found or drawn
    (a partial plan): the run's own results do not depend on the picture."""
    import warnings

    from planner.errors import GeometryWarning, QsplanError
    from planner.plots.draw import save_drawing
    from planner.plots.draw_file import draw_file
    from scenarios.registry import shipped_file

    if not source:
        return None
    try:
        path = Path(source) if Path(source).is_file() else shipped_file(source, "system")
    except QsplanError:
        return None
    try:
        with warnings.catch_warnings():  # the loader's warning was shown when the run began
            warnings.simplefilter("ignore", GeometryWarning)
            fig = draw_file(path)
    except QsplanError:
        return None
    return save_drawing(fig, out)


def run_scenario(scenario: Any, out_dir: str | Path, **options: Any) -> dict[str, Any]:
    """Run a registered scenario into ``out_dir`` (``options``: ``engine``, ``render`` and its
    typed parameters): a simulator scenario's spec by :func:`run_spec`, any other by its own
    ``run`` function; returns its summary."""
    if scenario.spec is not None:
        return run_spec(scenario, out_dir, **options)
    return scenario.run(out_dir, **options)


def run_spec(scenario: Any, out_dir: str | Path, *, engine: str = "pymunk",
             render: bool = True, **options: Any) -> dict[str, Any]:
    """Run a simulator scenario (its ``spec``: :class:`scenarios.registry.SystemRun`,
    ``PlanRun`` or ``RulerRun``, with typed parameters from ``options`` replacing the spec's
    fields) the way ``qsplan simulate`` / ``validate`` run a user's file; write and return its
    summary (``scenario`` and ``reference`` added)."""
    from dataclasses import fields, replace

    from planner.errors import InputError
    from planner.files.system_file import load_system
    from scenarios.registry import PlanRun, RulerRun, SystemRun, shipped_file

    spec = scenario.spec
    known = {f.name for f in fields(spec)}
    spec = replace(spec, **{k: v for k, v in options.items() if k in known})
    rest = {k: v for k, v in options.items() if k not in known}
    name, expect = scenario.name, scenario.expect
    if isinstance(spec, SystemRun):
        system = load_system(shipped_file(spec.source, "system"))
        judge = (None if spec.judge_source is None
                 else load_system(shipped_file(spec.judge_source, "system")))
        res = simulate_system(system, engine, mu=spec.mu, judge_mu=spec.judge_mu,
                              judge_system=judge, name=name, source=spec.source,
                              expect=expect, **rest)
    elif isinstance(spec, PlanRun):
        plan = _shipped_plan(spec.source, spec.mu_interval, spec.policy)
        res = validate_plan(plan, engine, spec.mu, waypoints=spec.waypoints, name=name,
                            source=spec.source, expect=expect)
    elif isinstance(spec, RulerRun):
        res = run_ruler(engine, mu_s=spec.mu_s, mu_k=spec.mu_k,
                        predict_mu_k=spec.predict_mu_k, required=spec.required, name=name,
                        expect=expect, **rest)
    else:
        raise InputError(f"scenario {scenario.name!r}: expected a SystemRun, PlanRun or "
                         f"RulerRun spec, got {type(spec).__name__}")
    return write_run(res, out_dir, render=render,
                     extra={"scenario": name, "reference": scenario.reference})


_PLANS: dict[tuple[str, tuple[float, ...], str], Any] = {}


def _shipped_plan(source: str, mu: tuple[float, ...], policy: str) -> Any:
    """The plan of a shipped hand for friction in ``mu`` with ``policy`` (planned once per
    process)."""
    key = (source, tuple(mu), policy)
    if key not in _PLANS:
        from planner.plan.hand_planner import plan_hand
        from scenarios.registry import shipped_file

        _PLANS[key] = plan_hand(shipped_file(source), mu=tuple(mu), policy=policy)
    return _PLANS[key]
