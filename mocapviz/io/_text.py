"""Shared helpers for the text readers: decoding, fast number parsing, error lines."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import numpy as np

from mocapviz.errors import MocapFormatError

# Candidate file length units (metres per unit), tried when a file does not say its unit.
LENGTH_UNITS = {
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    "cmu": 0.0254 / 0.45,  # CMU/VICON ASF: `length 0.45` means one unit is 1/0.45 inch
}
TYPICAL_HEIGHT_M = 1.7


def decode(raw: bytes) -> str:
    """UTF-8, or Latin-1 for bytes that are not UTF-8 (HDM05's comments)."""
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def read_text(path: str | Path) -> str:
    return decode(Path(path).read_bytes())


def guess_length_unit(height_in_file_units: float) -> float:
    """Metres per file unit: the candidate that makes the skeleton closest to 1.7 m tall."""
    if not np.isfinite(height_in_file_units) or height_in_file_units <= 0:
        return 1.0
    return min(LENGTH_UNITS.values(),
               key=lambda u: abs(np.log(height_in_file_units * u / TYPICAL_HEIGHT_M)))


def fast_number_table(data: bytes) -> np.ndarray | None:
    """(rows, cols) float64 table of whitespace-separated numbers, or None if not clean.

    Only the success path is taken from here: a ragged row, a non-number, NaN/inf, a
    lone CR, comments or quotes make it return None, and callers then run the exact
    line-by-line path that names the offending line.

    Why np.loadtxt and not a hand-written parser: measured on the real files (96-column
    CMU frames, 99-column H3.6M lines), numpy's C loadtxt parses ~65 MB/s with values
    equal to Python's ``float(str)`` (it uses the same correctly rounded conversion;
    tests/test_io_bvh.py checks every CMU value and a sample of H3.6M). A vectorised numpy
    byte-level decimal parser was written and measured at 10-25 MB/s (small 2-D
    reductions over tokens dominate), pandas' C reader at ~30 MB/s on 96 columns
    (per-column overhead) and ``np.array(text.split(), float)`` at ~40 MB/s.
    """
    if not data.strip():
        return np.zeros((0, 0))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            values = np.loadtxt(io.BytesIO(data), dtype=np.float64, comments=None, ndmin=2,
                                encoding="latin-1")
    except (ValueError, OverflowError):
        return None
    if not np.isfinite(values).all():
        return None
    return values


def _is_finite_number(tok: str) -> bool:
    if "_" in tok:  # Python's float() accepts "1_0"; no motion format does
        return False
    try:
        return bool(np.isfinite(float(tok)))
    except ValueError:
        return False


def parse_number_lines(block: str | bytes, n_values: int, first_line: int, path, n_lines: int | None = None,
                       what: str = "frame", sep: str | None = None) -> np.ndarray:
    """Parse lines of exactly ``n_values`` numbers each into an (n_lines, n_values) array.

    Blank lines are skipped. Any line with the wrong count, or a token that is not a
    number, raises MocapFormatError at its 1-based line number (``first_line`` is the
    number of the block's first line in the file). ``sep`` (e.g. ",") is a separator
    allowed besides whitespace.
    """
    data = block.encode("utf-8", errors="surrogateescape") if isinstance(block, str) else bytes(block)
    if sep:
        data = data.replace(sep.encode(), b" ")
    values = fast_number_table(data)
    if values is not None and (values.shape[1:] == (n_values,) or values.size == 0) \
            and (n_lines is None or len(values) == n_lines):
        return values.reshape(len(values), n_values)
    return _parse_number_lines_slow(data.decode("latin-1"), n_values, first_line, path, n_lines, what)


def _parse_number_lines_slow(block: str, n_values, first_line, path, n_lines, what) -> np.ndarray:
    """Line-by-line parse that names the first bad line (used when the fast path refuses)."""
    lines = block.split("\n")
    rows = []
    last = first_line
    for k, line in enumerate(lines):
        toks = line.split()
        if not toks:
            continue
        last = first_line + k
        if len(toks) != n_values:
            raise MocapFormatError(path, last, f"expected {n_values} values on a {what} line, found {len(toks)}")
        for tok in toks:
            if not _is_finite_number(tok):
                raise MocapFormatError(path, last, f"not a finite number: {tok!r}")
        rows.append(toks)
    if n_lines is not None and len(rows) != n_lines:
        raise MocapFormatError(path, last, f"file declares {n_lines} {what}s but has {len(rows)}"
                               + (" (truncated?)" if len(rows) < n_lines else ""))
    return np.array(rows, dtype=np.float64).reshape(len(rows), n_values)
