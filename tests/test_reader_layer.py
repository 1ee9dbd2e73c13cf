"""The reader layer (torlab.parsers._table): the rules every text reader shares.

Each test writes a small file whose right reading is known by construction (the values
written, the number of data lines written) and checks the layer against it: line ends,
encodings, the field count of every row, decimal marks, empty cells and cells of spaces,
blank and ``#`` lines, values beyond any measurement, files larger than the bound, and the
same answers whatever the block size the file is read in.
"""

from __future__ import annotations

import io
import itertools

import numpy as np
import pytest

from torlab.errors import TorlabInputError
from torlab.parsers import _table
from torlab.parsers._table import RowSpec, TextFile, iter_column_blocks, parse_rows, read_columns

ROWS = [[0.5 * i, 63.5 + 0.01 * i, -0.1 * i] for i in range(50)]
TEXT = "# head\n# more\na [s],b [kN],c [N]\n" + "".join(
    f"{a:.2f},{b:.4f},{c:.2f}\n" for a, b, c in ROWS)


def _spec(names=("a", "b", "c"), use=(0, 1, 2), **kw) -> RowSpec:
    return RowSpec(list(names), list(use), "f.txt", **kw)


def _read(data: bytes | str, first_line: int = 4, **kw) -> list[np.ndarray]:
    raw = data.encode() if isinstance(data, str) else data
    with TextFile(io.BytesIO(raw), name="f.txt") as tf:
        return read_columns(tf, first_line, _spec(**kw))


def _error(data: bytes | str, first_line: int = 4, **kw) -> TorlabInputError:
    with pytest.raises(TorlabInputError) as e:
        _read(data, first_line, **kw)
    return e.value


def test_rows_read_as_written():
    cols = _read(TEXT)
    assert np.array_equal(np.column_stack(cols), np.round(np.array(ROWS), 4))


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r", "\r\r\n"])
def test_every_line_end_reads_the_same_lines(end):
    """LF, CR LF, CR alone and CR CR LF (a CR LF file converted again) are each one line
    end, in the header and the data alike: no header line shifts the first row."""
    data = TEXT.replace("\n", end)
    with TextFile(io.BytesIO(data.encode()), name="f.txt") as tf:
        head = tf.head(lambda ln, s: s.startswith("a [s]"))
        cols = read_columns(tf, len(head) + 1, _spec())
    assert head == ["# head", "# more", "a [s],b [kN],c [N]"]
    assert len(cols[0]) == len(ROWS) and cols[0][0] == 0.0 and cols[0][-1] == ROWS[-1][0]


@pytest.mark.parametrize("encoding", ["utf-8-sig", "utf-16", "utf-16-be", "cp1252"])
def test_encodings(encoding):
    text = TEXT.replace("# more", "# more: 25 °C")
    raw = ("\ufeff" + text).encode("utf-16-be") if encoding == "utf-16-be" else \
        text.encode(encoding)
    with TextFile(io.BytesIO(raw), name="f.txt") as tf:
        assert tf.head(lambda ln, s: ln == 2)[1] == "# more: 25 °C"
        cols = read_columns(tf, 4, _spec())
    assert np.array_equal(np.column_stack(cols), np.round(np.array(ROWS), 4))


def test_binary_and_too_large_files_are_refused_before_they_are_read(tmp_path, monkeypatch):
    with pytest.raises(TorlabInputError, match="binary file"):
        TextFile(io.BytesIO(b"abc\x00def"), name="b.txt")
    big = tmp_path / "big.txt"
    with open(big, "wb") as f:  # sparse: no disk used
        f.truncate(_table.MAX_TEXT_BYTES + 1)

    def no_reading(self, n):
        raise AssertionError("read before the size was checked")

    monkeypatch.setattr(TextFile, "_read", no_reading)
    with pytest.raises(TorlabInputError, match="larger than 1024 MiB") as e:
        TextFile(big)
    assert e.value.path == str(big)


@pytest.mark.parametrize("row, line, fragment", [
    ("1.00,63.5000,2.00,7", 10, "found 4"),             # one field more
    ("1.00,63.5000", 10, "found 2 (a truncated row?)"),  # one fewer
    ("1.00,63,5000,2.00", 10, "a decimal comma in a comma-separated file"),
])
def test_a_row_with_another_field_count_is_an_error_naming_its_line(row, line, fragment):
    lines = TEXT.split("\n")
    lines[line - 1] = row
    e = _error("\n".join(lines))
    assert (e.path, e.line) == ("f.txt", line) and fragment in e.message


def test_the_first_row_with_an_extra_field_is_not_taken_for_an_index():
    """pandas reads extra fields in the first row of a table as an index: not here."""
    lines = TEXT.split("\n")
    lines[3] += ",9"
    assert _error("\n".join(lines)).line == 4


def test_one_row_too_long_and_one_too_short_do_not_cancel():
    lines = TEXT.split("\n")
    lines[9] += ",9"           # line 10: one more
    lines[20] = "1.00,63.5000"  # line 21: one fewer (the delimiters add up to the header's)
    e = _error("\n".join(lines))
    assert e.line == 10 and "found 4" in e.message


