"""Fuzzing the system-file loader and the public API: only documented errors may escape.

A short run is part of the default suite; ``-m slow`` runs >= 10,000 inputs per target.
Besides hypothesis' own JSON trees, valid system files (the paper's examples, a chain-form
hand, seeded random systems in every manipulator form) are *mutated*: keys deleted, values
replaced by wrong types / NaN / huge numbers / deep nesting, lists grown or emptied, and the
file text truncated, bit-flipped or spiked with non-UTF-8 bytes (:func:`mutate_tree`,
:func:`mutate_text`; ``tests/planner/test_fuzz_plan.py`` and ``benchmarks/robustness_table.py`` reuse
them). An accepted file must also survive ``system_to_dict`` -> ``system_from_dict`` unchanged.
"""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from randsys import random_system

from planner import QsplanError, System, feasible_modes
from planner.files.system_file import (
    load_system,
    system_from_dict,
    system_from_json,
    system_to_dict,
)

FAST = settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
LONG = settings(max_examples=10_000, deadline=None, suppress_health_check=list(HealthCheck))

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.integers(-10**6, 10**6),
    st.sampled_from([0, 1, -1, 0.5, 1e300, -1e-300]),
)
scalars = st.one_of(numbers, st.booleans(), st.none(), st.text(max_size=5))
json_values = st.recursive(
    scalars,
    lambda children: st.one_of(
        st.lists(children, max_size=4), st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=25,
)


def vec(n):
    return st.lists(numbers, min_size=n, max_size=n)


def plausible_system():
    """Mostly well-formed system dicts with targeted corruption."""
    contact = st.fixed_dictionaries(
        {"point": st.one_of(vec(2), json_values), "normal": st.one_of(
            st.sampled_from([[0, 1], [1, 0], [0.6, 0.8], [0, 0], [2, 0]]), json_values),
         "mu": st.one_of(st.floats(0, 2), numbers, json_values)}
    )
    manip = st.one_of(
        st.fixed_dictionaries({"contact_velocities": st.one_of(
            st.lists(vec(2), min_size=1, max_size=4), json_values)}),
        st.fixed_dictionaries({
            "jacobian": st.one_of(st.lists(st.lists(vec(2), min_size=2, max_size=2), max_size=4),
                                  json_values),
            "joints": st.one_of(st.lists(st.one_of(
                st.fixed_dictionaries({"velocity": numbers}),
                st.fixed_dictionaries({"effort": numbers}), json_values), max_size=3), json_values),
        }),
        json_values,
    )
    return st.fixed_dictionaries(
        {"contacts": st.one_of(st.lists(contact, min_size=0, max_size=4), json_values),
         "external_wrench": st.one_of(vec(3), json_values), "manipulator": manip}
    )


# ---------------------------------------------------------------------------------------------
# Mutation fuzzing of valid files (shared with test_fuzz_plan.py and the robustness benchmark).
# ---------------------------------------------------------------------------------------------
#: Replacement values: wrong types, non-finite and extreme numbers, containers.
NASTY_VALUES: tuple[Any, ...] = (
    None, True, False, "", "0.5", "NaN", "\u0000", "\udcff", 0, -1, 1, 2**63, 10**400, -(10**30),
    0.0, -0.0, 1e-320, 1e308, -1e308, math.nan, math.inf, -math.inf, [], {}, [[]], {"": None},
    [0.0], [1.0, 2.0, 3.0, 4.0, 5.0], {"velocity": 1.0}, {"effort": math.nan},
)

#: Values that crash a loader with a non-project exception (none known; the hook stays for the
#: next finding: the benchmark mixes them in and counts the crashes, CI does not).
KNOWN_CRASH_VALUES: tuple[Any, ...] = ()


def _paths(tree: Any, max_depth: int = 64) -> list[tuple]:
    """Every node position (down to ``max_depth``) of a JSON tree as a tuple of keys / indices
    (root = ()); iterative, so deep trees are fine."""
    out, stack = [], [((), tree)]
    while stack:
        prefix, node = stack.pop()
        out.append(prefix)
        if len(prefix) >= max_depth:
            continue
        if isinstance(node, dict):
            stack += [(prefix + (k,), v) for k, v in node.items()]
        elif isinstance(node, list):
            stack += [(prefix + (i,), v) for i, v in enumerate(node)]
    out.reverse()
    return out


def _get(tree: Any, path: tuple) -> Any:
    for k in path:
        tree = tree[k]
    return tree


def _deep(depth: int) -> Any:
    out: Any = 0.0
    for _ in range(depth):
        out = [out]
    return out


def mutate_tree(data: Any, rng: np.random.Generator, n_mutations: int | None = None,
                deep: tuple[int, ...] = (3, 50, 5000),
                values: tuple[Any, ...] = NASTY_VALUES) -> Any:
    """A copy of the JSON tree ``data`` with 1-3 random structural / value mutations.

    ``deep``: nesting depths used by the deep-nesting mutation (a parsed file never nests
    deeper than ``json.loads`` allows; deeper trees only reach the dict APIs)."""
    tree = copy.deepcopy(data)
    for _ in range(n_mutations or int(rng.integers(1, 4))):
        paths = _paths(tree)
        path = paths[int(rng.integers(len(paths)))]
        op = int(rng.integers(8))
        if not path:  # the root itself
            if op < 2:
                return copy.deepcopy(values[int(rng.integers(len(values)))])
            continue
        parent, key = _get(tree, path[:-1]), path[-1]
        node = parent[key]
        if op == 0:  # delete
            del parent[key]
        elif op in (1, 2):  # wrong type / non-finite / extreme
            # a copy: the pool's lists and dicts must not be mutated in place later
            parent[key] = copy.deepcopy(values[int(rng.integers(len(values)))])
        elif op == 3 and isinstance(node, (int, float)) and not isinstance(node, bool):
            parent[key] = float(node) * float(rng.choice([-1.0, 0.0, 1e-12, 1 + 1e-12, 1e12]))
        elif op == 3 or op == 4:  # grow or empty a container
            if isinstance(node, list):
                if node and rng.random() < 0.7:
                    node.append(copy.deepcopy(node[int(rng.integers(len(node)))]))
                else:
                    node.clear()
            elif isinstance(node, dict):
                node["unexpected_" + str(int(rng.integers(100)))] = 1.0
            else:
                parent[key] = [node, copy.deepcopy(node)]
        elif op == 5:  # deep nesting (last mutation: deep trees are not copied again)
            parent[key] = _deep(int(rng.choice(deep)))
            break
        elif op == 6 and isinstance(node, str):
            parent[key] = node + "\x00\u202e"
        else:  # swap in a sibling's value
            if isinstance(parent, dict) and len(parent) > 1:
                other = list(parent)[int(rng.integers(len(parent)))]
                parent[key] = copy.deepcopy(parent[other])
            elif isinstance(parent, list) and len(parent) > 1:
                parent[key] = copy.deepcopy(parent[int(rng.integers(len(parent)))])
    return tree


#: Literals spliced into file text (``KNOWN_CRASH_LITERALS`` still crash a loader).
LITERALS: tuple[bytes, ...] = (b"NaN", b"Infinity", b"-Infinity", b"1e999", b"-0", b"1e-400",
                               b"1" + b"0" * 400)
KNOWN_CRASH_LITERALS: tuple[bytes, ...] = ()


def mutate_text(text: str, rng: np.random.Generator,
                literals: tuple[bytes, ...] = LITERALS) -> bytes:
    """File bytes derived from valid JSON ``text``: truncated, bit-flipped, non-UTF-8, ...
    ``literals`` are spliced in at random places (most give a syntax error; in a number's
    place they are values)."""
    raw = text.encode("utf-8")
    op = int(rng.integers(9))
    i = int(rng.integers(len(raw) + 1))
    if op == 0:
        return raw[:i]  # truncated (a crash mid-write)
    if op == 1 and raw:
        j = min(i, len(raw) - 1)
        return raw[:j] + bytes([raw[j] ^ (1 << int(rng.integers(8)))]) + raw[j + 1:]
    if op == 2:
        return raw[:i] + bytes(rng.choice([b"\xff", b"\xc3\x28", b"\xed\xa0\x80", b"\x00"]))
    if op == 3:
        return b"\xef\xbb\xbf" + raw  # UTF-8 byte-order mark
    if op == 4:
        lit = literals[int(rng.integers(len(literals)))]
        if rng.random() < 0.5:  # replace a number so the file stays valid JSON
            nums = [m.span() for m in re.finditer(rb"-?\d+\.?\d*(?:[eE][-+]?\d+)?", raw)]
            if nums:
                a, b = nums[int(rng.integers(len(nums)))]
                return raw[:a] + lit + raw[b:]
        return raw[:i] + lit + raw[i:]
    if op == 5:
        depth = int(rng.choice([100, 5000, 200_000]))
        return b"[" * depth + b"]" * depth
    if op == 6:
        return b""
    if op == 7:
        return raw.replace(b"{", b'{"a": 1, "a": ', 1)  # duplicate keys / broken object
    return raw + raw[: int(rng.integers(1, 20))]  # trailing garbage


def seed_system_files() -> list[dict]:
    """Valid system files: the paper's examples, a chain hand, random systems in every form."""
    data = Path(__file__).resolve().parents[2] / "scenarios" / "data"
    out = [json.loads((data / f).read_text()) for f in ("example_4_1.json", "example_4_3.json")]
    out.append({
        "contacts": [{"point": [-0.05, 0.1], "normal": [1, 0], "mu": 0.2},
                     {"point": [0.05, 0.1], "normal": [-1, 0], "mu": 0.2}],
        "external_wrench": [0, -1, 0],
        "manipulator": {
            "chain": {"joints": [{"type": "revolute", "origin": [-0.05, 0.0], "angle": 1.5},
                                 {"type": "prismatic", "origin": [0.05, 0.0], "angle": 1.5}]},
            "q": [0.0, 0.0], "contact_links": [0, 1],
            "joints": [{"velocity": 0.1}, {"effort": 1.0}], "joint_loads": [0.0, 0.1],
        },
    })
    rng = np.random.default_rng(20261122)
    for n_c, n_e, virtual in ((3, 0, True), (4, 0, False), (4, 1, False), (5, 2, False)):
        out.append(system_to_dict(random_system(rng, n_c, n_e, virtual=virtual)))
    return out


def system_round_trips(system: System) -> bool:
    """An accepted system equals what its own file form loads back to (to a few ulps: the
    loader re-normalises geometric normals, and ``n / |n|`` is not idempotent in floating
    point)."""
    back = system_from_dict(json.loads(json.dumps(system_to_dict(system))))

    def close(a: np.ndarray, b: np.ndarray) -> bool:
        scale = float(np.max(np.abs(a), initial=0.0))
        return a.shape == b.shape and bool(np.all(np.abs(a - b) <= 1e-14 * max(scale, 1e-300)))

    return all(close(getattr(system, k), getattr(back, k))
               for k in ("W", "mu", "g_obj", "J", "joint_inputs", "g_man")) and (
        back.control == system.control)


def _only_documented_errors(fn, *args):
    try:
        return fn(*args)
    except QsplanError:
        return None


def _loader_then_solve(data):
    s = _only_documented_errors(system_from_dict, data)
    if s is not None:
        _only_documented_errors(feasible_modes, s)


@FAST
@given(json_values)
def test_fuzz_loader_arbitrary_json(data):
    _loader_then_solve(data)


@FAST
@given(plausible_system())
def test_fuzz_loader_plausible(data):
    _loader_then_solve(data)


@FAST
@given(st.text(max_size=200))
def test_fuzz_loader_text(text):
    _only_documented_errors(system_from_json, text)


def _public_api_case(data):
    n = data.draw(st.integers(1, 5))
    arr = st.lists(st.lists(numbers, min_size=2, max_size=2), min_size=n, max_size=n)
    kwargs = dict(points=data.draw(arr), normals=data.draw(arr),
                  mu=data.draw(st.one_of(st.floats(-1, 2), vec(n))),
                  external_wrench=data.draw(vec(3)), contact_velocities=data.draw(arr))
    s = _only_documented_errors(lambda: System.from_contacts(**kwargs))
    if s is not None:
        _only_documented_errors(feasible_modes, s, data.draw(st.one_of(vec(n), st.floats())))


@FAST
@given(st.data())
def test_fuzz_public_api(data):
    _public_api_case(data)


def _random_system_case(seed: int) -> None:
    """A seeded random system (3-5 contacts, at most one effort joint, lengths 1e-2..1e2)
    through feasible_modes: no exception at all, and every certificate of a determinate mode
    re-checks (tests/certify.py)."""
    from certify import check_certificate

    rng = np.random.default_rng(seed)
    n_c = int(rng.integers(3, 6))
    s = random_system(rng, n_c, int(rng.integers(0, 2)), scale=float(10 ** rng.uniform(-2, 2)))
    pred = feasible_modes(s)
    for fm in pred.modes:
        check_certificate(s, fm)


@FAST
@given(st.integers(0, 2**32 - 1))
def test_fuzz_random_systems(seed):
    _random_system_case(seed)


@pytest.mark.slow
@LONG
@given(st.data())
def test_fuzz_public_api_long(data):
    _public_api_case(data)


@pytest.mark.slow
@LONG
@given(st.integers(0, 2**32 - 1))
def test_fuzz_random_systems_long(seed):
    _random_system_case(seed)


@pytest.mark.slow
@LONG
@given(plausible_system())
def test_fuzz_loader_long(data):
    _loader_then_solve(data)


@pytest.mark.slow
@LONG
@given(json_values)
def test_fuzz_loader_arbitrary_long(data):
    _loader_then_solve(data)


SEEDS = seed_system_files()


def _mutated_system_case(seed: int) -> None:
    rng = np.random.default_rng(seed)
    base = SEEDS[int(rng.integers(len(SEEDS)))]
    s = _only_documented_errors(system_from_dict, mutate_tree(base, rng))
    if s is not None:
        assert system_round_trips(s)
        _only_documented_errors(feasible_modes, s)


@FAST
@given(st.integers(0, 2**32 - 1))
def test_fuzz_loader_mutated_files(seed):
    _mutated_system_case(seed)


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.integers(0, 2**32 - 1))
def test_fuzz_loader_mutated_bytes(tmp_path_factory, seed):
    rng = np.random.default_rng(seed)
    base = SEEDS[int(rng.integers(len(SEEDS)))]
    path = tmp_path_factory.mktemp("fuzz") / "system.json"
    path.write_bytes(mutate_text(json.dumps(base), rng))
    s = _only_documented_errors(load_system, path)
    if s is not None:
        _only_documented_errors(feasible_modes, s)


