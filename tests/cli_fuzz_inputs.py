"""Hostile inputs for the command-line fuzz campaign (``tests/qsplan/test_fuzz_cli.py``,
``benchmarks/fuzz_cli.py``): valid fixtures, mutated system/hand/plan files, hostile output
paths."""

from __future__ import annotations

import json
import os
import random
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "scenarios" / "data"


# ---------------------------------------------------------------------------------------------
# Fixtures: valid inputs, special files, a run folder.
# ---------------------------------------------------------------------------------------------
@dataclass
class Fixtures:
    root: Path
    system: Path
    hand: Path
    plan: Path
    run_dir: Path
    counter: list[int] = field(default_factory=lambda: [0])

    def fresh(self, stem: str) -> Path:
        self.counter[0] += 1
        return self.root / f"{stem}{self.counter[0]}"


def make_fixtures(root: Path) -> Fixtures:
    """Valid system, hand and plan files (a 4-waypoint plan), special files and a run folder."""
    from planner.plan.hand_planner import plan_hand
    from planner.plan.plan_file import save_plan

    root.mkdir(parents=True, exist_ok=True)
    system = root / "system.json"
    system.write_text((DATA / "example_4_1.json").read_text())
    hand = root / "hand.json"
    hand.write_text((DATA / "two_finger_hand.json").read_text())
    plan = save_plan(plan_hand(hand, mu=(0.0, 0.2), waypoints=4), root / "plan_ok.json")
    run_dir = root / "run"
    (run_dir / "sub").mkdir(parents=True)
    (run_dir / "summary.json").write_text(json.dumps({"scenario": "x", "passed": True}))
    (run_dir / "sub" / "summary_b.json").write_text('{"passed": [1, {"x": NaN}], ')
    (run_dir / "plan_x.json").write_text('{"format": "qsplan-plan", "waypoints": "nope"}')
    (run_dir / "checks.json").write_text(json.dumps({"checks": [1, None, {"held": "x"}]}))
    (run_dir / "sub" / "fig.png").write_bytes(b"\x89PNG not really")
    os.mkfifo(root / "fifo")
    os.symlink(root / "fifo", root / "link_to_fifo")
    os.symlink(root / "nowhere", root / "dangling")
    (root / "afile").write_text("a regular file\n")
    (root / "adir").mkdir()
    return Fixtures(root, system, hand, plan, run_dir)


# ---------------------------------------------------------------------------------------------
# Hostile file contents.
# ---------------------------------------------------------------------------------------------
HOSTILE_VALUES = ["x", None, True, [], {}, [[[]]], float("nan"), 1e308, -1e308, 10 ** 400, -1,
                  0, 2 ** 63, "NaN", [1, "a"], {"mu": 1}]


def _paths(tree: object, prefix: tuple = ()) -> list[tuple]:
    out = [prefix] if prefix else []
    if isinstance(tree, dict):
        for k, v in tree.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            out += _paths(v, prefix + (i,))
    return out


def _get(tree: object, path: tuple) -> object:
    for k in path:
        tree = tree[k]  # type: ignore[index]
    return tree


def _set(tree: object, path: tuple, value: object, delete: bool = False) -> None:
    node = tree
    for k in path[:-1]:
        node = node[k]  # type: ignore[index]
    if delete:
        del node[path[-1]]  # type: ignore[attr-defined]
    else:
        node[path[-1]] = value  # type: ignore[index]


