"""The one ``summary.json`` of every simulator run (system, plan, ruler; its JSON Schema:
``planner/files/schemas/run-summary.schema.json``, docs/file-formats.md).

Top level: what ran (``name``, ``kind``, ``engine``, ``source``), what was expected
(``expect``) and whether it held (``passed``), the verdict's fields (``status`` -- its outcome
-- ``agreement``, ``judged_steps``, ``reason``, ``reasons``, ``observed_counts``, ``fault``,
``fault_kind``, and a plan segment's or a system run's measures), then four sections:
``parameters`` (friction, scale, speeds, thresholds, engine settings: everything the run used),
``predicted`` (what the planner predicted), ``observed`` (what the run showed) and
``segments`` (a plan's verdict per segment; empty otherwise), and ``files`` (names of the
written pictures, relative to the summary's folder) and ``wall_time_s``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from sim.verdict import Expect, Verdict

#: Version of the summary layout (the schema's ``version``).
SUMMARY_VERSION = 2


@dataclass(frozen=True, eq=False)
class RunSummary:
    """One run's summary (module docstring)."""

    name: str
    kind: str
    engine: str
    source: str | None
    expect: Expect
    verdict: Verdict
    parameters: dict[str, Any]
    predicted: dict[str, Any]
    observed: dict[str, Any]
    segments: tuple[dict[str, Any], ...] = ()
    files: dict[str, str] = field(default_factory=dict)
    wall_time_s: float = 0.0

    @property
    def passed(self) -> bool:
        """The expectation held (a fault or an inconclusive run never passes)."""
        return self.verdict.held(self.expect)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready content of ``summary.json``."""
        return {"version": SUMMARY_VERSION, "name": self.name, "kind": self.kind,
                "engine": self.engine, "source": self.source, "expect": self.expect.value,
                "passed": self.passed, **self.verdict.to_dict(),
                "parameters": self.parameters, "predicted": self.predicted,
                "observed": self.observed, "segments": list(self.segments),
                "files": dict(self.files), "wall_time_s": self.wall_time_s}
