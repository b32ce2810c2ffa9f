"""CSV files the commands write: no cell a spreadsheet would run as a formula, and every name
read back exactly as it was (issue 32: ``=HYPERLINK(...)`` landed unescaped in names.csv)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from database_testlib import synthetic_motion
from hypothesis import given
from hypothesis import strategies as st

from elastic_motion.apps.csv_files import csv_cell, csv_text, csv_value
from elastic_motion.apps.database import DatabaseSettings, compute_matrix, load_matrix
from elastic_motion.apps.statistics import motion_labels
from elastic_motion.motion import write_bvh
from elastic_motion.warp import WarpOptions

#: Motion names a spreadsheet would run, or that look like the guard, or like a number.
NAMES = (
    '=HYPERLINK("x.example","click")',
    "+cmd",
    "-1+1",
    "@SUM(A1)",
    "\tlead",
    "\rcr",
    "'quoted",
    "-1",
    "plain",
)
FORMULA = tuple("=+-@\t\r")


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


@given(st.lists(st.lists(st.text(), min_size=1, max_size=4), max_size=5))
def test_csv_text_guards_every_cell_and_reads_back_exactly(rows):
    text = csv_text(rows)
    read = list(csv.reader(io.StringIO(text, newline="")))
    assert len(read) == len(rows)  # no cell breaks its row (a lone "\r" included)
    for cells, row in zip(read, rows, strict=True):
        assert not any(c.startswith(FORMULA) and not _is_number(c) for c in cells)
        assert [csv_value(c) for c in cells] == row


def test_guard_examples():
    assert [csv_cell(s) for s in ("walk", "=1+1", "-1+1", "-0.25", "-1e-07", "'q", "", 3, -2.5)] == [
        "walk",
        "'=1+1",
        "'-1+1",
        "-0.25",
        "-1e-07",
        "''q",
        "",
        "3",
        "-2.5",
    ]


def test_names_csv_of_a_matrix_run_is_guarded_and_reads_back(tmp_path: Path):
    db = tmp_path / "db"
    db.mkdir()
    for k, name in enumerate(NAMES):
        write_bvh(synthetic_motion(k % 3, k % 2, frames=20 + k), db / f"{name}.bvh")
    out = tmp_path / "out"
    settings = DatabaseSettings(n_samples=8, tile_size=4, warp=WarpOptions(method="none"))
    res = compute_matrix([db], out, settings)
    assert sorted(res.names) == sorted(NAMES)
    with open(out / "names.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert len(rows) == 1 + len(NAMES)
    for row in rows[1:]:  # what a spreadsheet sees: no formula in any cell
        assert not any(c.startswith(FORMULA) and not _is_number(c) for c in row), row
    assert {r[1] for r in rows[1:]} >= {'\'=HYPERLINK("x.example","click")', "''quoted", "-1"}
    m = load_matrix(out)  # the database still works, with the names as they were
    assert m.names == list(res.names) and sorted(m.names) == sorted(NAMES)
    assert [Path(p).name for p in m.paths] == [f"{n}.bvh" for n in m.names]
    # a label file made from names.csv's column (guarded) or with the names as written
    labels = tmp_path / "labels.csv"
    by_cell = {csv_value(r[1]): r[1] for r in rows[1:]}
    with open(labels, "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows([[by_cell[NAMES[0]], "copied"], [NAMES[1], "written"]])
    assert motion_labels(NAMES[:3], labels) == ["copied", "written", None]