def test_seed_files_are_valid_and_mutations_are_rejected():
    """The mutation fuzzer starts from files the loader accepts, and its mutations bite."""
    for d in SEEDS:
        assert system_round_trips(system_from_dict(d))
    rng = np.random.default_rng(0)
    pool = repr(NASTY_VALUES)
    rejected = 0
    for _ in range(200):
        try:
            system_from_dict(mutate_tree(SEEDS[0], rng))
        except QsplanError:
            rejected += 1
    assert rejected > 100
    assert repr(NASTY_VALUES) == pool  # mutations never alter the shared value pool


@pytest.mark.parametrize("blob,match", [
    (b"", "expected valid JSON"),
    (b"\xff\xfe{}", "expected UTF-8 text"),
    (b"[" * 200_000 + b"]" * 200_000, "expected JSON nested at most 64 deep"),
    (b'{"contacts": [], "mu": NaN}', "got the constant NaN"),
    (b"[1, 2", "expected valid JSON"),
])
def test_file_level_garbage_messages(tmp_path, blob, match):
    path = tmp_path / "bad.json"
    path.write_bytes(blob)
    with pytest.raises(QsplanError, match=match):
        load_system(path)


@pytest.mark.parametrize("key,value,match", [
    ("external_wrench", [0.0, float("nan"), 0.0], "external_wrench"),
    ("external_wrench", [0.0, 1e308, 1e308], None),
    ("mu", [0.2, -0.3, 0.1], "mu"),
    ("mu", [0.2, True, 0.1], "mu: expected numbers, got a boolean"),
    ("wrench_matrix", _deep(500), "wrench_matrix: expected shape (3, 2*n_c)"),
])
def test_mutations_of_example_41_are_rejected(data_dir, key, value, match):
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d[key] = value
    try:
        s = system_from_dict(d)
    except QsplanError as exc:
        assert match is None or match in str(exc)
        return
    assert match is None, f"{key}={value!r} was accepted"
    # accepted huge loads: the solver answers or raises a documented error, nothing else
    _only_documented_errors(feasible_modes, s)


