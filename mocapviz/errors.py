"""Errors raised on bad input files."""

from __future__ import annotations

from pathlib import Path


class MocapFormatError(ValueError):
    """A motion file is malformed. Names the file and, when known, the 1-based line."""

    def __init__(self, path: str | Path | None, line: int | None, message: str):
        self.path = None if path is None else str(path)
        self.line = line
        self.message = message
        where = self.path or "<text>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {message}")
