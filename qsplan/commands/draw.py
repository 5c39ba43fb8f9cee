"""``qsplan draw FILE [--out PICTURE.png|.svg] [--mode LABEL]``: a picture of a system,
multi-body, hand or plan file before it is run (:mod:`planner.plots.draw`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from planner.errors import InputError
from qsplan.options import input_warnings

DESCRIPTION = """\
Draw a system, multi-body, hand or plan file: the workpieces, surfaces and fingers, the
contacts numbered as every output numbers them with their inward normals and friction cones
(half-angle atan(mu)), the load at the centre of mass, the drive (each contact's manipulator
velocity), chain joints; a hand at its start configuration with its goal pose dashed; a plan's
hand at its first waypoint with the torque command of each effort-controlled joint.  --mode
LABEL overlays a feasible mode's certificate (system files): the contact forces on the
workpiece and the velocity of every workpiece vertex.  The format follows --out's suffix (.png
or .svg; default FILE's name with .png in the current folder).  Exit 0 written, 2 bad input
(including a --mode that is not feasible)."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("draw", help="a picture of a system, hand or plan file (PNG or SVG)",
                       description=DESCRIPTION)
    p.add_argument("file", help="system, multi-body, hand or plan file (JSON)")
    p.add_argument("--out", help="picture to write, .png or .svg (default ./FILE_STEM.png)")
    p.add_argument("--mode", help="a feasible mode's label, e.g. 'S-1 S-2 R3' (system files): "
                                  "draw its contact forces and velocities")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from planner.files.outputs import output_set
    from planner.files.reader import read_json

    out = Path(args.out) if args.out is not None else Path(Path(args.file).stem + ".png")
    if out.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"--out: expected a .png or .svg file, got {str(out)!r}")
    kind = kind_of(read_json(args.file, "file to draw"))
    with output_set(out, "file", "--out") as tmp:
        fig = figure(args.file, kind, args.mode)
        from planner.plots.draw import save_drawing

        save_drawing(fig, tmp)
    if not getattr(args, "quiet", False):
        print(f"wrote {out} ({kind} file {args.file})")
    return 0


def figure(path: str, kind: str, mode_label: str | None = None) -> Any:
    """The matplotlib figure of a file of ``kind`` (:func:`planner.plots.draw_file.draw_file`),
    a geometry warning of a system file printed as one line on stderr."""
    from planner.plots.draw_file import draw_file

    with input_warnings("draw"):
        return draw_file(path, kind, mode_label)


def kind_of(data: Any) -> str:
    """``system``, ``hand`` or ``plan`` (:func:`planner.plots.draw_file.kind_of`)."""
    from planner.plots.draw_file import kind_of as kind

    return kind(data)
