"""The ruler (Sec. 5.1) against its closed-form theory on both engines.

For several static/kinetic pairs and start layouts, run the ruler in slow motion and compare the
first five switch positions with ``rho^k b`` (:mod:`sim.scenes.ruler_theory`). A layout/pair
passes when 5 switches are seen, the sliding finger alternates as predicted and every relative
error is <= 2 %; otherwise it is reported ``disagreed`` -- or ``inconclusive`` when the sticking
finger's measured creep (mean |v_t| of the non-sliding finger) exceeds a tenth of the slip
threshold, i.e. the engine cannot hold a static contact well enough to tell.

    python benchmarks/ruler_theory.py --engine pymunk
    python benchmarks/ruler_theory.py --engine mujoco --quick
"""

from __future__ import annotations

import argparse
import json

from sim.scenes.ruler_theory import SETTINGS, run_case

PAIRS = ((0.5, 0.3), (0.8, 0.6), (0.8, 0.5), (0.6, 0.4))
LAYOUTS = ((-0.4, 0.25), (-0.2, 0.35), (-0.35, 0.3))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="pymunk", choices=sorted(SETTINGS))
    ap.add_argument("--quick", action="store_true", help="2 pairs x 2 layouts")
    ap.add_argument("--json", help="write the rows to this file")
    args = ap.parse_args()
    pairs = PAIRS[:2] if args.quick else PAIRS
    layouts = LAYOUTS[:2] if args.quick else LAYOUTS
    rows = []
    for mu_s, mu_k in pairs:
        for left, right in layouts:
            r = run_case(args.engine, mu_s, mu_k, left, right)
            rows.append(r)
            errs = " ".join(f"{e:.4f}" for e in r["relative_errors"])
            print(f"{args.engine:7s} mu {mu_s}/{mu_k} layout ({left}, {right}): {r['status']:12s} "
                  f"switches {len(r['observed_m'])} errors [{errs}] creep "
                  f"{r['creep_m_per_s']:.2g} m/s, contacts missing "
                  f"{r['contact_lost_fraction']:.1%}  {r['wall_s']:.1f} s", flush=True)
            if r["cause"]:
                print(f"        cause: {r['cause']}")
    counts = {s: sum(r["status"] == s for r in rows)
              for s in ("agreed", "disagreed", "inconclusive", "fault")}
    print(json.dumps(counts))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
