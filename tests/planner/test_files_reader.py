"""The one JSON reader (planner/files/reader.py): every error it raises, and that every loader of
the tool reads through it (same caps, same messages for the same problem)."""

from __future__ import annotations

import ast
import json
import os
import socket
from pathlib import Path

import pytest

import planner.files.reader as reader
from planner.errors import FileFormatError, InputError
from planner.files.hand_file import load_hand
from planner.files.reader import MAX_JSON_DEPTH, json_depth, parse_json, read_json
from planner.files.system_file import load_system
from planner.plan.plan_file import load_plan

ROOT = Path(__file__).resolve().parents[2]
LOADERS = {"system file": load_system, "hand file": load_hand, "plan file": load_plan}


def _nested(depth: int) -> str:
    return "[" * depth + "]" * depth


@pytest.mark.parametrize("text,match", [
    ("", "expected valid JSON, got a syntax error at line 1 column 1"),
    ("{", "expected valid JSON, got a syntax error at line 1"),
    ('{"a": 1} x', "expected valid JSON, got a syntax error"),
    ('{"a": NaN}', "expected finite numbers .*got the constant NaN"),
    ('{"a": Infinity}', "got the constant Infinity"),
    ('{"a": -Infinity}', "got the constant -Infinity"),
    ('{"a": 1e999}', "expected finite numbers, got a number beyond the float range"),
    ('{"a": 1, "a": 2}', "expected each key once per object, got 'a' twice"),
    ('{"o": {"b": [], "b": {}}}', "got 'b' twice"),
    (_nested(MAX_JSON_DEPTH + 1), f"expected JSON nested at most {MAX_JSON_DEPTH} deep, got depth"),
    (_nested(200_000), f"expected JSON nested at most {MAX_JSON_DEPTH} deep"),
    ("1" * 5000, "expected JSON numbers Python can read"),
])
def test_parse_errors_say_expected_and_got(text, match):
    with pytest.raises(FileFormatError, match=match) as info:
        parse_json(text, "thing 'x.json'")
    assert str(info.value).startswith("thing 'x.json': ")


def test_strict_json_still_reads_ordinary_values():
    assert parse_json(_nested(MAX_JSON_DEPTH), "s") is not None  # exactly at the cap
    assert parse_json('{"a": [1, 2.5e3, -0, null, true, "\\u00e9"]}', "s") == {
        "a": [1, 2500.0, 0, None, True, "\u00e9"]}
    assert parse_json(b"\xef\xbb\xbf{\"a\": 1}", "s") == {"a": 1}  # a UTF-8 byte-order mark
    assert parse_json("\ufeff[1]", "s") == [1]
    assert parse_json("1e308", "s") == 1e308
    assert parse_json(str(10**400), "s") == 10**400  # integers: the loaders check ranges


def test_json_depth():
    assert json_depth(1) == 0
    assert json_depth([]) == 1
    assert json_depth({"a": [[1], {"b": []}]}) == 4


def test_utf8_errors_name_the_byte():
    with pytest.raises(FileFormatError, match="expected UTF-8 text, got byte 0xff at offset 2"):
        parse_json(b'{"\xff": 1}', "s")


@pytest.mark.parametrize("what,loader", LOADERS.items())
def test_missing_file_is_one_error(tmp_path, what, loader):
    path = tmp_path / "missing.json"
    with pytest.raises(FileFormatError,
                       match=f"{what} '.*missing.json': expected an existing file, got no such file"):
        loader(path)


@pytest.mark.parametrize("what,loader", LOADERS.items())
def test_directory_is_refused(tmp_path, what, loader):
    with pytest.raises(FileFormatError, match=f"{what} .*: expected a regular file, got a directory"):
        loader(tmp_path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("what,loader", LOADERS.items())
def test_fifo_is_refused_without_blocking(tmp_path, what, loader):
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)  # opening it for reading would block until a writer comes
    with pytest.raises(FileFormatError, match="expected a regular file, got a FIFO"):
        loader(fifo)


@pytest.mark.skipif(not Path("/dev/null").exists(), reason="no /dev/null")
def test_device_is_refused():
    with pytest.raises(FileFormatError, match="expected a regular file, got a device"):
        read_json("/dev/null", "system file")


def test_socket_is_refused(tmp_path):
    path = tmp_path / "s.sock"
    if len(str(path)) > 100:
        pytest.skip("socket path too long for AF_UNIX")
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(path))
        with pytest.raises(FileFormatError, match="expected a regular file, got a socket"):
            read_json(path, "plan file")


@pytest.mark.parametrize("what,loader", LOADERS.items())
def test_size_cap_is_the_same_for_every_loader(tmp_path, monkeypatch, what, loader):
    path = tmp_path / "big.json"
    path.write_text(json.dumps({"pad": "x" * 200}))
    monkeypatch.setattr(reader, "MAX_JSON_BYTES", 100)
    with pytest.raises(FileFormatError, match=f"{what} .*: expected at most 100 bytes, got 2"):
        loader(path)


@pytest.mark.parametrize("what,loader", LOADERS.items())
def test_every_loader_reports_the_same_reader_errors(tmp_path, what, loader):
    path = tmp_path / "x.json"
    for blob, match in [(b"{", "expected valid JSON"), (b"\xff", "expected UTF-8 text"),
                        (b'{"a": NaN}', "got the constant NaN"),
                        (b'{"a": 1, "a": 1}', "got 'a' twice"),
                        (_nested(100).encode(), "nested at most 64 deep")]:
        path.write_bytes(blob)
        with pytest.raises(FileFormatError, match=match) as info:
            loader(path)
        assert str(info.value).startswith(f"{what} '{path}': ")


def test_unreadable_file(tmp_path):
    path = tmp_path / "secret.json"
    path.write_text("{}")
    path.chmod(0)
    try:
        if os.access(path, os.R_OK):
            pytest.skip("running with permissions that read anything (root)")
        with pytest.raises(FileFormatError, match="expected a readable file, got Permission"):
            read_json(path, "hand file")
    finally:
        path.chmod(0o600)


def test_errors_are_input_errors():
    """A bad file is bad input: the command line maps InputError to exit code 2."""
    assert issubclass(FileFormatError, InputError)


def _json_parse_calls(source: str) -> list[int]:
    """Line numbers of ``json.load``/``json.loads`` calls in ``source``."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr in ("load", "loads") \
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "json":
            lines.append(node.lineno)
    return lines


def test_every_json_read_of_the_tool_goes_through_the_reader():
    offenders = [
        f"{p.relative_to(ROOT)}:{no}"
        for pkg in ("planner", "sim", "scenarios", "qsplan")
        for p in sorted((ROOT / pkg).rglob("*.py")) if p != Path(reader.__file__).resolve()
        for no in _json_parse_calls(p.read_text())
    ]
    assert offenders == [], "read JSON through planner.files.reader: " + ", ".join(offenders)


def test_the_static_check_itself():
    assert _json_parse_calls("import json\njson.loads(t)\nx = json.load(fh)") == [2, 3]
    assert _json_parse_calls("json.dumps(x)\nparse_json(t, 's')") == []
