"""Fuzzing the plan-file loader (``planner.plan.plan_file.load_plan``): only documented errors may escape,
and a tampered plan is never accepted.

A valid plan (the two-finger hand of ``scenarios/data/two_finger_hand.json``, Sec. 5.2, planned
once per session) is mutated three ways (mutation helpers from ``tests/planner/test_fuzz.py``):

* *stale digest*: values changed, keys deleted, wrong types, NaN, huge numbers, deep nesting --
  but the SHA-256 digest left as written. The loader must reject every change of the content;
  if it accepts a mutated file, the plan it returns must equal the original.
* *re-signed*: the same mutations with the digest recomputed (anyone can do that: the digest is
  tamper-evident, not a signature), so the field checks behind the digest are exercised.
* *bytes*: the file text truncated, bit-flipped, spiked with non-UTF-8 bytes, NaN/Infinity
  literals, a byte-order mark, deep nesting, trailing garbage.

A short run is part of the default suite; ``-m slow`` runs 10,000 inputs per kind.
"""

from __future__ import annotations

import copy
import functools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fuzz import NASTY_VALUES, _deep, mutate_text, mutate_tree

from planner import QsplanError
from planner.errors import FileFormatError
from planner.plan.model import Plan
from planner.plan.plan_file import digest, load_plan, plan_from_dict, plans_equal, save_plan
from scenarios.registry import DATA_DIR

HAND_FILE = DATA_DIR / "two_finger_hand.json"

FAST = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
LONG = settings(max_examples=10_000, deadline=None, suppress_health_check=list(HealthCheck))


@functools.lru_cache(maxsize=1)
def _base_plan() -> Plan:
    from planner.plan.hand_planner import plan_hand

    return plan_hand(HAND_FILE, waypoints=5)


def valid_plan_file(folder: Path) -> Path:
    """Write the session's valid plan into ``folder`` (atomically, by ``save_plan``)."""
    return save_plan(_base_plan(), Path(folder) / "valid_plan.json")


def same_plan_content(plan: Plan, base_path: Path) -> bool:
    """True when ``plan`` has the canonical content of the plan stored at ``base_path``."""
    return plans_equal(plan, load_plan(base_path))


def resign(data: Any) -> Any:
    """Recompute the digest of a (mutated) plan dict; leaves it stale when the content cannot
    be hashed (NaN, too deep) or the dict has no place for a digest."""
    if not isinstance(data, dict):
        return data
    body = {k: v for k, v in data.items() if k != "digest"}
    try:
        data["digest"] = {"algorithm": "sha256", "value": digest(body)}
    except (ValueError, RecursionError):
        pass
    return data


@pytest.fixture(scope="module")
def plan_path(tmp_path_factory) -> Path:
    return valid_plan_file(tmp_path_factory.mktemp("plan"))


@pytest.fixture(scope="module")
def plan_dict(plan_path) -> dict:
    return json.loads(plan_path.read_text())


def _write(path: Path, data: Any) -> Path:
    try:
        text = json.dumps(data, indent=1)
    except RecursionError:
        text = "[" * 100_000
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    return path


def _load_documented(path: Path) -> Plan | None:
    try:
        return load_plan(path)
    except QsplanError:
        return None


# ---------------------------------------------------------------------------------------------
def test_valid_plan_round_trips(plan_path, tmp_path):
    plan = load_plan(plan_path)
    again = load_plan(save_plan(plan, tmp_path / "again.json"))
    assert plans_equal(plan, again) and plans_equal(plan, _base_plan())
    seg = plan.segments[0]
    assert len(seg.waypoints) == 5 and all(math.isfinite(t) for t in seg.times())
    assert not list(tmp_path.glob(".*.tmp"))  # no temporary file left behind


def _stale_case(seed: int, base: dict, base_path: Path, folder: Path) -> None:
    rng = np.random.default_rng(seed)
    data = mutate_tree(base, rng)
    loaded = _load_documented(_write(folder / "stale.json", data))
    if loaded is not None:  # only a change the digest does not cover may pass
        assert same_plan_content(loaded, base_path), f"tampered plan accepted (seed {seed})"


