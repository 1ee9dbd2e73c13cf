"""The one reader layer of torlab's text instrument files: bytes -> lines -> numeric rows.

Every parser reads its file through :class:`TextFile` and its numeric rows through
:func:`read_columns`, :func:`iter_column_blocks` or :func:`parse_rows`, so every reader
keeps the same rules:

* **Regular, bounded files.**  A path must be a regular file (no FIFO or device) of at
  most :data:`MAX_TEXT_BYTES`; its size is checked before anything is read.
* **Encodings.**  UTF-8 with or without BOM; Windows-1252 where a file is not UTF-8 (PCS
  software writes it); UTF-16 with its BOM (Excel's "Unicode text").  A NUL byte in the
  first 4 KiB is a binary file.
* **Line ends.**  LF, CR LF, CR alone and CR CR LF (a CR LF file converted once more) are
  each one line end, in the header and in the data alike, so a header line can never
  shift the first data row.
* **Rows.**  Every data row has the header's number of fields: one more (a decimal comma
  in a comma-separated file) or one fewer (a truncated row) is an error naming the file
  and the line -- never a row read with its fields shifted.  Every cell is a finite number
  in plain decimal notation with the file's decimal mark (``.`` unless the file declares
  ``,``); a cell with the other mark, text, NaN or infinity is an error naming the file,
  line and column.  An empty cell, or a cell of spaces, is a missing value where the
  column may be empty and an error elsewhere.  A value beyond :data:`MAX_MAGNITUDE` in SI
  units is a broken cell, not a measurement.  Blank and ``#`` lines may end the data, not
  interrupt it.
* **Streaming.**  Data are read in blocks of :data:`BLOCK_BYTES`: a first pass checks
  every row's field count and counts the rows (numpy over the bytes), a second parses
  the used columns (pandas' C parser) into arrays allocated once.  Reading a log takes
  the memory of its used columns (8 bytes a value), not of its text.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import IO, Any

import numpy as np

from torlab.errors import TorlabInputError

__all__ = ["BLOCK_BYTES", "MAX_MAGNITUDE", "MAX_TEXT_BYTES", "RowSpec", "TextFile",
           "head_text", "iter_column_blocks", "memory_error", "number_field", "parse_rows", "read_columns"]

#: largest text input read (bytes)
MAX_TEXT_BYTES = 1 << 30
#: bytes read and parsed at a time
BLOCK_BYTES = 4 << 20
#: the largest magnitude of a value in SI units that is taken for a measurement
MAX_MAGNITUDE = 1e100

# ASCII digits only: float() also reads the digits of other scripts ('\u0664'), pandas does not
NUMBER_FIELD = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)",
                          re.IGNORECASE | re.ASCII)
_LINE_END = re.compile(rb"\r+\n|\r")

PathOrBuffer = str | os.PathLike[str] | IO[str] | IO[bytes]


def number_field(f: str, *, path: Any, line: int, column: str, shown: str | None = None
                 ) -> float:
    """One field of a data row as a finite number; the error names the file, line and column.

    Only plain decimal numbers are taken (``float()`` alone would accept ``'1_0'``
    or surrounding control characters); ``nan`` and ``inf`` are refused.
    """
    shown = f if shown is None else shown
    if not NUMBER_FIELD.fullmatch(f):
        raise TorlabInputError(f"{shown!r} is not a number", path=path, line=line,
                               key=f"column {column!r}")
    v = float(f)
    if not math.isfinite(v):
        raise TorlabInputError(f"{shown!r} is not a finite number", path=path, line=line,
                               key=f"column {column!r}")
    return v


# ------------------------------------------------------------------------------ the file
class TextFile:
    """A text input (path, bytes or text buffer) read in blocks of whole, normalised lines.

    Parameters
    ----------
    src
        Path, or a binary or text buffer.
    name
        Name for messages (default: the path, the buffer's ``name`` or ``<buffer>``).
    max_bytes
        Largest input accepted.

    Raises
    ------
    TorlabInputError
        Missing, a folder, not a regular file, larger than ``max_bytes`` (said before
        reading it), a binary file, unreadable.
    """

    def __init__(self, src: PathOrBuffer, *, name: str | None = None,
                 max_bytes: int = MAX_TEXT_BYTES) -> None:
        self._ended_without_newline = False
        if isinstance(src, (str, os.PathLike)):
            from torlab.files import open_regular

            p = os.fspath(src)
            self.display = str(name or p)
            try:
                f = open_regular(p)
            except TorlabInputError as e:
                raise TorlabInputError(e.message, path=self.display) from None
            size = os.fstat(f.fileno()).st_size
            if size > max_bytes:
                f.close()
                raise self._too_large(max_bytes)
            self._f: Any = f
        else:
            self.display = str(name or getattr(src, "name", None) or "<buffer>")
            raw = src.read(max_bytes + 1)
            if isinstance(raw, str):
                raw = raw.encode("utf-8", "surrogatepass")
            if len(raw) > max_bytes:
                raise self._too_large(max_bytes)
            self._f = io.BytesIO(raw)
        self._start = 0
        self._f.seek(0, os.SEEK_END)
        #: bytes of the input (of its UTF-8 text for a UTF-16 file)
        self.size = self._f.tell()
        self._f.seek(0)
        bom = self._read(4)
        if bom.startswith(b"\xef\xbb\xbf"):
            self._start = 3
        elif bom[:2] in (b"\xff\xfe", b"\xfe\xff"):  # UTF-16: read as UTF-8 from here on
            self._f.seek(0)
            data = self._read(-1)
            self._f.close()
            self._f = io.BytesIO(data.decode("utf-16", "replace").encode("utf-8"))
            self.size = len(self._f.getbuffer())
        self._f.seek(self._start)
        if b"\x00" in self._read(4096):
            self.close()
            raise TorlabInputError("binary file, expected text", path=self.display)

    def _too_large(self, max_bytes: int) -> TorlabInputError:
        return TorlabInputError(f"larger than {max_bytes >> 20} MiB; torlab reads text files up "
                                "to that size", path=self.display)

    def _read(self, n: int) -> bytes:
        try:
            return self._f.read(n)
        except OSError as e:
            raise TorlabInputError(f"cannot read ({e.strerror})", path=self.display) from None

    def close(self) -> None:
        """Close the file."""
        self._f.close()

    def __enter__(self) -> TextFile:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- lines ------------------------------------------------------------------
    def blocks(self, block: int | None = None) -> Iterator[bytes]:
        """The file in blocks of whole lines (about ``block`` bytes, default
        :data:`BLOCK_BYTES`), each line ended by ``\\n`` (every line end normalised; one
        added at the end)."""
        block = block or BLOCK_BYTES
        self._f.seek(self._start)
        held = b""  # CRs at the end of a read: their LF may come with the next one
        parts: list[bytes] = []  # the start of a line that is longer than a block
        while True:
            raw = self._read(block)
            piece = held + raw if held else raw
            held = b""
            if raw and piece.endswith(b"\r"):
                cut = len(piece) - 1
                while cut and piece[cut - 1] == 13:
                    cut -= 1
                piece, held = piece[:cut], piece[cut:]
            if b"\r" in piece:
                piece = _LINE_END.sub(b"\n", piece)
            if not raw:
                tail = b"".join([*parts, piece])
                if tail:
                    if not tail.endswith(b"\n"):
                        tail += b"\n"
                        self._ended_without_newline = True
                    yield tail
                return
            k = piece.rfind(b"\n")
            if k < 0:
                parts.append(piece)
                continue
            out = b"".join([*parts, piece[: k + 1]]) if parts else piece[: k + 1]
            parts = [piece[k + 1:]] if k + 1 < len(piece) else []
            yield out

    def iter_lines(self, block: int = 1 << 16) -> Iterator[tuple[int, str]]:
        """``(line number, text)`` of every line, decoded (UTF-8, else Windows-1252); read
        in small blocks (a header is short)."""
        first = 1
        for b in self.blocks(block):
            try:
                text = b.decode("utf-8")
            except UnicodeDecodeError:
                text = "\n".join(_decode_line(ln) for ln in b.split(b"\n"))
            lines = text.split("\n")[:-1]
            for k, s in enumerate(lines):
                yield first + k, s
            first += len(lines)

    def head(self, stop: Callable[[int, str], bool]) -> list[str]:
        """The lines up to and including the first one for which ``stop(line number,
        text)`` is true (every line when none is)."""
        out: list[str] = []
        for ln, s in self.iter_lines():
            out.append(s)
            if stop(ln, s):
                break
        return out

    def read_text(self) -> str:
        """The whole text, ``\\n`` line ends, no BOM (UTF-8, else Windows-1252 throughout)."""
        data = b"".join(self.blocks())
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            text = data.decode("cp1252", errors="replace")
        if self._ended_without_newline:
            text = text[:-1]
        return text


def head_text(src: PathOrBuffer, n: int = 1 << 14, *, name: str | None = None) -> str:
    """The first ``n`` bytes of a text file as text (encodings and line ends as
    :class:`TextFile` reads them; for telling formats apart)."""
    with TextFile(src, name=name) as tf:
        out = []
        got = 0
        for b in tf.blocks(max(n, 1 << 12)):
            out.append(b)
            got += len(b)
            if got >= n:
                break
    data = b"".join(out)[:n]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        if e.start >= len(data) - 3:  # a character cut at the end
            return data[: e.start].decode("utf-8")
        return data.decode("cp1252", errors="replace")


def _decode_line(b: bytes) -> str:
    try:
        return b.decode("utf-8")
    except UnicodeDecodeError:
        return b.decode("cp1252", errors="replace")


# ------------------------------------------------------------------------------ rows
@dataclass
class RowSpec:
    """How to read the data rows of one table.

    Attributes
    ----------
    names
        Every field's name as the header gives it (their number is the field count).
    use
        Indices of the fields returned, in this order.
    path
        File name for messages.
    delimiter, decimal
        Field separator and decimal mark (``decimal=","`` only with another delimiter).
    allow_empty
        Per used field, whether an empty cell (a missing value, NaN) is allowed.
    scales, offsets
        Per used field, the conversion to SI (``value * scale + offset``).
    units
        Per used field, the unit written (for messages about a value too large).
    hint
        Added to the message about a cell with a decimal comma (where the file could
        declare one).
    """

    names: Sequence[str]
    use: Sequence[int]
    path: str
    delimiter: str = ","
    decimal: str = "."
    allow_empty: Sequence[bool] | None = None
    scales: Sequence[float] | None = None
    offsets: Sequence[float] | None = None
    units: Sequence[str] | None = None
    hint: str = ""
    _empty: list[bool] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        k = len(self.use)
        self._empty = [False] * k if self.allow_empty is None else list(self.allow_empty)
        if len(self.delimiter) != 1 or self.delimiter in "\r\n\"" or self.delimiter == self.decimal:
            raise ValueError(f"bad delimiter {self.delimiter!r} (decimal {self.decimal!r})")

    @property
    def ncol(self) -> int:
        return len(self.names)

    def column(self, j: int) -> str:
        """The name of field ``j`` for messages."""
        return str(self.names[j]).strip() or f"column {j + 1}"


def _region(tf: TextFile, first_line: int) -> Iterator[bytes]:
    """The blocks from line ``first_line`` on (the lines before it dropped)."""
    line = 1
    for b in tf.blocks():
        if line >= first_line:
            yield b
            continue
        n = b.count(b"\n")
        if line + n <= first_line:
            line += n
            continue
        k = -1
        for _ in range(first_line - line):
            k = b.index(b"\n", k + 1)
        line = first_line
        if k + 1 < len(b):
            yield b[k + 1:]


class _Survey:
    """The first look at each block of rows: field counts, blank and ``#`` lines.

    Blank and ``#`` lines may only end the data: one that is followed by a data row (in
    this block or a later one) is an error naming it.
    """

    def __init__(self, spec: RowSpec, line_of: Callable[[int], int]) -> None:
        self.spec = spec
        self.line_of = line_of
        self.dbyte = ord(spec.delimiter)
        self.gap: tuple[int, str] | None = None  # a blank/'#' line after the last row so far
        self.rows = 0  # data rows so far
        self.idx = 0  # lines so far

    def block(self, b: bytes) -> int:
        """Check the lines of block ``b``: the number of its lines up to its last data row
        (all of them rows).

        The usual block costs one pass for its line ends and one count of its delimiters:
        when the data lines hold as many delimiters as they should together, no line has
        more than its share either (:func:`_parse_block` has pandas refuse a line with
        more fields), so none has fewer.  Otherwise every line is counted and the first
        wrong one named.
        """
        spec, want = self.spec, self.spec.ncol - 1
        a = np.frombuffer(b, np.uint8)
        ends = np.flatnonzero(a == 10)
        n = len(ends)
        if n == 0:
            return 0
        starts = np.empty_like(ends)
        starts[0] = 0
        starts[1:] = ends[:-1] + 1
        blank = ends == starts
        comment = ~blank & (a[np.minimum(starts, len(a) - 1)] == 35)
        gaps = blank | comment
        idx0 = self.idx
        self.idx += n
        last = self._last(gaps, blank)
        if last < 0:
            return 0
        if gaps[:last].any() or int(np.count_nonzero(a[: int(ends[last])] == self.dbyte)) \
                != (last + 1) * want:
            delims = np.flatnonzero(a == self.dbyte)
            cnt = np.diff(np.searchsorted(delims, ends), prepend=0)
            odd = ~gaps & (cnt != want)
            for i in np.flatnonzero(odd):  # lines of spaces, indented '#' lines: gaps
                text = b[starts[i]: ends[i]].decode("utf-8", "replace")
                if not text.strip():
                    blank[i], odd[i] = True, False
                elif text.lstrip().startswith("#"):
                    comment[i], odd[i] = True, False
            gaps = blank | comment
            last = self._last(gaps, blank)
            if last < 0:
                return 0
            bad = np.flatnonzero(odd[: last + 1] | np.r_[gaps[:last], False])
            if len(bad):
                i = int(bad[0])
                if gaps[i]:
                    _gap_error((self.line_of(idx0 + i), "blank" if blank[i] else "#"), spec)
                _count_error(b[starts[i]: ends[i]], self.line_of(idx0 + i), spec)
        tail = np.flatnonzero(gaps[last + 1:])
        if len(tail):
            i = last + 1 + int(tail[0])
            self.gap = (self.line_of(idx0 + i), "blank" if blank[i] else "#")
        self.rows += last + 1
        return last + 1

    def _last(self, gaps: np.ndarray, blank: np.ndarray) -> int:
        """The block's last data line (-1: none); a gap before the block's first data line
        that came in an earlier block is an error."""
        data = ~gaps
        if not data.any():
            if self.gap is None and gaps.any():
                i = int(np.argmax(gaps))
                self.gap = (self.line_of(self.idx - len(gaps) + i),
                            "blank" if blank[i] else "#")
            return -1
        if self.gap is not None:
            _gap_error(self.gap, self.spec)
        return len(gaps) - 1 - int(np.argmax(data[::-1]))


def _gap_error(gap: tuple[int, str], spec: RowSpec) -> None:
    line, kind = gap
    what = {"blank": "blank line", "#": "a '#' line"}.get(kind, "a blank or '#' line")
    raise TorlabInputError(f"{what} between data rows", path=spec.path, line=line)


def _count_error(row: bytes, line: int, spec: RowSpec) -> None:
    s = row.decode("utf-8", "replace")
    k = s.count(spec.delimiter) + 1
    d = spec.delimiter
    hint = ""
    if k < spec.ncol:
        hint = " (a truncated row?)"
    elif k == spec.ncol + 1 and d == "," and spec.decimal == "." and \
            re.search(r"(?:^|,)\s*[+-]?\d+,\d+\s*(?:,|$)", s):
        hint = " (a decimal comma in a comma-separated file?)"
    shown = {"\t": "tab", ",": "','", ";": "';'"}.get(d, repr(d))
    raise TorlabInputError(f"expected {spec.ncol} fields separated by {shown} like the column "
                           f"header, found {k}{hint}", path=spec.path, line=line)


def _parse_block(data: bytes, spec: RowSpec, first_idx: int,
                 line_of: Callable[[int], int]) -> list[np.ndarray]:
    """Second pass on one block of checked rows: the used columns as float arrays, in SI,
    every value checked."""
    import pandas as pd

    use = list(spec.use)
    vals: list[np.ndarray] | None = None
    # every field parsed (no usecols, which would drop a row's extra fields silently), after
    # a first row of the right length (pandas would take extra fields in the first row for
    # an index): a row with more fields is an error, one with fewer the survey's
    first = (spec.delimiter.join(["0"] * spec.ncol) + "\n").encode()
    try:
        df = pd.read_csv(
            io.BytesIO(first + data), sep=spec.delimiter, decimal=spec.decimal, header=None,
            names=list(range(spec.ncol)), dtype=dict.fromkeys(use, np.float64), engine="c",
            skip_blank_lines=False, keep_default_na=False, na_values=[""], on_bad_lines="error",
            quoting=csv.QUOTE_NONE, encoding="utf-8", encoding_errors="replace")
        vals = [df[j].to_numpy(dtype=np.float64)[1:] for j in use]
    except MemoryError:
        raise
    except Exception:  # a cell pandas cannot read: the exact scan names it (or reads it)
        vals = None
    if vals is None:
        vals = _scan_block(data, spec, first_idx, line_of)
    out = []
    for k, (j, v) in enumerate(zip(use, vals, strict=True)):
        sc = 1.0 if spec.scales is None else spec.scales[k]
        off = 0.0 if spec.offsets is None else spec.offsets[k]
        usual = not len(v) or (-MAX_MAGNITUDE <= v.min() and v.max() <= MAX_MAGNITUDE)
        if not usual:  # NaN, infinity or a huge number somewhere (NaN fails the test above)
            fin = np.isfinite(v)
            if not fin.all():
                bad = ~fin & ~(np.isnan(v) & spec._empty[k])
                if bad.any():
                    _cell_error(data, int(np.argmax(bad)), j, spec, first_idx, line_of)
        if sc != 1.0 or off != 0.0:
            with np.errstate(over="ignore"):
                v = v * sc + off
            usual = usual and (not len(v) or bool(-MAX_MAGNITUDE <= v.min()
                                                  and v.max() <= MAX_MAGNITUDE))
        if usual:
            out.append(v)  # the usual column: every value finite and in range
            continue
        with np.errstate(invalid="ignore"):
            big = np.abs(v) > MAX_MAGNITUDE
        if big.any():
            i = int(np.argmax(big))
            cell = _cell_text(data, i, j, spec)
            unit = f" {spec.units[k]}" if spec.units is not None and spec.units[k] else ""
            raise TorlabInputError(f"{cell}{unit} is too large to be a measurement (beyond "
                                   f"{MAX_MAGNITUDE:g} in SI units)", path=spec.path,
                                   line=line_of(first_idx + i), key=f"column {spec.column(j)!r}")
        out.append(v)
    return out


def _row(data: bytes, i: int) -> str:
    k0 = -1
    for _ in range(i):
        k0 = data.index(b"\n", k0 + 1)
    k1 = data.index(b"\n", k0 + 1)
    return data[k0 + 1: k1].decode("utf-8", "replace")


def _cell_text(data: bytes, i: int, j: int, spec: RowSpec) -> str:
    return _row(data, i).split(spec.delimiter)[j].strip()


def _cell_error(data: bytes, i: int, j: int, spec: RowSpec, first_idx: int,
                line_of: Callable[[int], int]) -> None:
    raw = _row(data, i).split(spec.delimiter)[j]
    cell = raw.strip()
    msg = (f"{cell!r} is not a finite number" if cell else
           "a cell of spaces (write a number)" if raw else "empty value (write a number)")
    raise TorlabInputError(msg, path=spec.path, line=line_of(first_idx + i),
                           key=f"column {spec.column(j)!r}")


def _scan_block(data: bytes, spec: RowSpec, first_idx: int,
                line_of: Callable[[int], int]) -> list[np.ndarray]:
    """Every used cell of a block read one by one (where pandas refused one): the values,
    or the error naming the first cell that is not a number."""
    rows = data.decode("utf-8", "replace").split("\n")[:-1]
    out = np.full((len(rows), len(spec.use)), np.nan)
    dec = spec.decimal
    for i, row in enumerate(rows):
        fields = row.split(spec.delimiter)
        ln = line_of(first_idx + i)
        if len(fields) != spec.ncol:
            _count_error(row.encode("utf-8", "surrogatepass"), ln, spec)
        for k, j in enumerate(spec.use):
            raw = fields[j]
            f = raw.strip(" \t")
            col = spec.column(j)
            if not f:
                if spec._empty[k]:
                    continue
                msg = "empty value" if not raw else "a cell of spaces"
                raise TorlabInputError(f"{msg} (write a number)", path=spec.path, line=ln,
                                       key=f"column {col!r}")
            if dec != ".":
                if "." in f:
                    raise TorlabInputError(f"{f!r} has a decimal point, but the file's decimal "
                                           f"mark is {dec!r}", path=spec.path, line=ln,
                                           key=f"column {col!r}")
                g = f.replace(dec, ".")
            else:
                if "," in f and NUMBER_FIELD.fullmatch(f.replace(",", ".", 1)):
                    raise TorlabInputError(f"{f!r} has a decimal comma, but the file's decimal "
                                           f"mark is '.'{spec.hint}", path=spec.path, line=ln,
                                           key=f"column {col!r}")
                g = f
            out[i, k] = number_field(g, path=spec.path, line=ln, column=col, shown=f)
    return [out[:, k].copy() for k in range(len(spec.use))]


def _blocks_of_rows(tf: TextFile, first_line: int, spec: RowSpec
                    ) -> Iterator[tuple[int, list[np.ndarray], int]]:
    def line_of(i: int) -> int:
        return first_line + i

    survey = _Survey(spec, line_of)
    done = 0
    for b in _region(tf, first_line):
        before = survey.idx
        m = survey.block(b)
        if m:
            k = -1
            if m < survey.idx - before:
                for _ in range(m):
                    k = b.index(b"\n", k + 1)
                b = b[: k + 1]
            yield first_line + done, _parse_block(b, spec, done, line_of), len(b)
        done = survey.idx
    if survey.rows == 0:
        raise TorlabInputError("no data rows after the column header", path=spec.path,
                               line=first_line - 1)


def iter_column_blocks(tf: TextFile, first_line: int, spec: RowSpec
                       ) -> Iterator[tuple[int, list[np.ndarray]]]:
    """``(line of the block's first row, used columns)`` for the data rows from line
    ``first_line`` on, block by block, each block checked before it is given (see the
    module docstring).

    Raises
    ------
    TorlabInputError
        No data rows, a row with another field count, a blank or ``#`` line between
        rows, a cell that is not a finite number (or empty where allowed), a value beyond
        :data:`MAX_MAGNITUDE` -- naming the file, line (and column).
    """
    for first, cols, _ in _blocks_of_rows(tf, first_line, spec):
        yield first, cols


def read_columns(tf: TextFile, first_line: int, spec: RowSpec) -> list[np.ndarray]:
    """The used columns of every data row (from line ``first_line`` on), one array each:
    :func:`iter_column_blocks` without holding the blocks (each array is allocated for
    the rows the file's size suggests and grown in place where it holds more).

    Raises
    ------
    TorlabInputError
        As :func:`iter_column_blocks`; also when the memory runs out (naming the file).
    """
    try:
        out: list[np.ndarray] = []
        done = 0
        for _, cols, nbytes in _blocks_of_rows(tf, first_line, spec):
            m = len(cols[0]) if cols else 0
            if not out:  # the rows the file holds at this block's bytes per row
                cap = max(m, int(tf.size * max(m, 1) / max(nbytes, 1) * 1.02) + 64)
                out = [np.empty(cap) for _ in spec.use]
            if done + m > len(out[0]):
                cap = max(done + m, int(1.25 * len(out[0])))
                for v in out:
                    v.resize(cap, refcheck=False)
            for k, v in enumerate(cols):
                out[k][done: done + m] = v
            done += m
        for v in out:
            v.resize(done, refcheck=False)
        return out if out else [np.empty(0) for _ in spec.use]
    except MemoryError:
        raise TorlabInputError(f"not enough memory to read this file ({_size(tf)})",
                               path=spec.path) from None


def memory_error(src: Any, name: str | None = None, what: str = "read") -> TorlabInputError:
    """The error for a file that memory ran out on (a :class:`MemoryError` in its reader or
    reduction): one line naming the file and its size."""
    display = str(name or (os.fspath(src) if isinstance(src, (str, os.PathLike)) else
                           getattr(src, "name", None) or "<buffer>"))
    size = ""
    if isinstance(src, (str, os.PathLike)):
        try:
            size = f" ({os.path.getsize(src) / 1e6:.0f} MB)"
        except OSError:
            pass
    return TorlabInputError(f"not enough memory to {what} this file{size}", path=display)


def _size(tf: TextFile) -> str:
    try:
        return f"{os.fstat(tf._f.fileno()).st_size / 1e6:.0f} MB"
    except (OSError, AttributeError, io.UnsupportedOperation):
        return "in memory"


def parse_rows(lines: Sequence[str], line_nos: Sequence[int] | np.ndarray | int,
               spec: RowSpec) -> np.ndarray:
    """The used columns of in-memory data rows as an ``(n_rows, n_used)`` array.

    ``line_nos`` is the file line of each row, or of the first (the rows following each
    other).  Rows as in :func:`iter_column_blocks`, except that blank or ``#`` lines at the
    end are the caller's to drop.
    """
    n = len(lines)
    if isinstance(line_nos, (int, np.integer)):
        start = int(line_nos)

        def line_of(i: int) -> int:
            return start + i
    else:
        arr = np.asarray(line_nos)

        def line_of(i: int) -> int:
            return int(arr[min(i, len(arr) - 1)]) if len(arr) else i + 1
    if n == 0:
        return np.empty((0, len(spec.use)))
    data = ("\n".join(lines) + "\n").encode("utf-8", "surrogatepass")
    got = _Survey(spec, line_of).block(data)
    if got == 0:
        _gap_error((line_of(0), "blank"), spec)
    if got < n:  # blank or '#' lines at the end: not data rows here
        _gap_error((line_of(got), "blank" if not lines[got].strip() else "#"), spec)
    cols = _parse_block(data, spec, 0, line_of)
    return np.column_stack(cols) if cols else np.empty((n, 0))
