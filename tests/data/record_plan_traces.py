"""Record the plan-run traces that tests/sim/test_judge_plan_slips.py judges.

Run from the repository root (heavy: a MuJoCo run of the flip takes several minutes):
``PYTHONPATH=.:tests python tests/data/record_plan_traces.py [NAME ...]`` (the traces named,
else all).

Each trace is one run of the shipped flip's plan (``plan_flip_against_wall.json``, written by
``qsplan plan flip_against_wall``) through the pipeline of ``qsplan validate``
(:func:`sim.jobs.job_for_plan`, the engine's hand settings) at the friction listed below --
the plan's efforts, or with ``negative`` the negative control's efforts just outside the
guaranteed region (:func:`planner.plan.negative_controls.outside_torques`, the reach of
``benchmarks/field_tasks.py``) -- cut to its first ``stop`` seconds and every ``every``-th
recorded step, stored as float32 arrays in ``tests/data/plan_trace_<name>.npz``: ``times``
(T,), per contact ``vt``, ``fn``, ``ft``, ``depth``, ``present`` (T, P), the workpiece
``poses`` (T, 3) and ``meta`` (a JSON string). The tests rebuild the expectation from the plan;
nothing judged is stored.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from planner.plan.plan_file import load_plan
from sim.run import Recording

HERE = Path(__file__).resolve().parent
PLAN = HERE / "plan_flip_against_wall.json"
#: Mode tests need the stretch where the wall corner's predicted slip is below the slip
#: threshold (about the first 16 degrees of the turn) and well past it.
LOWER_CORNER = (0.0, 0.0, 0.7)
#: name -> (engine, friction per contact, negative control, stop [s], every)
TRACES = {
    "pymunk_flip_lower": ("pymunk", LOWER_CORNER, False, 30.0, 10),
    "mujoco_flip_lower": ("mujoco", LOWER_CORNER, False, 40.0, 10),
    "pymunk_flip_negative": ("pymunk", LOWER_CORNER, True, 30.0, 10),
    "mujoco_flip_negative": ("mujoco", LOWER_CORNER, True, 30.0, 10),
}
#: The negative control's reach (benchmarks/field_tasks.py, NEGATIVE_REACH).
NEGATIVE_REACH = 0.3


def save_trace(name: str, rec: Recording) -> Path:
    """Write the cut, thinned ``rec`` of trace ``name`` (module docstring)."""
    engine, mu, negative, stop, every = TRACES[name]
    keep = np.flatnonzero(rec.times <= stop + 1e-9)[::every]
    iw = rec.body_names.index("workpiece")
    meta = {"engine": engine, "mu": list(mu), "negative": negative, "stop": stop,
            "every": every, "reach": NEGATIVE_REACH, "plan": PLAN.name}
    path = HERE / f"plan_trace_{name}.npz"
    np.savez_compressed(
        path, times=rec.times[keep], vt=rec.slip_velocity[keep].astype(np.float32),
        fn=rec.normal_force[keep].astype(np.float32),
        ft=rec.tangent_force[keep].astype(np.float32),
        depth=rec.depth[keep].astype(np.float32), present=rec.present[keep],
        poses=rec.poses[keep, iw], meta=np.array(json.dumps(meta)))
    return path


def record(name: str) -> Path:
    from planner.plan.negative_controls import outside_torques
    from scenarios.runs import validate_plan

    engine, mu, negative, _, _ = TRACES[name]
    plan = load_plan(PLAN)
    if negative:
        seg = plan.segments[-1]
        tau = outside_torques(seg, seg.hand_model[0], list(mu), reach=NEGATIVE_REACH)
        run = validate_plan(seg, engine, list(mu), torques=tau, expect="disagree")
    else:
        run = validate_plan(plan, engine, list(mu))
    return save_trace(name, run.recording)


if __name__ == "__main__":
    import sys

    for nm in sys.argv[1:] or TRACES:  # the traces named, else all
        p = record(nm)
        print(f"{p.name}: {p.stat().st_size / 1024:.0f} KiB")