def _resigned_case(seed: int, base: dict, folder: Path) -> None:
    rng = np.random.default_rng(seed)
    data = resign(mutate_tree(base, rng))
    loaded = _load_documented(_write(folder / "resigned.json", data))
    if loaded is not None:
        assert isinstance(loaded, Plan)
        for seg in loaded.segments:
            assert np.all(np.isfinite(seg.poses())) and np.all(np.diff(seg.times()) > 0)
            assert seg.joint_commands().shape == (len(seg.waypoints), len(seg.control))


def _bytes_case(seed: int, base_path: Path, folder: Path) -> None:
    rng = np.random.default_rng(seed)
    path = folder / "bytes.json"
    path.write_bytes(mutate_text(base_path.read_text(), rng))
    loaded = _load_documented(path)
    if loaded is not None:
        assert same_plan_content(loaded, base_path), f"corrupted plan accepted (seed {seed})"


@FAST
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_stale_digest(plan_dict, plan_path, tmp_path_factory, seed):
    _stale_case(seed, plan_dict, plan_path, tmp_path_factory.getbasetemp())


@FAST
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_resigned(plan_dict, tmp_path_factory, seed):
    _resigned_case(seed, plan_dict, tmp_path_factory.getbasetemp())


@FAST
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_bytes(plan_path, tmp_path_factory, seed):
    _bytes_case(seed, plan_path, tmp_path_factory.getbasetemp())


def test_mutations_bite(plan_dict, plan_path, tmp_path):
    """The fuzzer's stale-digest mutations are rejected for the digest, re-signed ones mostly
    pass the digest and are rejected by the field checks (so both layers are exercised)."""
    rng = np.random.default_rng(1)
    reasons: dict[str, int] = {}
    for k in range(150):
        data = mutate_tree(plan_dict, rng)
        if k % 2:
            resign(data)
        try:
            load_plan(_write(tmp_path / "m.json", data))
            reasons["accepted"] = reasons.get("accepted", 0) + 1
        except FileFormatError as exc:
            key = "digest" if "digest mismatch" in str(exc) else "field"
            reasons[key] = reasons.get(key, 0) + 1
    assert reasons.get("digest", 0) > 20 and reasons.get("field", 0) > 20, reasons


# ---------------------------------------------------------------------------------------------
# Targeted cases with the messages users see.
# ---------------------------------------------------------------------------------------------
def _edited(plan_dict: dict, edit, sign: bool) -> dict:
    d = copy.deepcopy(plan_dict)
    edit(d)
    return resign(d) if sign else d


def _seg(d: dict) -> dict:
    return d["segments"][0]


def _wps(d: dict) -> list:
    return d["segments"][0]["waypoints"]


@pytest.mark.parametrize("edit,sign,match", [
    (lambda d: _wps(d)[2].__setitem__("torque_commands", [0.123]), False, "digest mismatch"),
    (lambda d: _wps(d)[2]["pose"].__setitem__(0, 1.0), False, "digest mismatch"),
    (lambda d: _seg(d).__setitem__("claim", "R1 R2 B3 B4"), False, "digest mismatch"),
    (lambda d: d["mu"]["intervals"].pop(), False, "digest mismatch"),
    (lambda d: d.pop("digest"), False, "expected key 'digest'"),
    (lambda d: d.__setitem__("version", 4), True, "expected plan version 1, 2, 3, got 4"),
    (lambda d: d.__setitem__("version", "3"), True, "expected plan version 1, 2, 3, got '3'"),
    (lambda d: d.__setitem__("format", "qsplan-system"), True, "expected format 'qsplan-plan'"),
    (lambda d: _wps(d)[1].__setitem__("t", "1.0"), True, "expected a finite number"),
    (lambda d: _wps(d)[1].__setitem__("t", 1e308), True, "strictly increasing"),
    (lambda d: _wps(d)[1].__setitem__("pose", [0.0, 0.0]), True, "list of 3 numbers"),
    (lambda d: _wps(d)[1].__setitem__("bands", [[1.0, -1.0]]), True, "lower <= upper"),
    (lambda d: _wps(d)[1].__setitem__("predicted", [None]), True, "list of strings"),
    (lambda d: _seg(d).__setitem__("waypoints", _wps(d)[:1]), True, ">= 2 waypoints"),
    (lambda d: d["mu"].__setitem__("intervals", [[0.2, 0.1]]), True, "0 <= lo <= hi"),
    (lambda d: d["mu"].__setitem__("validate", [-0.1]), True, "coefficients >= 0"),
    (lambda d: _seg(d).__setitem__("control", ["effort", "effort"]), True,
     "at least one 'velocity'"),
    (lambda d: _seg(d).__setitem__("exact", 1), True, "expected true or false"),
    (lambda d: d["hand"].__setitem__("workpiece", 7), True, r"segments\[0\]\.hand: expected a "
                                                             "hand file"),
])
def test_targeted_plan_edits(plan_dict, tmp_path, edit, sign, match):
    path = _write(tmp_path / "edited.json", _edited(plan_dict, edit, sign))
    with pytest.raises(FileFormatError, match=match):
        load_plan(path)


