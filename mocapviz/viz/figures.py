"""matplotlib figure output: save to a file, show in a notebook (one home for both)."""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib.pyplot as plt


def save_figure(fig, path: str | Path | None, dpi: int = 120) -> Path | None:
    """Write ``fig`` to ``path`` (format from the suffix), creating its folder; no-op for None."""
    if path is None:
        return None
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def show_figure(fig) -> None:
    """Display a figure as PNG in a notebook, whatever the matplotlib backend, and close it.

    ``MPLBACKEND=Agg`` (set by the Makefile for headless runs) would otherwise leave the
    notebook without the figure; closing it avoids a second copy under the inline backend.
    """
    from IPython.display import Image, display

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    display(Image(data=buf.getvalue()))
