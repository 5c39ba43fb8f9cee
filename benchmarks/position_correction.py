"""How much of a workpiece's motion each engine makes by position correction rather than by its
velocities (docs/simulation-measurements.md, "pymunk: motion by position correction").

Re-runs the drawn systems of a validation-campaign file (rows with a ``file``: the ``acute``,
``supports``, ``stacked`` and ``static`` cases) through the one pipeline
(:func:`sim.jobs.job_for_system`, :func:`sim.jobs.execute`, what ``qsplan simulate`` runs) and
prints per run: the verdict, the largest correction rate over the judged steps (window
``jam_rate_window``) divided by the jam depth rate, and the share of judged steps that
:func:`sim.classify.correction_steps` flags. Nothing is asserted here
(tests/sim/test_position_correction.py, tests/sim/test_sim_classify.py).

    PYTHONPATH=. python benchmarks/position_correction.py \\
        benchmarks/results/validation_campaign_seed5.jsonl --engines pymunk,mujoco,dart --runs 40
"""

from __future__ import annotations

import argparse
import json
import random

import numpy as np

from planner.files.system_file import system_from_dict
from planner.predict.feasibility import feasible_modes
from sim.classify import correction_steps, judged_mask
from sim.jobs import execute, job_for_system


def correction_ratio(rec, th, bodies) -> float:
    """Largest rate of ``rec.correction`` over ``th.jam_rate_window`` among the judged steps,
    over the jam depth rate (``|(v_x, v_y, L w)|``, the largest over ``bodies``)."""
    idx = [rec.body_names.index(b) for b in bodies]
    C = rec.correction[:, idx, :]
    T = len(rec.times)
    step = float(rec.times[1] - rec.times[0])
    w = min(max(1, int(round(th.jam_rate_window / step))), T - 1)
    rate = (C[w:] - C[:-w]) / (w * step)
    speed = np.linalg.norm(rate * np.array([1.0, 1.0, th.length_scale]), axis=-1).max(axis=1)
    judged = rec.times[w:] >= th.settle
    return float(speed[judged].max() / th.jam_depth_rate) if judged.any() else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", help="validation campaign JSONL (rows with a 'file')")
    ap.add_argument("--engines", default="pymunk,mujoco,dart")
    ap.add_argument("--runs", type=int, default=40, help="systems per engine (seeded shuffle)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rows = [json.loads(line) for line in open(args.campaign)]
    files = {(r["case"], r["index"]): r["file"] for r in rows if "file" in r}
    keys = sorted(files)
    random.Random(args.seed).shuffle(keys)
    print("engine | case | index | predicted | verdict | max correction / jam depth rate | "
          "flagged judged steps")
    for engine in args.engines.split(","):
        for key in keys[:args.runs]:
            system = system_from_dict(files[key])
            pred = feasible_modes(system, system.mu)
            job = job_for_system(system, engine, pred)
            res = execute(job)
            rec, th = res.recording, job.thresholds
            bodies = job.expectation.bodies
            mask = judged_mask(rec, th)
            flagged = correction_steps(rec, th, bodies)[mask]
            labels = [m.label for m in pred.all_modes] or ["JAM"]
            print(f"{engine} | {key[0]} | {key[1]} | {' / '.join(labels)} | "
                  f"{res.verdict.outcome.value} | {correction_ratio(rec, th, bodies):.3g} | "
                  f"{np.mean(flagged) if len(flagged) else 0.0:.1%}", flush=True)


if __name__ == "__main__":
    main()
