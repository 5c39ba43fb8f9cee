"""Engine artefacts measured in one run, and the consensus of several engines' verdicts.

Per run (:func:`engine_measures`, written to ``summary.json`` as ``observed.engine_measures``):
what the engine did that the rigid quasistatic model does not do, measured from the run's own
recording, each against a threshold derived from the judge's and the classifier's settings
(docs/simulation.md, "Engines side by side"):

* **creep** -- a contact the prediction keeps sticking (``R`` in every predicted mode, or in a
  plan segment's claim; a frictionless contact has no stiction and is left out) whose
  window-mean ``|v_t|`` exceeds the classifier's slip threshold on more than
  ``1 - MODE_FRACTION_REQUIRED`` of the judged steps;
* **lift-off** -- a contact the prediction keeps loaded (closed in every predicted mode, and
  loaded by every certificate of each: a force-indeterminate mode may unload a closed contact,
  which the judge accepts) whose window token is ``B`` (mean normal force below the
  classifier's force floor) on more than that fraction;
* **chatter** -- a contact whose per-step token (:func:`sim.classify.raw_tokens`) changes more
  often than once per classifier window on average over the judged steps: a quasistatic run
  changes modes only at predicted events, and the window mean reads one mode per window;
* **penetration** -- the deepest contact deeper than ``2 x pre-load + slip_speed x window``
  (the pre-load is half the collision slop a rigid contact rests within; beyond it, the sink
  is larger than the distance the classifier resolves as rest in one window) on more than
  ``1 - MODE_FRACTION_REQUIRED`` of the judged steps;
* **capped solves** -- a backend that counts contact solves stopped at an iteration cap
  (``unconverged`` of ``solves``: DART) in more than that fraction of its solves: there the
  engine returned no solution of the contact problem.

Each threshold is the point where that effect alone takes more judged steps out of the
predicted mode than the judge allows (``MODE_FRACTION_REQUIRED``), or is below what the
classifier resolves; none depends on an engine or a scene kind.

Across engines (:func:`consensus`, from ``summary.json`` contents): the verdicts side by side;
when a strict majority of engines share a verdict, the others are the odd engines and the
consensus names, for each, the artefacts its run measured -- so an engine's artefact is never
reported as a model error, and an odd verdict with no measured artefact is said to be
unexplained.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.model.modes import BREAK, ROLL
from sim.classify import Thresholds, correction_steps, raw_tokens, window_tokens
from sim.expectation import Expectation, ModeSet, PlanSchedule
from sim.run import Recording
from sim.scene import preload_depth
from sim.verdict import MODE_FRACTION_REQUIRED

#: Judged steps an effect may take out of the predicted mode before it is named as a cause:
#: what the judge itself allows (``1 - MODE_FRACTION_REQUIRED``).
OFF_MODE_FRACTION = 1.0 - MODE_FRACTION_REQUIRED
#: Engine names as printed.
ENGINE_TITLES = {"pymunk": "pymunk", "mujoco": "MuJoCo", "dart": "DART"}


def title(engine: str) -> str:
    """``pymunk``, ``MuJoCo``, ``DART`` (an unknown name as given)."""
    return ENGINE_TITLES.get(engine, engine)


def _contact_roles(expectation: Expectation, n_pairs: int, times: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``(stick, closed)``, each (T, P) bool: the steps at which the prediction keeps a pair
    sticking (``R`` with friction) / loaded (closed, ``R`` or ``S``, in every predicted mode,
    and no member of any predicted mode's certificate family unloads it -- a
    force-indeterminate mode may leave a closed contact without load, which the judge accepts,
    :func:`planner.predict.family.admits_unloaded`). A predicted jam, a static system
    predicted to move and a ruler (its sticking finger alternates) keep none."""
    T = len(times)
    stick = np.zeros((T, n_pairs), dtype=bool)
    closed = np.zeros((T, n_pairs), dtype=bool)
    if isinstance(expectation, ModeSet) and expectation.modes:
        codes = np.array([m.mode.codes for m in expectation.modes])  # (n_modes, n_c)
        n = min(codes.shape[1], n_pairs)
        rough = np.ones(n, dtype=bool)
        if expectation.system is not None:
            rough = np.asarray(expectation.system.mu, dtype=float)[:n] > 0
        stick[:, :n] = np.all(codes[:, :n] == ROLL, axis=0) & rough
        loaded = np.all(codes[:, :n] != BREAK, axis=0)
        if expectation.system is not None:
            from planner.predict.family import admits_unloaded

            for j in np.flatnonzero(loaded):
                loaded[j] = not any(admits_unloaded(expectation.system, m.mode, [int(j)])
                                    for m in expectation.modes)
        closed[:, :n] = loaded
    elif isinstance(expectation, PlanSchedule):
        starts = [seg.start for seg in expectation.segments] + [np.inf]
        for k, seg in enumerate(expectation.segments):
            rows = (times >= seg.start - 1e-12) & (times < starts[k + 1] - 1e-12)
            for pos, col in enumerate(seg.pairs):
                if pos in seg.gained or col >= n_pairs:
                    continue  # a gained contact is judged once it touches
                code = seg.claim.codes[pos]
                stick[rows, col] = code == ROLL
                closed[rows, col] = code != BREAK
    return stick, closed