def hostile_text(rng: random.Random, valid: str) -> tuple[str | bytes, bool | None, str]:
    """A mutation of the JSON text ``valid``: (content, surely bad?, mutation name)."""
    kind = rng.choice(["truncate", "nan_literal", "value", "value", "delete", "unknown_key",
                       "empty", "binary", "deep", "not_object", "bom", "duplicate", "valid"])
    if kind == "truncate":
        return valid[: rng.randrange(0, valid.rindex("}"))], True, kind
    if kind == "nan_literal":
        tree = json.loads(valid)
        numeric = [q for q in _paths(tree) if isinstance(_get(tree, q), (int, float))
                   and not isinstance(_get(tree, q), bool)]
        _set(tree, rng.choice(numeric), 987654321.125)
        lit = rng.choice(["NaN", "Infinity", "-Infinity"])
        return json.dumps(tree).replace("987654321.125", lit), True, kind
    if kind == "empty":
        return rng.choice(["", " ", "\n"]), True, kind
    if kind == "binary":
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 200))), True, kind
    if kind == "deep":
        d = rng.choice([1000, 100_000])
        return "[" * d + "]" * d, True, kind
    if kind == "not_object":
        return rng.choice(["[1, 2, 3]", "1", '"a string"', "null", "true"]), True, kind
    if kind == "bom":
        return "\ufeff" + valid, None, kind
    if kind == "duplicate":
        return valid.replace("{", '{"mu": 1, ', 1), None, kind
    if kind == "valid":
        return valid, None, kind
    tree = json.loads(valid)
    paths = _paths(tree)
    if kind == "unknown_key":
        _set(tree, (rng.choice(["extra", "__proto__", "mu_", "x" * 300]),), 1)
    elif kind == "delete":
        _set(tree, rng.choice(paths), None, delete=True)
    else:
        _set(tree, rng.choice(paths), rng.choice(HOSTILE_VALUES))
    return json.dumps(tree), None, kind


def write_input(fx: Fixtures, rng: random.Random, valid_path: Path) -> tuple[str, bool | None]:
    """A hostile input file (or path) derived from ``valid_path``."""
    roll = rng.random()
    if roll < 0.12:
        return rng.choice([str(fx.root / "missing.json"), str(fx.root / "adir"), "", "/dev/null",
                           str(fx.root / "afile" / "x.json"), str(fx.root / "dangling")]), True
    content, bad, _ = hostile_text(rng, valid_path.read_text())
    path = fx.fresh("in") .with_suffix(".json")
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")
    return str(path), bad


# ---------------------------------------------------------------------------------------------
# Hostile output paths.
# ---------------------------------------------------------------------------------------------
OLD = b"OLD CONTENT\n"
SECRET = b"SECRET-BYTES-OUTSIDE-THE-RUN"
"""Bytes of a file outside every run folder, linked into one: no output may contain them."""


def output_path(fx: Fixtures, rng: random.Random, kind: str,
                names: tuple[str, ...] = ()) -> tuple[str, bool | None]:
    """(path, surely bad?) for an output of ``kind`` ("file"/"dir"); existing outputs are
    pre-filled with old content (``names`` inside an old folder) so that a failed run which
    touched them is seen."""
    choice = rng.choice(["new", "new", "nested", "old", "old", "wrong_kind", "fifo", "devnull",
                         "link_fifo", "dangling", "under_file", "empty", "proc", "long"])
    if choice == "new":
        return str(fx.fresh("out") if kind == "dir" else fx.fresh("out").with_suffix(".json")), \
            False
    if choice == "nested":
        return str(fx.fresh("nest") / "a" / ("b" if kind == "dir" else "b.json")), False
    if choice == "old":
        p = fx.fresh("old")
        if kind == "dir":
            p.mkdir()
            for n in names or ("old.txt",):
                (p / n).write_bytes(OLD)
        else:
            p = p.with_suffix(".json")
            p.write_bytes(OLD)
        return str(p), False
    if choice == "wrong_kind":
        p = fx.fresh("wrong")
        if kind == "dir":
            p.write_bytes(OLD)
        else:
            p.mkdir()
        return str(p), True
    return {
        "fifo": str(fx.root / "fifo"), "devnull": "/dev/null",
        "link_fifo": str(fx.root / "link_to_fifo"), "dangling": str(fx.root / "dangling"),
        "under_file": str(fx.root / "afile" / "x"), "empty": "",
        "proc": "/proc/qsplan-fuzz/out", "long": str(fx.root / ("x" * 300)),
    }[choice], True