def test_system_from_dict_deep_nesting(data_dir):
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d["wrench_matrix"] = _deep(5000)
    with pytest.raises(QsplanError):
        system_from_dict(d)


@pytest.mark.parametrize("key", ["mu", "external_wrench"])
def test_system_from_dict_deep_nesting_in_other_fields(data_dir, key):
    d = json.loads((data_dir / "example_4_1.json").read_text())
    d[key] = _deep(5000)
    with pytest.raises(QsplanError, match=key):
        system_from_dict(d)


@pytest.mark.parametrize("field", ["jacobian", "joint"])
def test_huge_integer_in_manipulator_fields(field):
    d = system_to_dict(_jacobian_system())
    if field == "jacobian":
        d["manipulator"]["jacobian"][0][0][0] = 10**400
    else:
        d["manipulator"]["joints"][0] = {next(iter(d["manipulator"]["joints"][0])): 10**400}
    with pytest.raises(QsplanError, match=field):
        system_from_json(json.dumps(d))


def _jacobian_system() -> System:
    """A seeded random system in the Jacobian form (3 contacts, one effort joint)."""
    return random_system(np.random.default_rng(3), 3, 1, virtual=False)


def test_deep_contact_entry(data_dir):
    d = {"contacts": [_deep(5000)], "external_wrench": [0, -1, 0],
         "manipulator": {"contact_velocities": [[0.0, 1.0]]}}
    with pytest.raises(QsplanError, match="contact 1"):
        system_from_dict(d)