def _changes(tokens: np.ndarray) -> np.ndarray:
    """(P,) how many times each column of ``tokens`` (T, P) changes from step to step."""
    if len(tokens) < 2:
        return np.zeros(tokens.shape[1], dtype=int)
    return np.sum(tokens[1:] != tokens[:-1], axis=0)


def engine_measures(rec: Recording, expectation: Expectation, th: Thresholds, *,
                    length_scale: float, capped_solves: int | None = None,
                    solves: int | None = None) -> dict[str, Any]:
    """The engine artefacts of one run (module docstring), JSON-ready.

    ``rec`` in user units; ``th`` the run's thresholds; ``length_scale`` [m] the scene's (its
    pre-load is :func:`sim.scene.preload_depth` of it); ``capped_solves`` of ``solves``: the
    backend's count of contact solves stopped at their iteration cap, of all its contact
    solves in the run (``None``: the engine does not count them).

    Returns ``thresholds`` (what each effect is compared with), per pair ``creep`` (window-mean
    ``|v_t|`` above the slip threshold: fraction of judged steps, median speed there [m/s]),
    ``lift_off`` (fraction), ``chatter`` (per-step token changes), ``max_depth_m``,
    ``deep_fraction``, ``mode_changes`` (observed window-mode changes on judged steps),
    ``capped_fraction``, ``correction_fraction`` (judged steps on which a workpiece moved
    by position correction, :func:`sim.classify.correction_steps`) and ``artefacts``: the
    effects above their thresholds, each ``{"kind", "contact", "value", "threshold", "text"}``.
    """
    judged = rec.times >= th.settle - 1e-12
    n_judged = int(judged.sum())
    names = rec.pair_names
    P = len(names)
    span = float(rec.times[judged][-1] - rec.times[judged][0]) if n_judged > 1 else 0.0
    depth_limit = 2.0 * preload_depth(length_scale) + th.slip_speed * th.window
    chatter_limit = span / th.window
    out: dict[str, Any] = {
        "thresholds": {"slip_speed_m_per_s": th.slip_speed, "force_floor_N": th.force_floor,
                       "off_mode_fraction": OFF_MODE_FRACTION,
                       "chatter_changes": chatter_limit, "depth_m": depth_limit},
        "judged_steps": n_judged, "creep": {}, "lift_off": {}, "chatter": {},
        "max_depth_m": 0.0, "deepest": None, "deep_fraction": 0.0, "mode_changes": 0,
        "capped_solves": capped_solves, "capped_fraction": None, "artefacts": []}
    arts: list[dict[str, Any]] = out["artefacts"]
    if capped_solves is not None and solves:
        frac = capped_solves / float(solves)
        out["capped_fraction"] = frac
        if frac > OFF_MODE_FRACTION:
            arts.append({"kind": "capped_solves", "contact": None, "value": frac,
                         "threshold": OFF_MODE_FRACTION,
                         "text": f"{frac:.0%} of the contact solves stopped at the iteration "
                                 f"cap (no solution of the contact problem there)"})
    if n_judged == 0 or P == 0:
        return out
    win = window_tokens(rec, th)[judged]
    raw = raw_tokens(rec, th)[judged]
    slip = np.abs(_window_slip(rec, th))[judged]
    stick, closed = _contact_roles(expectation, P, rec.times)
    stick, closed = stick[judged], closed[judged]
    out["mode_changes"] = int(np.sum(np.any(win[1:] != win[:-1], axis=1))) if n_judged > 1 \
        else 0
    for j, nm in enumerate(names):
        if stick[:, j].any():
            moving = stick[:, j] & (slip[:, j] > th.slip_speed)
            frac = float(moving.sum() / n_judged)
            speed = float(np.median(slip[moving, j])) if moving.any() else 0.0
            out["creep"][nm] = {"fraction": frac, "speed_m_per_s": speed}
            if frac > OFF_MODE_FRACTION:
                arts.append({"kind": "creep", "contact": nm, "value": speed,
                             "threshold": th.slip_speed,
                             "text": f"contact {nm}, predicted to stick, slipped at "
                                     f"{speed:.2g} m/s ({speed / th.slip_speed:.1f} x the slip "
                                     f"threshold {th.slip_speed:.2g} m/s) on {frac:.0%} of "
                                     f"the judged steps"})
        if closed[:, j].any():
            frac = float(np.sum(closed[:, j] & (win[:, j] == "B")) / n_judged)
            out["lift_off"][nm] = frac
            if frac > OFF_MODE_FRACTION:
                arts.append({"kind": "lift_off", "contact": nm, "value": frac,
                             "threshold": OFF_MODE_FRACTION,
                             "text": f"contact {nm}, predicted to carry load, carried none "
                                     f"on {frac:.0%} of the judged steps"})
    changes = _changes(raw)
    for j, nm in enumerate(names):
        out["chatter"][nm] = int(changes[j])
    j = int(np.argmax(changes))
    if changes[j] > chatter_limit:
        arts.append({"kind": "chatter", "contact": names[j], "value": int(changes[j]),
                     "threshold": chatter_limit,
                     "text": f"contact {names[j]} changed its per-step mode {changes[j]} times "
                             f"in {span:.2g} s (more than once per {th.window:g} s "
                             f"classifier window: {chatter_limit:.0f})"})
    depth = np.where(rec.present, rec.depth, 0.0)[judged]
    deepest = np.max(depth, axis=1)
    k = int(np.argmax(deepest))
    out["max_depth_m"] = float(deepest[k])
    out["deepest"] = names[int(np.argmax(depth[k]))]
    deep = float(np.mean(deepest > depth_limit))
    out["deep_fraction"] = deep
    if deep > OFF_MODE_FRACTION:
        arts.append({"kind": "penetration", "contact": out["deepest"], "value": deepest[k],
                     "threshold": depth_limit,
                     "text": f"contacts sank deeper than {depth_limit:.2g} m on {deep:.0%} of "
                             f"the judged steps (deepest {deepest[k]:.2g} m, contact "
                             f"{out['deepest']})"})
    bodies = tuple(getattr(expectation, "bodies", ()) or ())
    flagged = correction_steps(rec, th, bodies)[judged] if bodies else np.zeros(0, bool)
    moved = float(np.mean(flagged)) if len(flagged) else 0.0
    out["correction_fraction"] = moved
    if moved > OFF_MODE_FRACTION:
        arts.append({"kind": "position_correction", "contact": None, "value": moved,
                     "threshold": OFF_MODE_FRACTION,
                     "text": f"the engine moved the workpiece by position correction, not by "
                             f"its velocities, on {moved:.0%} of the judged steps (overlap "
                             f"removed without friction)"})
    return out


