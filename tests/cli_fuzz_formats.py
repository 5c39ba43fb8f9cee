"""The command-line fuzz campaign on the formats and surfaces added since it was written:
geometry, chain and multi-body system files, hand files with a goal and any-hand files,
version-2 plans, ``scenarios run --set``, hostile run folders for ``report`` and special files
inside output sets.  Cases for :func:`cli_fuzz_cases.run_case` (in-process); the checks are the
campaign's: no traceback, bad input exit 2 with expected and got, no partial output set,
special files never replaced or deleted."""

from __future__ import annotations

import json
import os
import random
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

from cli_fuzz_cases import NUM_BAD, Case, _combine, _likely_bad, _opt
from cli_fuzz_inputs import DATA, OLD, ROOT, SECRET, Fixtures, output_path, write_input


@dataclass
class Formats:
    """Valid inputs of the newer formats (paths)."""

    geometry: Path
    chain: Path
    multibody: Path
    goal_hand: Path
    any_hand: Path
    task_plan: Path
    hostile_run: Path

    def systems(self, fx: Fixtures) -> list[Path]:
        return [fx.system, self.geometry, self.chain, self.multibody]


def _png_header(width: int, height: int) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", len(ihdr)) + chunk
            + struct.pack(">I", zlib.crc32(chunk)))


def make_formats(fx: Fixtures, task_plan: Path | None = None) -> Formats:
    """The newer formats' fixtures in ``fx.root``; ``task_plan``: a version-2 plan file to use
    (else one is planned for table_push_hand, about 10 s)."""
    root = fx.root
    copies = {}
    for name, src in (("geometry", DATA / "box_on_table_high.json"),
                      ("chain", ROOT / "tests" / "data" / "two_link_finger_box.json"),
                      ("multibody", DATA / "stacked_blocks.json"),
                      ("goal_hand", DATA / "figure9_task_hand.json"),
                      ("any_hand", DATA / "table_push_hand.json")):
        copies[name] = root / f"{name}.json"
        copies[name].write_bytes(src.read_bytes())
    if task_plan is None:
        from planner.plan.hand_planner import plan_hand
        from planner.plan.plan_file import save_plan

        task_plan = save_plan(plan_hand(copies["any_hand"], waypoints=3), root / "task_plan.json")
    else:
        task_plan = Path(task_plan)
    run = root / "hostile_run"
    (run / "a").mkdir(parents=True)
    outside = root / "outside"
    outside.mkdir()
    (outside / "private.png").write_bytes(_png_header(1, 1) + SECRET)
    (outside / "summary.json").write_text(json.dumps({"scenario": SECRET.decode()}))
    os.symlink(outside / "private.png", run / "leak.png")
    os.symlink(outside, run / "linked")
    os.mkfifo(run / "pipe.png")
    os.mkfifo(run / "summary_pipe.json")
    (run / os.fsdecode(b"bild-\xff.png")).write_bytes(_png_header(2, 2))
    (run / "huge.png").write_bytes(_png_header(100_000, 100_000))
    (run / "a" / "plan.json").write_text(
        '{"format": "qsplan-plan", "waypoints": [{"margin": 1' + "0" * 400 + '}]}')
    (run / "summary.json").write_text('{"scenario": "\\ud800", "agreement": 1' + "0" * 400
                                      + ', "passed": true}')
    return Formats(task_plan=task_plan, hostile_run=run, **copies)