@pytest.mark.parametrize("cell, fragment", [
    ("abc", "'abc' is not a number"), ("nan", "'nan' is not a finite number"),
    ("inf", "'inf' is not a finite number"), ("1e400", "'1e400' is not a finite number"),
    ("", "empty value"), ("   ", "a cell of spaces"), ("1_0", "'1_0' is not a number"),
    ("1e150", "too large to be a measurement"),
])
def test_a_bad_cell_is_an_error_naming_line_and_column(cell, fragment):
    lines = TEXT.split("\n")
    c = lines[11].split(",")
    c[1] = cell
    lines[11] = ",".join(c)
    e = _error("\n".join(lines), names=("a [s]", "b [kN]", "c [N]"))
    assert (e.line, e.key) == (12, "column 'b [kN]'") and fragment in e.message


def test_values_too_large_once_in_si_units():
    lines = TEXT.split("\n")
    c = lines[11].split(",")
    c[1] = "1e98"  # 1e98 kN = 1e101 N
    lines[11] = ",".join(c)
    e = _error("\n".join(lines), scales=[1.0, 1e3, 1.0], units=["s", "kN", "N"])
    assert e.line == 12 and "1e98 kN is too large" in e.message
    ok = _read("\n".join(lines))  # the same cell as a plain number is a value
    assert ok[1][8] == 1e98


def test_empty_cells_and_cells_of_spaces_where_a_column_may_be_empty():
    lines = TEXT.split("\n")
    c = lines[11].split(",")
    c[2] = ""
    lines[11] = ",".join(c)
    c = lines[12].split(",")
    c[2] = "   "
    lines[12] = ",".join(c)
    cols = _read("\n".join(lines), allow_empty=[False, False, True])
    assert np.isnan(cols[2][8]) and np.isnan(cols[2][9])
    assert np.isfinite(np.delete(cols[2], [8, 9])).all()


def test_a_declared_decimal_comma_is_read_right_and_a_point_refused():
    text = TEXT.replace(",", ";").replace(".", ",")
    cols = _read(text, delimiter=";", decimal=",")
    assert np.array_equal(np.column_stack(cols), np.round(np.array(ROWS), 4))
    lines = text.split("\n")
    lines[6] = lines[6].replace(",", ".", 1)  # '409.00' in a decimal-comma file
    e = _error("\n".join(lines), delimiter=";", decimal=",")
    assert e.line == 7 and "has a decimal point, but the file's decimal mark is ','" in e.message


def test_blank_and_hash_lines_end_the_data_but_do_not_interrupt_it():
    cols = _read(TEXT + "\n# end of run\n   \n")
    assert len(cols[0]) == len(ROWS)
    lines = TEXT.split("\n")
    for filler, what in (("", "blank line"), ("# pause", "'#' line"), ("  \t", "blank line")):
        bad = [*lines[:20], filler, *lines[20:]]
        e = _error("\n".join(bad))
        assert e.line == 21 and what in e.message


def test_no_data_rows():
    e = _error("# head\n# more\na [s],b [kN],c [N]\n# nothing\n")
    assert "no data rows" in e.message


@pytest.mark.parametrize("block", [7, 64, 333])
def test_the_answers_do_not_depend_on_the_block_size(block, monkeypatch):
    """Rows, errors and lines alike when the file is read in small blocks (CR at a block's
    end, a blank line in one block and a row in the next, a line longer than a block)."""
    monkeypatch.setattr(_table, "BLOCK_BYTES", block)
    data = TEXT.replace("# more", "# " + "m" * 500).replace("\n", "\r\n")
    cols = _read(data)
    assert np.array_equal(np.column_stack(cols), np.round(np.array(ROWS), 4))
    lines = TEXT.split("\n")
    e = _error("\n".join([*lines[:30], "", *lines[30:]]))
    assert e.line == 31 and "blank line" in e.message
    lines[40] += ",1"
    assert _error("\n".join(lines)).line == 41
    with TextFile(io.BytesIO(TEXT.encode()), name="f.txt") as tf:
        got = [(first, len(c[0])) for first, c in iter_column_blocks(tf, 4, _spec())]
    assert got[0][0] == 4 and sum(n for _, n in got) == len(ROWS)
    assert all(b[0] == a[0] + a[1] for a, b in itertools.pairwise(got))


def test_rows_held_in_memory_with_their_own_line_numbers():
    rows = ["1\t2\t", "3\t\t5", "6\t7\t8"]
    spec = RowSpec(["x", "y", "z"], [0, 2], "p.txt", delimiter="\t",
                   allow_empty=[True, True])
    arr = parse_rows(rows, [10, 20, 30], spec)
    assert np.array_equal(arr, np.array([[1.0, np.nan], [3.0, 5.0], [6.0, 8.0]]),
                          equal_nan=True)
    with pytest.raises(TorlabInputError) as e:
        parse_rows([*rows[:2], "6\t7"], [10, 20, 30], spec)
    assert e.value.line == 30 and "tab" in e.value.message


def test_memory_running_out_is_one_line_naming_the_file(tmp_path, monkeypatch):
    f = tmp_path / "log.txt"
    f.write_text(TEXT)

    def empty(*a, **k):
        raise MemoryError

    monkeypatch.setattr(_table.np, "empty", empty)
    with TextFile(f) as tf, pytest.raises(TorlabInputError) as e:
        read_columns(tf, 4, _spec())
    assert e.value.path == "f.txt" and "not enough memory to read this file" in e.value.message