def _window_slip(rec: Recording, th: Thresholds) -> np.ndarray:
    """(T, P) window-mean ``v_t`` over the steps each pair touches (the classifier's)."""
    from sim.classify import window_mean

    present = rec.present.astype(float)
    slip = window_mean(rec.slip_velocity, present, rec.times, th.window)
    return np.nan_to_num(slip, nan=0.0)


# ---- several engines --------------------------------------------------------------------------
@dataclass(frozen=True)
class Consensus:
    """Verdicts of several engines on one question (module docstring).

    ``verdicts``: engine -> status (``agreed``, ``disagreed``, ``inconclusive``, ``fault``);
    ``majority``: the status a strict majority of the engines share (``None``: none does);
    ``odd``: the engines outside it; ``causes``: per engine, the texts of its run's measured
    artefacts (its fault first); ``explained``: every odd engine has one. The artefacts of the
    majority's own runs are reported too: a majority whose runs measured artefacts is weaker
    evidence than one whose runs are clean."""

    verdicts: dict[str, str]
    majority: str | None
    odd: tuple[str, ...]
    causes: dict[str, tuple[str, ...]]

    @property
    def majority_causes(self) -> dict[str, tuple[str, ...]]:
        """Measured artefacts of the engines in the majority (those with any)."""
        return {e: c for e, c in self.causes.items() if e not in self.odd and c}

    @property
    def unanimous(self) -> bool:
        return len(set(self.verdicts.values())) <= 1

    @property
    def explained(self) -> bool:
        return bool(self.odd) and all(self.causes.get(e) for e in self.odd)

    @property
    def text(self) -> str:
        """One sentence for a report."""
        if self.unanimous:
            status = next(iter(self.verdicts.values()), "no run")
            return f"all engines {status}" if len(self.verdicts) > 1 else status
        sides = "; ".join(f"{title(e)} {s}" for e, s in self.verdicts.items())
        if self.majority is None:
            parts = [f"engines disagree with each other, no majority ({sides})"]
            parts += [f"{title(e)} measured: {'; '.join(c)}" for e, c in self.causes.items()
                      if c]
            return ". ".join(parts)
        parts = [f"consensus {self.majority} ({sides}); odd engine: "
                 + ", ".join(title(e) for e in self.odd)]
        for e in self.odd:
            c = self.causes.get(e)
            parts.append(f"{title(e)}'s run measured {'; '.join(c)} -- an engine artefact"
                         if c else f"{title(e)}'s run measured no engine artefact: its "
                                   f"verdict is unexplained (a model error is not excluded)")
        weak = self.majority_causes
        if weak:
            parts.append("The majority's runs measured artefacts too ("
                         + "; ".join(f"{title(e)}: {'; '.join(c)}" for e, c in weak.items())
                         + ")")
        return ". ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        return {"verdicts": dict(self.verdicts), "majority": self.majority,
                "odd": list(self.odd), "unanimous": self.unanimous,
                "explained": self.explained,
                "causes": {e: list(c) for e, c in self.causes.items()}, "text": self.text}


