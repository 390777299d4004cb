"""matplotlib figures of the 4D dataset (notebook 10): gait-cycle segmentation, cycle counts
per motion type and subject, cycle durations."""

from __future__ import annotations

import numpy as np


def plot_segmentation(ax, curves: np.ndarray, fps: float, cycles, reference=None, title: str = ""):
    """Hip flexion curves (F, 2) over time with detected cycles shaded and boundaries marked
    (left-start cycles in blue, right-start in red)."""
    t = np.arange(len(curves)) / fps
    ax.plot(t, curves[:, 0], color="#1f77b4", label="left hip flexion")
    ax.plot(t, curves[:, 1], color="#d62728", label="right hip flexion")
    for c in cycles:
        col = "#1f77b4" if c.side == "L" else "#d62728"
        ax.axvspan(c.start / fps, c.end / fps, color=col, alpha=0.08)
        for f in (c.start, c.end):
            ax.axvline(f / fps, color=col, ls="--", lw=1)
        ax.text((c.start + c.end) / 2 / fps, np.nanmax(curves) + 2,
                f"{c.side} {c.distance:.1f}", ha="center", fontsize=8, color=col)
    if reference is not None:
        ax.axvspan(reference[0] / fps, reference[1] / fps, color="k", alpha=0.06, label="reference cycle")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("flexion (deg)")
    ax.set_title(title, fontsize=10)
    return ax


def plot_counts(ax, counts, colors: dict | None = None):
    """Stacked bars: cycles per motion type, one colour per subject (``counts``: type x subject)."""
    counts = counts.drop(index="total", columns="total", errors="ignore")
    bottom = np.zeros(len(counts))
    for subj in counts.columns:
        vals = counts[subj].values
        ax.bar(counts.index, vals, bottom=bottom, color=(colors or {}).get(subj), label=subj)
        bottom += vals
    ax.set_ylabel("cycles")
    ax.legend(fontsize=7, ncol=2)
    return ax


def plot_durations(ax, cycles_df, bins=np.arange(0.3, 3.01, 0.1)):
    """Histogram of cycle durations (s) per motion type."""
    for typ, g in cycles_df.groupby("type"):
        ax.hist(g["duration_s"], bins=bins, alpha=0.6, label=f"{typ} ({len(g)})")
    ax.set_xlabel("cycle duration (s)")
    ax.set_ylabel("cycles")
    ax.legend(fontsize=8)
    return ax
