"""The JSON Schemas of the file formats, shipped in ``planner/files/schemas/``.

One schema per format: ``system`` (:mod:`planner.files.system_file`), ``hand``
(:mod:`planner.files.hand_file`) and ``plan`` (:mod:`planner.plan.plan_file`; it refers to the
hand schema by ``$id``).  They document the formats and let other tools check a file; the
loaders keep their own checks (and messages that say what was expected and what came) and check
more than a schema can (digests, geometry, counts that must match).  The test suite validates
every shipped file and the documentation's examples against them with the ``jsonschema``
package and checks that loader and schema agree on good and bad documents.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.files.reader import read_json

#: Folder of the shipped schemas (``<kind>.schema.json``).
SCHEMA_DIR = Path(__file__).resolve().parent / "schemas"

#: The formats that have a schema.
SCHEMA_KINDS = ("system", "hand", "plan", "run-summary")


def schema_path(kind: str) -> Path:
    """Path of the shipped schema of ``kind`` (one of :data:`SCHEMA_KINDS`)."""
    if kind not in SCHEMA_KINDS:
        raise InputError(f"schema: expected one of {SCHEMA_KINDS}, got {kind!r}")
    return SCHEMA_DIR / f"{kind}.schema.json"


def load_schema(kind: str) -> dict[str, Any]:
    """The schema of ``kind`` as a JSON object (read through the one JSON reader)."""
    data = read_json(schema_path(kind), "schema")
    if not isinstance(data, dict):  # a shipped file: never expected to happen
        raise InputError(f"schema {kind}: expected a JSON object, got {type(data).__name__}")
    return data