def _system(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> tuple[str, bool | None]:
    valid = rng.choice(ff.systems(fx))
    return write_input(fx, rng, valid) if rng.random() < p else (str(valid), False)


def case_modes_formats(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    path, b0 = _system(fx, ff, rng, p)
    argv = ["modes", path]
    b1 = _opt(rng, argv, "--mu", ["nan", "-1", "1e999", "x"], ["0.3", "0.1"], p / 3)
    if rng.random() < 0.3:
        argv.append("--search")
    if rng.random() < 0.3:
        argv.append("--json")
    return Case("modes", argv, _combine(b0, b1))


def case_muspace_formats(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    path, b0 = _system(fx, ff, rng, p)
    out, b1 = output_path(fx, rng, "dir", ("muspace.json", "muspace.png")) \
        if rng.random() < p else (str(fx.fresh("out")), False)
    argv = ["muspace", path, "--vary", rng.choice(["1,2", "2,3"]), "--n", "3", "--out", out]
    return Case("muspace", argv, _combine(b0, b1), ((out, "dir"),),
                ("muspace.json", "muspace.png"))


def case_simulate_formats(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    """Always with one surely bad part (an accepted run simulates for seconds)."""
    path, b0 = _likely_bad(lambda: write_input(fx, rng, rng.choice(ff.systems(fx))))
    argv = ["simulate", path, "--no-render", "--out", str(fx.fresh("sim"))]
    if b0 is not True:
        argv += rng.choice([["--engine", "bullet"], ["--mu", rng.choice(NUM_BAD)],
                            ["--duration", "-1"], ["--judge-mu", "nan"]])
    return Case("simulate", argv, True, ((argv[argv.index("--out") + 1], "dir"),))


def case_plan_hands(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    """Hand files with a goal and any-hand files; always with one surely bad part (an
    accepted task plan takes about a minute)."""
    hand, b0 = _likely_bad(lambda: write_input(fx, rng, rng.choice([ff.goal_hand,
                                                                     ff.any_hand])))
    out = str(fx.fresh("plan").with_suffix(".json"))
    argv = ["plan", hand, "--out", out]
    if b0 is not True:
        argv += rng.choice([["--waypoints", "1"], ["--mu", "nan"], ["--max-expansions", "0"],
                            ["--policy", "constant"], ["--figures", str(fx.fresh("f"))],
                            ["--mu", "0:0.2,0:0.2,0:0.2,0:0.2,0:0.2,0:0.2,0:0.2"]])
    return Case("plan", argv, True, ((out, "file"),))


def case_validate_v2(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    """Version-2 plans; always with one surely bad part."""
    plan, b0 = _likely_bad(lambda: write_input(fx, rng, ff.task_plan))
    out = str(fx.fresh("val"))
    argv = ["validate", plan, "--out", out, "--no-render"]
    if b0 is not True:
        argv += rng.choice([["--engine", "bullet"], ["--mu", "nan"], ["--mu", "0.1/0.2"],
                            ["--mu", ",".join(["0.1"] * 101)]])
    return Case("validate", argv, True, ((out, "dir"),))


SET_BAD = ["mu=nan", "mu=1e308", "mu=0.1", "mu=", "=0.1", "mu", "nosuch=1", "mu=x,y,z",
           "mu=-1,0.2,0.3", "mu=" + ",".join(["0.1"] * 1000), "mu=0.1,0.2,1e999",
           "speed=inf", "mu=11,0.2,0.3"]


def case_scenarios_set(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    out = str(fx.fresh("scn"))
    argv = ["scenarios", "run", rng.choice(["ex41_3s", "ex41_rs", "neg_ex41_wrong_region"]),
            "--out", out, "--no-render"]
    for _ in range(rng.randint(1, 2)):
        argv += ["--set", rng.choice(SET_BAD)]
    return Case("scenarios", argv, True, ((out, "dir"),))


def case_report_hostile(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    out, b0 = output_path(fx, rng, "file") if rng.random() < p / 2 else (
        str(fx.fresh("rep").with_suffix(".html")), False)
    return Case("report", ["report", str(ff.hostile_run), "--out", out], b0, ((out, "file"),))


def _special_inside(fx: Fixtures, rng: random.Random, entries: tuple[str, ...]
                    ) -> tuple[str, bool]:
    """An existing output folder with old entries and one hostile thing inside: a FIFO or a
    symbolic link at an entry, a file where a folder goes, a FIFO deep inside an entry folder
    that would be replaced (all bad), or a FIFO in a folder the command does not write
    (fine: left alone)."""
    out = fx.fresh("setx")
    out.mkdir()
    for name in entries:
        if name.endswith("/"):
            (out / name).mkdir()
            (out / name / "old.png").write_bytes(OLD)
        else:
            (out / name).write_bytes(OLD)
    kind = rng.choice(["fifo_entry", "link_entry", "file_for_folder", "fifo_deep",
                       "fifo_elsewhere"])
    files = [e for e in entries if not e.endswith("/")]
    folders = [e.rstrip("/") for e in entries if e.endswith("/")]
    if kind == "fifo_entry" and files:
        victim = out / rng.choice(files)
        victim.unlink()
        os.mkfifo(victim)
    elif kind == "link_entry" and files:
        victim = out / rng.choice(files)
        victim.unlink()
        os.symlink(fx.root / "afile", victim)
    elif kind in ("file_for_folder", "fifo_deep") and folders:
        victim = out / rng.choice(folders)
        if kind == "file_for_folder":
            for child in victim.iterdir():
                child.unlink()
            victim.rmdir()
            victim.write_bytes(OLD)
        else:
            (victim / "deeper").mkdir()
            os.mkfifo(victim / "deeper" / "pipe")
    else:
        (out / "mine").mkdir()
        os.mkfifo(out / "mine" / "pipe")
        return str(out), False
    return str(out), True


def case_outputs_special(fx: Fixtures, ff: Formats, rng: random.Random, p: float) -> Case:
    """Special files inside the output sets of the commands that declare their entries."""
    from qsplan.commands.muspace import OUTPUTS
    from qsplan.commands.plan import FIGURES

    if rng.random() < 0.6:
        out, bad = _special_inside(fx, rng, OUTPUTS)
        return Case("muspace", ["muspace", str(fx.system), "--vary", "1,2", "--n", "3", "--out",
                                out], bad, ((out, "dir"),), OUTPUTS)
    figs, bad = _special_inside(fx, rng, FIGURES)
    plan = str(fx.fresh("plan").with_suffix(".json"))
    argv = ["plan", str(fx.hand), "--out", plan, "--figures", figs, "--waypoints", "3"]
    return Case("plan", argv, bad, ((plan, "file"), (figs, "dir")))


FORMAT_GENERATORS = {
    "modes": (case_modes_formats,), "muspace": (case_muspace_formats, case_outputs_special),
    "plan": (case_plan_hands,), "validate": (case_validate_v2,),
    "simulate": (case_simulate_formats,), "scenarios": (case_scenarios_set,),
    "report": (case_report_hostile,),
}


def generate_formats(fx: Fixtures, ff: Formats, seed: int, per_command: int,
                     commands: tuple[str, ...] = tuple(FORMAT_GENERATORS), p_bad: float = 0.6
                     ) -> list[Case]:
    rng = random.Random(seed)
    out = []
    for command in commands:
        for _ in range(per_command):
            out.append(rng.choice(FORMAT_GENERATORS[command])(fx, ff, rng, p_bad))
    return out
