"""The validation campaign's engine-against-engine tables (benchmarks/campaign_engines.py) on
constructed rows: pairwise agreement away from region boundaries and the engines' consensus."""

from __future__ import annotations

from campaign_module import campaign


def _row(case, index, engine, status, near=False, artefacts=None):
    r = {"case": case, "index": index, "seed": 5, "engine": engine, "status": status,
         "near_boundary": near, "near_velocity": False, "wedge": []}
    if artefacts is not None:
        r["artefacts"] = artefacts
    return r


ROWS = [
    # away: all agree; MuJoCo odd with an artefact; MuJoCo odd with none recorded
    *(_row("stacked", 0, e, "agreed") for e in ("pymunk", "mujoco", "dart")),
    _row("stacked", 1, "pymunk", "agreed"), _row("stacked", 1, "dart", "agreed", artefacts=[]),
    _row("stacked", 1, "mujoco", "disagreed", artefacts=["contact c4 ... predicted to stick"]),
    _row("stacked", 2, "pymunk", "agreed"), _row("stacked", 2, "dart", "agreed"),
    _row("stacked", 2, "mujoco", "inconclusive"),
    # near a boundary: not in the tables away from boundaries
    *(_row("ex41", 0, e, s, near=True) for e, s in (("pymunk", "agreed"),
                                                      ("mujoco", "disagreed"),
                                                      ("dart", "disagreed"))),
    # DART did not run this point yet: in the pymunk - MuJoCo column only
    _row("ex41", 1, "pymunk", "agreed"), _row("ex41", 1, "mujoco", "agreed"),
    # refused rows never count
    _row("ex41", 2, "pymunk", "refused"), _row("ex41", 2, "dart", "agreed"),
]


def test_pairwise_agreement_away_from_boundaries():
    m = campaign()
    text = m.pairwise_table(ROWS, m.where)
    assert "| case | pymunk - MuJoCo | pymunk - DART | MuJoCo - DART |" in text
    assert "| stacked | 1 of 3 (33%) | 3 of 3 (100%) | 1 of 3 (33%) |" in text
    assert "| ex41 | 1 of 1 (100%) | 0 of 0 | 0 of 0 |" in text
    common = m.pairwise_table(ROWS, m.where, common=True)
    assert "| stacked | 1 of 3 (33%) | 3 of 3 (100%) | 1 of 3 (33%) |" in common
    assert "| ex41 |" not in common  # no point away from boundaries ran in all three
    anywhere = m.pairwise_table(ROWS, m.where, None)
    assert "| ex41 | 1 of 2 (50%) | 0 of 1 (0%) | 1 of 1 (100%) |" in anywhere


def test_consensus_counts_odd_engines_explained_by_recorded_artefacts():
    m = campaign()
    text = m.consensus_table(ROWS, m.where)
    assert "| stacked | 3 | 1 | 1 | 1 | 0 | MuJoCo 2 |" in text
    assert "| ex41 |" not in text  # no point away from boundaries ran in all three engines


def test_odd_rows_without_recorded_artefacts_are_the_ones_to_run_again():
    m = campaign()
    assert m.odd_unrecorded(ROWS, m.where, 5) == [("stacked", 2, "mujoco", 5)]
    assert m.odd_unrecorded(ROWS, m.where, 4) == []


def test_a_rerun_of_a_point_replaces_the_earlier_row_in_the_tables():
    """Rows of several files (``--also``): the last row of a ``(case, index, engine, seed)``
    counts, once, so a re-run point is not counted twice."""
    m = campaign()
    first = _row("supports", 0, "mujoco", "disagreed")
    again = _row("supports", 0, "mujoco", "agreed")
    rows = m.latest([first, _row("supports", 0, "pymunk", "agreed"), again])
    assert len(rows) == 2 and again in rows and first not in rows
    assert "| supports | mujoco | away | 1 | 1 (100%)" in m.table(rows)
