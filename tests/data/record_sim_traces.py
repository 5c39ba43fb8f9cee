"""Record the short simulator traces that tests/sim/test_sim_flicker.py classifies, and the
validation campaign's runs that tests/sim/test_campaign_traces.py judges.

Run from the repository root: ``PYTHONPATH=.:tests python tests/data/record_sim_traces.py
[NAME ...]`` (the traces named, else all).
Each trace is one paper-example run (at :data:`RECORDED_WITH`: the scale, speed, mass, time step
and backend defaults the traces were recorded with -- they are recorded data of real flicker
and jams for the classifier's tests, not the pipeline's settings) cut to the
``[start, stop]`` seconds listed below and stored as float32 arrays in
``tests/data/sim_trace_<name>.npz``: ``times`` (T,), per contact ``vt``, ``fn``, ``ft``,
``depth`` (T, P) and ``present`` (T, P), the workpiece ``poses`` (T, 3), and ``meta`` (a JSON
string: engine, data, scale, mu, speed, load, creep, settle, length_scale). The tests rebuild the
prediction from the planner; nothing predicted is stored.

A **campaign trace** (:data:`CAMPAIGN_TRACES`) is one row of a validation campaign's results
file (its system file, friction and negative control), simulated again through
:func:`scenarios.runs.simulate_system` -- the path of ``qsplan simulate FILE --engine E`` --
and stored whole in ``tests/data/campaign_trace_<name>.npz``: ``times`` (T,), per pair ``vt``,
``fn``, ``ft``, ``depth``, ``present`` (T, P) and the contact ``points`` (T, P, 2) [m, world
frame], the workpieces' ``poses`` (T, n_b, 3), and ``meta`` (engine, the system ``file``, ``mu``,
``control_mu``, ``control_system``, the row it came from).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from sim_helpers import example_scene

from planner.files.system_file import load_system
from scenarios.registry import DATA_DIR as DATA
from sim.backends import make_backend
from sim.run import RunSettings, run_scene

HERE = Path(__file__).resolve().parent
#: Per engine: time step [s], creep floor [m/s], drive speed [m/s], workpiece mass [kg] and
#: settling time [s] of the recordings (MuJoCo with the backend's default settings).
RECORDED_WITH = {
    "pymunk": {"dt": 1e-3, "creep": 1e-9, "speed": 2e-3, "mass": 0.1, "settle": 0.2},
    "mujoco": {"dt": 1e-3, "creep": 1e-8, "speed": 5e-4, "mass": 0.01, "settle": 1.5},
    "dart": {"dt": 1e-3, "creep": 1e-6, "speed": 2e-3, "mass": 0.1, "settle": 0.3},
}
#: name -> (engine, data, scale, mu, start [s], stop [s])
TRACES = {
    # Example 4.1 inside the 3S region at high mu_2: MuJoCo's contacts flicker
    "mujoco_ex41_3s_flicker": ("mujoco", "example_4_1", 0.01, (0.2, 0.6, 0.1), 1.2, 2.6),
    "mujoco_ex41_3s_flicker_b": ("mujoco", "example_4_1", 0.01, (0.3, 0.7, 0.2), 1.2, 2.6),
    # Example 4.3 at mu = 3: pymunk wedges the workpiece (B1 R2 S-3, forces 30-110 x the load)
    # for 0.4 s, flickers, then leaves for S-1 R2 B3 (both predicted)
    "pymunk_ex43_mu3_wedge": ("pymunk", "example_4_3", 0.1, (3.0, 3.0, 3.0), 0.0, 1.4),
    # Example 4.1 in a jam region: pymunk's contacts flicker while the force blows up
    "pymunk_ex41_jam_flicker": ("pymunk", "example_4_1", 0.01, (1.44, 1.09, 0.81), 0.0, 0.5),
    # clean runs: 3S in pymunk, a MuJoCo jam (penetration grows, nothing predicted)
    "pymunk_ex41_3s": ("pymunk", "example_4_1", 0.01, (0.2, 0.6, 0.1), 0.0, 1.4),
    "mujoco_ex41_jam": ("mujoco", "example_4_1", 0.01, (0.75, 0.95, 0.25), 0.5, 3.0),
    # the same 3S run in DART (the engine with true stiction, docs/engine-dart.md)
    "dart_ex41_3s": ("dart", "example_4_1", 0.01, (0.2, 0.6, 0.1), 0.0, 1.4),
}


#: name -> (results file under benchmarks/results, row index, engine): campaign rows whose
#: MuJoCo verdict missed while pymunk and DART agreed, and the same points in pymunk
CAMPAIGN_TRACES = {
    # seed 6 supports 6: a 2.1 x 6.0 m box on 9 supports tipping about its corner; MuJoCo's
    # support next to the pivot touches it 0.085 m from the pivot (the model's: 0.262 m)
    "mujoco_seed6_supports6_tips": ("validation_campaign_seed6.jsonl", 24, "mujoco"),
    "pymunk_seed6_supports6_tips": ("validation_campaign_seed6.jsonl", 25, "pymunk"),
    # seed 6 supports 9: a box on 7 supports tipping about the other corner (mirrored)
    "mujoco_seed6_supports9_tips": ("validation_campaign_seed6.jsonl", 36, "mujoco"),
    "pymunk_seed6_supports9_tips": ("validation_campaign_seed6.jsonl", 37, "pymunk"),
    # seed 5 stacked 2: two blocks slide on the table, pushed by a finger that sticks; MuJoCo's
    # finger contact chatters (missing on 11 % of the steps) and its slip reading flickers
    "mujoco_seed5_stacked2_finger_sticks": (
        "validation_campaign_seed5_soft_contacts.jsonl", 10, "mujoco"),
    "pymunk_seed5_stacked2_finger_sticks": (
        "validation_campaign_seed5_soft_contacts.jsonl", 11, "pymunk"),
    # seed 5 stacked 9: the top block slides on the middle one; its sticking finger chatters
    "mujoco_seed5_stacked9_top_slides": (
        "validation_campaign_seed5_soft_contacts.jsonl", 38, "mujoco"),
    "pymunk_seed5_stacked9_top_slides": (
        "validation_campaign_seed5_soft_contacts.jsonl", 39, "pymunk"),
    # seed 7 acute 10: a 31 deg rhombus slid along the table by a frictionless finger on its
    # slanted edge; its certificate loads the rear corner (the lower end of the finger's edge)
    # with 2.2 N of 108 N, and pymunk leaves that corner unloaded (B) on 94 % of the steps
    # while the twist matches
    "pymunk_seed7_acute10_light_corner": ("validation_campaign_seed7.jsonl", 124, "pymunk"),
    "mujoco_seed7_acute10_light_corner": ("validation_campaign_seed7.jsonl", 125, "mujoco"),
}
RESULTS = HERE.parents[1] / "benchmarks" / "results"


def record_campaign(name: str) -> Path:
    """Simulate one campaign row again as ``qsplan simulate`` does and store the run whole
    (module docstring)."""
    from planner.files.system_file import system_from_dict
    from scenarios.runs import simulate_system

    results, index, engine = CAMPAIGN_TRACES[name]
    row = [json.loads(line) for line in (RESULTS / results).read_text().splitlines()][index]
    assert row["engine"] == engine, (row["engine"], engine)
    system = system_from_dict(row["file"])
    res = simulate_system(system, engine, mu=np.asarray(row["mu"]))
    rec = res.recording
    assert rec.fault is None, rec.fault
    idx = [rec.body_names.index(b) for b in res.job.expectation.bodies]
    meta = {"engine": engine, "file": row["file"], "mu": row["mu"],
            "control_mu": row["control_mu"], "control_system": row.get("control_system"),
            "row": f"{results} #{index}: {row['case']} {row['index']} (seed {row['seed']})",
            "bodies": list(res.job.expectation.bodies)}
    path = HERE / f"campaign_trace_{name}.npz"
    np.savez_compressed(
        path, times=rec.times, vt=rec.slip_velocity.astype(np.float32),
        fn=rec.normal_force.astype(np.float32), ft=rec.tangent_force.astype(np.float32),
        depth=rec.depth.astype(np.float32), present=rec.present,
        points=rec.points.astype(np.float32), poses=rec.poses[:, idx],
        meta=np.array(json.dumps(meta)))
    return path


def record(name: str) -> Path:
    if name in CAMPAIGN_TRACES:
        return record_campaign(name)
    engine, data, scale, mu, start, stop = TRACES[name]
    es = RECORDED_WITH[engine]
    speed = float(es["speed"])
    base = load_system(DATA / f"{data}.json")
    scene = example_scene(data, scale, speed, mu, mass=float(es["mass"]))
    load = float(np.linalg.norm(base.g_obj[:2]))
    rec = run_scene(scene, make_backend(engine), RunSettings(
        duration=stop, dt=float(es["dt"]), slip_speed=0.05 * speed,
        penetration_tol=0.02 * scene.length_scale))
    assert rec.fault is None, rec.fault
    keep = (rec.times >= start - 1e-9) & (rec.times <= stop + 1e-9)
    iw = rec.body_names.index("workpiece")
    meta = {"engine": engine, "data": data, "scale": scale, "mu": list(mu), "speed": speed,
            "load": load, "creep": float(es["creep"]), "settle": float(es["settle"]),
            "length_scale": scene.length_scale, "start": start, "stop": stop}
    path = HERE / f"sim_trace_{name}.npz"
    np.savez_compressed(
        path, times=rec.times[keep], vt=rec.slip_velocity[keep].astype(np.float32),
        fn=rec.normal_force[keep].astype(np.float32),
        ft=rec.tangent_force[keep].astype(np.float32),
        depth=rec.depth[keep].astype(np.float32), present=rec.present[keep],
        poses=rec.poses[keep, iw], meta=np.array(json.dumps(meta)))
    return path


if __name__ == "__main__":
    import sys

    for nm in sys.argv[1:] or [*TRACES, *CAMPAIGN_TRACES]:  # the traces named, else all
        p = record(nm)
        print(f"{p.name}: {p.stat().st_size / 1024:.0f} KiB")
