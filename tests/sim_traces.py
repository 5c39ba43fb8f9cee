"""Recorded simulator traces (tests/data/sim_trace_*.npz, written by
tests/data/record_sim_traces.py) as :class:`sim.run.Recording` objects, with the planner's
prediction for the same system and friction recomputed (nothing predicted is stored)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from sim_helpers import example

from planner.predict.feasibility import Prediction, feasible_modes
from sim.classify import Thresholds
from sim.expectation import ModeSet
from sim.run import Recording

TRACE_DIR = Path(__file__).resolve().parent / "data"


@dataclass(frozen=True)
class Trace:
    rec: Recording
    meta: dict[str, Any]

    def prediction(self, mu: tuple[float, ...] | None = None) -> Prediction:
        m = self.meta
        system = example(m["data"], m["scale"], m["speed"])
        return feasible_modes(system, tuple(m["mu"]) if mu is None else mu)

    def system(self, mu: tuple[float, ...] | None = None) -> Any:
        """The (scaled) system the trace was recorded from, at its friction or ``mu``."""
        m = self.meta
        return example(m["data"], m["scale"], m["speed"]).with_mu(
            tuple(m["mu"]) if mu is None else mu)

    def expectation(self, modes: Any, mu: tuple[float, ...] | None = None,
                    system: Any = None) -> ModeSet:
        """The expectation of judging the trace against ``modes`` of its system at ``mu``
        (or of ``system``)."""
        m = self.meta
        return ModeSet(tuple(modes), system if system is not None else self.system(mu), 1.0,
                       ("workpiece",), m["speed"], m["length_scale"], m["load"])

    def thresholds(self, **kw: Any) -> Thresholds:
        m = self.meta
        # judge from the later of the engine's settling time and one window after the cut
        settle = max(m["settle"], m["start"] + 0.1)
        return Thresholds.for_drive(m["speed"], m["load"], creep_floor=m["creep"],
                                    settle=settle, jam_force=20.0 * m["load"],
                                    length_scale=m["length_scale"], **kw)


def _recording(path: Path) -> tuple[Recording, dict[str, Any]]:
    """A recorded trace file (``times``, ``poses``, ``present``, ``fn``, ``ft``, ``vt``,
    ``depth``, ``meta``) as a :class:`Recording` of one workpiece and its contacts, with its
    ``meta``."""
    d = np.load(path)
    meta = json.loads(str(d["meta"]))
    T, P = d["vt"].shape
    z = np.zeros((T, P))
    rec = Recording(
        engine=meta["engine"], pair_names=tuple(f"c{i + 1}" for i in range(P)),
        body_names=("workpiece",), times=np.asarray(d["times"], dtype=float),
        poses=np.asarray(d["poses"], dtype=float).reshape(T, 1, 3),
        present=np.asarray(d["present"], dtype=bool),
        points=(np.asarray(d["points"], dtype=float) if "points" in d
                else np.full((T, P, 2), np.nan)),
        normals=np.zeros((T, P, 2)), normal_force=np.asarray(d["fn"], dtype=float),
        tangent_force=np.asarray(d["ft"], dtype=float),
        slip_velocity=np.asarray(d["vt"], dtype=float),
        depth=np.asarray(d["depth"], dtype=float), mu_used=z)
    return rec, meta


def load_trace(name: str) -> Trace:
    return Trace(*_recording(TRACE_DIR / f"sim_trace_{name}.npz"))


def load_plan_trace(name: str) -> tuple[Recording, dict[str, Any]]:
    """A recorded plan run (tests/data/plan_trace_*.npz, written by
    tests/data/record_plan_traces.py) as a :class:`Recording` of its workpiece and contacts,
    with its ``meta``."""
    return _recording(TRACE_DIR / f"plan_trace_{name}.npz")


@dataclass(frozen=True)
class CampaignTrace:
    """A validation campaign's run stored whole (tests/data/campaign_trace_*.npz, written by
    tests/data/record_sim_traces.py): the recording, and the expectation and thresholds
    rebuilt as ``qsplan simulate`` builds them (:func:`sim.jobs.job_for_system`) from the row's
    system file and friction -- the planner predicts again; nothing predicted is stored."""

    rec: Recording
    meta: dict[str, Any]

    def system(self) -> Any:
        from planner.files.system_file import system_from_dict

        return system_from_dict(self.meta["file"]).with_mu(np.asarray(self.meta["mu"]))

    def job(self) -> Any:
        from sim.jobs import job_for_system

        system = self.system()
        return job_for_system(system, self.meta["engine"], feasible_modes(system))

    def expectation(self) -> ModeSet:
        """The prediction at the run's own friction (the point judged)."""
        exp: ModeSet = self.job().expectation
        return exp

    def control(self) -> ModeSet:
        """The campaign's negative control: the prediction at ``control_mu`` of the system (or
        of its mirror image), whose modes share none with the point's."""
        from dataclasses import replace

        from planner.files.system_file import system_from_dict
        from planner.sweeps.user_files import mirror_system

        data = self.meta["file"]
        if self.meta.get("control_system") == "mirror image":
            data = mirror_system(data)
        control = system_from_dict(data).with_mu(np.asarray(self.meta["control_mu"]))
        exp = self.expectation()
        modes = tuple(feasible_modes(control).all_modes)
        assert not set(m.label for m in modes) & set(exp.labels)
        return replace(exp, modes=modes, system=control)

    def thresholds(self) -> Thresholds:
        th: Thresholds = self.job().thresholds
        return th


def load_campaign_trace(name: str) -> CampaignTrace:
    """``tests/data/campaign_trace_<name>.npz`` as a :class:`CampaignTrace` (its workpieces'
    poses; the contacts' readings and points)."""
    d = np.load(TRACE_DIR / f"campaign_trace_{name}.npz")
    meta = json.loads(str(d["meta"]))
    T, P = d["vt"].shape
    rec = Recording(
        engine=meta["engine"], pair_names=tuple(f"c{i + 1}" for i in range(P)),
        body_names=tuple(meta["bodies"]), times=np.asarray(d["times"], dtype=float),
        poses=np.asarray(d["poses"], dtype=float), present=np.asarray(d["present"], dtype=bool),
        points=np.asarray(d["points"], dtype=float), normals=np.zeros((T, P, 2)),
        normal_force=np.asarray(d["fn"], dtype=float),
        tangent_force=np.asarray(d["ft"], dtype=float),
        slip_velocity=np.asarray(d["vt"], dtype=float),
        depth=np.asarray(d["depth"], dtype=float), mu_used=np.zeros((T, P)))
    return CampaignTrace(rec, meta)
