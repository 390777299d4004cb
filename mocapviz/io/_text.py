"""Shared helpers for the text readers: decoding, fast number parsing, error lines."""

from __future__ import annotations

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


def read_text(path: str | Path) -> str:
    """File text; bytes that are not UTF-8 (HDM05's Latin-1 comments) decode as Latin-1."""
    raw = Path(path).read_bytes()
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def guess_length_unit(height_in_file_units: float) -> float:
    """Metres per file unit: the candidate that makes the skeleton closest to 1.7 m tall."""
    if not np.isfinite(height_in_file_units) or height_in_file_units <= 0:
        return 1.0
    return min(LENGTH_UNITS.values(),
               key=lambda u: abs(np.log(height_in_file_units * u / TYPICAL_HEIGHT_M)))


def tokens_per_line(block: str) -> tuple[np.ndarray, np.ndarray]:
    """Whitespace-separated token counts of every line of ``block`` and line start offsets.

    Vectorised over the bytes so a whole motion section is checked in milliseconds; only
    ASCII whitespace separates tokens, as in the formats we read.
    """
    b = np.frombuffer(block.encode("latin-1", errors="replace"), dtype=np.uint8)
    if b.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    space = (b == 32) | (b == 9) | (b == 13) | (b == 10) | (b == 11) | (b == 12)
    starts = ~space & np.concatenate([[True], space[:-1]])
    newlines = np.flatnonzero(b == 10)
    ends = np.concatenate([newlines, [b.size]]) if (newlines.size == 0 or newlines[-1] != b.size - 1) else newlines
    csum = np.concatenate([[0], np.cumsum(starts)])
    counts = np.diff(np.concatenate([[0], csum[ends]]))
    line_starts = np.concatenate([[0], ends[:-1] + 1])
    return counts, line_starts


def parse_number_lines(block: str, n_values: int, first_line: int, path, n_lines: int | None = None,
                       what: str = "frame") -> np.ndarray:
    """Parse lines of exactly ``n_values`` numbers each into an (n_lines, n_values) array.

    Blank lines are skipped. Any line with the wrong count, or a token that is not a
    number, raises MocapFormatError at its 1-based line number (``first_line`` is the
    number of the block's first line in the file).
    """
    counts, _ = tokens_per_line(block)
    nonblank = np.flatnonzero(counts)
    wrong = nonblank[counts[nonblank] != n_values]
    if wrong.size:
        k = int(wrong[0])
        raise MocapFormatError(path, first_line + k,
                               f"expected {n_values} values on a {what} line, found {int(counts[k])}")
    if n_lines is not None and nonblank.size != n_lines:
        last = first_line + (int(nonblank[-1]) if nonblank.size else 0)
        raise MocapFormatError(path, last, f"file declares {n_lines} {what}s but has {nonblank.size}"
                               + (" (truncated?)" if nonblank.size < n_lines else ""))
    tokens = block.split()
    try:
        values = np.array(tokens, dtype=np.float64)
    except ValueError:
        values = None
    if values is None or not np.all(np.isfinite(values)):
        lines = block.split("\n")
        for k in nonblank:
            for tok in lines[k].split():
                try:
                    ok = np.isfinite(float(tok))
                except ValueError:
                    ok = False
                if not ok:
                    raise MocapFormatError(path, first_line + int(k), f"not a finite number: {tok!r}")
    return values.reshape(nonblank.size, n_values)
