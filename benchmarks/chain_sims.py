"""Chain manipulators in both simulators: every case, its negative control.

* Plans of the chain-finger hands (``plan_segment`` on the hand file's segment and
  friction interval) run at the interval's ends and middle on both engines
  (:func:`scenarios.runs.validate_plan`), and once with torques outside every region
  (:func:`planner.plan.negative_controls.outside_torques`) or, for a hand without an effort
  joint, at friction outside the box where the planner predicts a rival;
* the chain systems of ``tests/data`` through ``simulate_system`` (as ``qsplan simulate``),
  and judged at the friction of their negative control.

Writes a JSON list of rows (atomically) and prints a table. Nothing is asserted here; the tests
(tests/sim/test_chain_hands_sim.py, tests/sim/test_simulate_chain.py) hold the verdicts.

    PYTHONPATH=. python benchmarks/chain_sims.py --out benchmarks/results/chain_sims.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from planner.files.atomic import atomic_write_json
from planner.files.hand_file import load_hand_file
from planner.files.system_file import load_system
from planner.plan.negative_controls import outside_torques
from planner.plan.segment_planner import plan_segment
from scenarios.runs import simulate_system, validate_plan
from sim.settings import ENGINES

ROOT = Path(__file__).resolve().parents[1]
HANDS = ("prismatic_finger_hand", "two_link_finger_hand", "three_finger_hand",
         "table_push_hand")
#: chain system file -> judging friction of its negative control (tests/sim/test_simulate_chain.py)
SYSTEMS = {"two_link_finger_box": [2.0, 2.0, 0.0], "prismatic_finger_box": [2.0, 2.0, 0.0],
           "two_link_effort_finger_box": [2.0, 2.0, 0.5]}
#: friction of the velocity-only hand's negative control (tests/sim/test_chain_hands_sim.py)
VELOCITY_ONLY_NEGATIVE = [0.4, 0.4, 2.0]


def _plan_row(name, rp, engine, mu, run, wall, kind="plan"):
    pm = run.verdict.plan
    return {"case": name, "kind": kind, "engine": engine, "mu": mu, "claim": rp.claim,
            "velocity_joints": list(rp.velocity_joints),
            "effort_joints": list(rp.effort_joints), "status": run.verdict.outcome.value,
            "claim_fraction": None if pm is None else pm.claim_fraction,
            "final_error_of_travel": None if pm is None else pm.final_error / pm.travel,
            "slow_motion": run.summary.parameters["slow_motion"], "wall_s": round(wall, 2)}


def hand_rows(engines=ENGINES):
    rows = []
    for name in HANDS:
        hf = load_hand_file(ROOT / "scenarios" / "data" / f"{name}.json")
        s = hf.segment
        mu = [list(p) for p in hf.mu_interval]
        rp = plan_segment(hf.hand, hf.q0, data=hf.data, drive=s.drives, speed=s.speeds,
                          mode=s.mode, mu=mu if len(mu) > 1 else mu[0],
                          model="independent" if len(mu) > 1 else "common",
                          max_time=s.max_time, steps=s.steps, waypoints=s.waypoints)
        lo, hi = np.array([p[0] for p in mu]), np.array([p[1] for p in mu])
        for frac in (0.0, 0.5, 1.0):
            m = lo + frac * (hi - lo)
            m_arg = m.tolist() if len(m) > 1 else float(m[0])
            for engine in engines:
                t0 = time.perf_counter()
                run = validate_plan(rp, engine, m_arg)
                rows.append(_plan_row(name, rp, engine, m_arg, run, time.perf_counter() - t0))
                print(rows[-1], flush=True)
        mid = 0.5 * (lo + hi)
        m_arg = mid.tolist() if len(mid) > 1 else float(mid[0])
        for engine in engines:
            t0 = time.perf_counter()
            if rp.effort_joints:
                run = validate_plan(rp, engine, m_arg,
                                    expect="disagree",
                                    torques=outside_torques(rp, hf.hand, m_arg))
                kind = "negative: torques outside the regions"
            else:
                m_arg2 = VELOCITY_ONLY_NEGATIVE
                run = validate_plan(rp, engine, m_arg2,
                                    expect="disagree")
                kind = f"negative: mu {m_arg2}"
            rows.append(_plan_row(name, rp, engine, m_arg, run, time.perf_counter() - t0, kind))
            print(rows[-1], flush=True)
    return rows


def system_rows(engines=ENGINES):
    rows = []
    for name, judge in SYSTEMS.items():
        system = load_system(ROOT / "tests" / "data" / f"{name}.json")
        for engine in engines:
            for jm in (None, judge):
                t0 = time.perf_counter()
                run = simulate_system(system, engine, judge_mu=jm)
                rows.append({"case": name, "engine": engine,
                             "kind": "simulate" if jm is None else f"negative: judge-mu {jm}",
                             "status": run.verdict.outcome.value,
                             "agreement": run.verdict.agreement,
                             "judged_steps": run.verdict.judged_steps,
                             "wall_s": round(time.perf_counter() - t0, 2)})
                print(rows[-1], flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="benchmarks/results/chain_sims.json")
    ap.add_argument("--engines", default=",".join(ENGINES))
    args = ap.parse_args(argv)
    engines = tuple(args.engines.split(","))
    rows = hand_rows(engines) + system_rows(engines)
    atomic_write_json(args.out, rows)
    print(f"{len(rows)} rows -> {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