def artefact_texts(summary: Mapping[str, Any]) -> tuple[str, ...]:
    """A summary's fault and measured artefacts, as texts (older summaries: the fault only)."""
    obs = summary.get("observed") or {}
    texts = []
    if summary.get("status") == "fault" or obs.get("fault"):
        texts.append(f"fault: {obs.get('fault') or summary.get('reason')}")
    measures = obs.get("engine_measures") or {}
    texts += [a["text"] for a in measures.get("artefacts", [])]
    return tuple(texts)


def consensus_of(verdicts: Mapping[str, str],
                 causes: Mapping[str, Sequence[str]] | None = None) -> Consensus:
    """The consensus of ``verdicts`` (engine -> status), with each engine's measured
    artefact texts ``causes``."""
    causes = causes or {}
    counts = Counter(verdicts.values())
    top, n = counts.most_common(1)[0] if counts else (None, 0)
    majority = top if n * 2 > len(verdicts) and len(verdicts) > 1 else None
    if len(counts) <= 1:
        majority = top
    odd = tuple(e for e, s in verdicts.items() if majority is not None and s != majority)
    return Consensus(dict(verdicts), majority, odd,
                     {e: tuple(causes.get(e, ())) for e in verdicts})


def consensus(summaries: Sequence[Mapping[str, Any]]) -> Consensus:
    """The consensus of the runs of one question in several engines (``summary.json``
    contents, :meth:`sim.summary.RunSummary.to_dict`), from their statuses and measured
    artefacts."""
    verdicts = {str(s["engine"]): str(s["status"]) for s in summaries}
    return consensus_of(verdicts, {str(s["engine"]): artefact_texts(s) for s in summaries})


def segment_consensus(summaries: Sequence[Mapping[str, Any]]) -> list[Consensus]:
    """Per plan segment (``segments`` of each summary, matched by number), the consensus of
    the engines that reached it; the causes are the whole runs' artefacts."""
    numbers = sorted({row["segment"] for s in summaries for row in s.get("segments", [])})
    out = []
    for k in numbers:
        verdicts = {str(s["engine"]): str(row["status"]) for s in summaries
                    for row in s.get("segments", []) if row["segment"] == k}
        out.append(consensus_of(verdicts, {str(s["engine"]): artefact_texts(s)
                                           for s in summaries}))
    return out