@pytest.mark.parametrize("blob,match", [
    (b"", "expected valid JSON"),
    (b"\xff\xfe{}", "expected UTF-8 text"),
    (b"[" * 200_000 + b"]" * 200_000, "expected JSON nested at most 64 deep"),
    (b'{"format": "qsplan-plan", "version": NaN}', "got the constant NaN"),
    (b"[]", "expected a JSON object, got list"),
])
def test_plan_file_level_garbage(tmp_path, blob, match):
    path = tmp_path / "bad.json"
    path.write_bytes(blob)
    with pytest.raises(FileFormatError, match=match):
        load_plan(path)


def test_truncated_plan_is_rejected(plan_path, tmp_path):
    raw = plan_path.read_bytes()
    for cut in (1, len(raw) // 3, len(raw) // 2, len(raw) - 3):
        path = tmp_path / "cut.json"
        path.write_bytes(raw[:cut])
        with pytest.raises(FileFormatError, match="expected valid JSON, got a syntax error"):
            load_plan(path)


def test_missing_plan_file(tmp_path):
    with pytest.raises(QsplanError, match="plan file .*: expected an existing file"):
        load_plan(tmp_path / "nope.json")


def test_loader_never_executes_content(plan_dict, tmp_path):
    """Strings that would run code under eval/pickle stay inert strings."""
    marker = tmp_path / "executed"
    payload = f"__import__('pathlib').Path({str(marker)!r}).touch()"
    d = resign(_edited(plan_dict, lambda d: d.__setitem__("notes", payload), sign=False))
    plan = load_plan(_write(tmp_path / "payload.json", d))
    assert plan.notes == payload and not marker.exists()
    (tmp_path / "pickle.json").write_bytes(b"\x80\x04\x95" + b"cos\nsystem\n")
    with pytest.raises(FileFormatError):
        load_plan(tmp_path / "pickle.json")


def test_huge_integer_literal_in_a_resigned_plan(plan_dict, tmp_path):
    d = _edited(plan_dict, lambda d: _wps(d)[1].__setitem__("torque_commands", [10**400]),
                sign=True)
    with pytest.raises(FileFormatError, match="torque_commands"):
        load_plan(_write(tmp_path / "huge.json", d))


def test_plan_from_dict_deep_nesting(plan_dict):
    d = copy.deepcopy(plan_dict)
    d["extra"] = _deep(5000)
    with pytest.raises(FileFormatError):
        plan_from_dict(d)


def test_nasty_values_are_covered():
    """The mutation pool contains the hostile values: NaN, huge numbers, wrong types."""
    assert any(isinstance(v, float) and math.isnan(v) for v in NASTY_VALUES)
    assert 1e308 in NASTY_VALUES and None in NASTY_VALUES and "0.5" in NASTY_VALUES


# ---------------------------------------------------------------------------------------------
@pytest.mark.slow
@LONG
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_stale_digest_long(plan_dict, plan_path, tmp_path_factory, seed):
    _stale_case(seed, plan_dict, plan_path, tmp_path_factory.getbasetemp())


@pytest.mark.slow
@LONG
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_resigned_long(plan_dict, tmp_path_factory, seed):
    _resigned_case(seed, plan_dict, tmp_path_factory.getbasetemp())


@pytest.mark.slow
@LONG
@given(st.integers(0, 2**32 - 1))
def test_fuzz_plan_bytes_long(plan_path, tmp_path_factory, seed):
    _bytes_case(seed, plan_path, tmp_path_factory.getbasetemp())
