"""Fuzzing the system-file loader and the public API: only documented errors may escape.

A short run is part of the default suite; ``-m slow`` runs >= 10,000 inputs per target.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner import QsplanError, System, feasible_modes
from planner.io import system_from_dict, system_from_json

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


@FAST
@given(st.data())
def test_fuzz_public_api(data):
    n = data.draw(st.integers(1, 5))
    arr = st.lists(st.lists(numbers, min_size=2, max_size=2), min_size=n, max_size=n)
    kwargs = dict(points=data.draw(arr), normals=data.draw(arr),
                  mu=data.draw(st.one_of(st.floats(-1, 2), vec(n))),
                  external_wrench=data.draw(vec(3)), contact_velocities=data.draw(arr))
    s = _only_documented_errors(lambda: System.from_contacts(**kwargs))
    if s is not None:
        _only_documented_errors(feasible_modes, s, data.draw(st.one_of(vec(n), st.floats())))


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


def test_valid_files_survive_json_round_trip(data_dir):
    for name in ("example_4_1.json", "example_4_3.json"):
        d = json.loads((data_dir / name).read_text())
        s = system_from_dict(d)
        assert np.isfinite(s.W).all()
