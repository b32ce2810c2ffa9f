"""CSV files the commands write (``names.csv`` of a matrix run, the demo's ``distances.csv``)
and read back: one home for their cells.

A spreadsheet runs a cell that starts with ``=``, ``+``, ``-`` or ``@`` as a formula (and a
tab or carriage return in front of one does not stop it), so a motion named
``=HYPERLINK("http://...")`` would become a live link, or worse, in whoever opens the file.
Following the OWASP rule for CSV injection, :func:`csv_cell` writes such a cell with a
``'`` in front, which a spreadsheet takes as "this is text" and does not show. So that the
scheme can be undone exactly, a cell that starts with ``'`` gets one too; plain numbers
(``-0.5``, ``-1e-07``, ``-inf``) are written as they are. :func:`csv_value` removes the
``'`` again: ``csv_value(csv_cell(s)) == s`` for every string ``s``.

Examples
--------
>>> [csv_cell(s) for s in ("walk", "=1+1", "-1+1", "-0.25", "'quoted")]
['walk', "'=1+1", "'-1+1", '-0.25', "''quoted"]
>>> csv_value("'=1+1")
'=1+1'
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Sequence
from typing import Any

from elastic_motion._io import read_bytes

__all__ = ["csv_cell", "csv_text", "csv_value", "read_csv_dicts"]

#: First characters a spreadsheet may read as the start of a formula (OWASP), and ``'``, the
#: guard itself (so that a cell starting with it is guarded too and the round trip is exact).
_FORMULA_START = frozenset("=+-@\t\r'")
#: A plain number as Python and the writers here print it: never a formula, left as it is.
_NUMBER = re.compile(r"-?(\d+\.?\d*([eE][-+]?\d+)?|inf|nan)")


def csv_cell(value: Any) -> str:
    """The text of one CSV cell for ``value`` (``str(value)``), guarded against formulas.

    Parameters
    ----------
    value : any
        A name, a path, a number.

    Returns
    -------
    str
        ``"'" + text`` when the text starts with ``=``, ``+``, ``-``, ``@``, tab, carriage
        return or ``'`` and is not a plain number; the text otherwise.
    """
    text = str(value)
    if text[:1] in _FORMULA_START and not _NUMBER.fullmatch(text):
        return "'" + text
    return text


def csv_value(cell: str) -> str:
    """The value :func:`csv_cell` wrote as ``cell`` (its leading ``'`` removed)."""
    return cell[1:] if cell.startswith("'") else cell


def csv_text(rows: Iterable[Sequence[Any]]) -> str:
    """CSV text (``\\n`` line ends) of ``rows``, every cell through :func:`csv_cell` (a row
    with a carriage return in a cell: every cell quoted)."""
    buf = io.StringIO()
    for row in rows:
        cells = [csv_cell(v) for v in row]
        # csv quotes a cell holding the line end "\n" but not a lone "\r", which readers also
        # take for a line end: a row with one is written with every cell quoted
        quoting = csv.QUOTE_ALL if any("\r" in c for c in cells) else csv.QUOTE_MINIMAL
        csv.writer(buf, lineterminator="\n", quoting=quoting).writerow(cells)
    return buf.getvalue()


def read_csv_dicts(path: str | os.PathLike[str]) -> list[dict[str, str]]:
    """The rows of a CSV file written by :func:`csv_text` (header first) as dicts, every
    field and value through :func:`csv_value`. Only a regular file is opened (a FIFO in its
    place is a ``ParseError``, not a hang: :func:`elastic_motion._io.read_bytes`); bytes that
    are not UTF-8 come back as the surrogates they were written from (file names)."""
    text = read_bytes(path).decode("utf-8", "surrogateescape")
    rows = csv.DictReader(io.StringIO(text, newline=""), restval="")
    return [{csv_value(k): csv_value(v) for k, v in row.items() if k is not None} for row in rows]