def test_huge_integer_literal_in_a_file(tmp_path, data_dir):
    text = (data_dir / "example_4_1.json").read_text().replace('"mu": [0.2,', '"mu": [1' +
                                                               "0" * 400 + ",")
    path = tmp_path / "huge.json"
    path.write_text(text)
    with pytest.raises(QsplanError, match="mu"):
        load_system(path)


@pytest.mark.slow
@LONG
@given(st.integers(0, 2**32 - 1))
def test_fuzz_loader_mutated_files_long(seed):
    _mutated_system_case(seed)


def test_valid_files_survive_json_round_trip(data_dir):
    for name in ("example_4_1.json", "example_4_3.json"):
        d = json.loads((data_dir / name).read_text())
        s = system_from_dict(d)
        assert np.isfinite(s.W).all()


# ---------------------------------------------------------------------------------------------
# Tests for what benchmarks/robustness_table.py found (docs/robustness.md, "What the campaigns
# found": each finding with the test that pins it).
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("speed", [1e-9, 1e-10])
def test_rod_prediction_does_not_depend_on_the_speed_unit(speed):
    """Sec. 5.1 rod: the same modes at 1 m/s and at ``speed``; every certificate re-checks."""
    from certify import check_certificate
    from test_paper import rod

    ref = feasible_modes(rod(0.4, 0.25, 0.3, 0.3, speed=1.0))
    slow_system = rod(0.4, 0.25, 0.3, 0.3, speed=speed)
    slow = feasible_modes(slow_system)
    for fm in slow.modes + slow.indeterminate_modes:
        check_certificate(slow_system, fm)  # "R1 R2": contact 1 rolling but moves
    assert slow.labels == ref.labels == ["S+1 R2"]


def test_search_modes_without_candidates():
    from planner import Status
    from planner.predict.search import search_modes

    s = System.from_contacts(
        points=[[-1, 0], [1, 0]], normals=[[0, 1], [0, 1]], mu=0.3, external_wrench=[0, -1, 0],
        jacobian=[[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 0, 0]]],
        joints=[{"velocity": 1.0}, {"effort": 1.0}, {"effort": 2.0}])
    assert feasible_modes(s).status is Status.NO_CANDIDATES
    assert search_modes(s).prediction.status is Status.NO_CANDIDATES


@pytest.mark.parametrize("fmt,ver", [("qsplan-system", 2), ("qsplan-plan", 1), ("qsplan-system", "1")])
def test_system_file_version_is_checked(tmp_path, data_dir, fmt, ver):
    from planner.files.system_file import save_system

    saved = json.loads(save_system(load_system(data_dir / "example_4_1.json"),
                                   tmp_path / "s.json").read_text())
    assert (saved["format"], saved["version"]) == ("qsplan-system", 1)
    saved["format"], saved["version"] = fmt, ver
    with pytest.raises(QsplanError, match="expected format 'qsplan-system' version 1"):
        system_from_dict(saved)
