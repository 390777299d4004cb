"""Colours shared by the 3D scenes and the matplotlib plots: one per subject, time ramps."""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps
from matplotlib.colors import to_hex

# HDM05 actors in warm tones, CMU subjects in cool/neutral ones, so the two sources separate
# at a glance; within a source, subjects keep the order they are given in.
_WARM = ["#d62728", "#ff7f0e", "#bcbd22", "#8c564b", "#e377c2", "#f7b6d2", "#ffbb78", "#c49c94"]


def subject_colors(subjects, sources=None) -> dict[str, str]:
    """Hex colour per subject. ``sources`` (same length) separates HDM05 from CMU palettes."""
    subjects = list(subjects)
    sources = list(sources) if sources is not None else ["" for _ in subjects]
    cool = colormaps["tab20"].colors
    cool = [c for i, c in enumerate(cool) if i not in (2, 3, 6, 7, 10, 11, 12, 13, 16, 17)]  # drop warm
    cool += list(colormaps["tab20b"].colors[::2])
    out, n_warm, n_cool = {}, 0, 0
    for subj, src in zip(subjects, sources):
        if subj in out:
            continue
        if src == "hdm05" and n_warm < len(_WARM):
            out[subj] = _WARM[n_warm]
            n_warm += 1
        else:
            out[subj] = to_hex(cool[n_cool % len(cool)])
            n_cool += 1
    return out


def time_colors(n: int, cmap: str = "viridis") -> list[str]:
    """``n`` colours from the start (dark) to the end (light) of a cycle."""
    cm = colormaps[cmap]
    return [to_hex(cm(x)) for x in np.linspace(0.0, 0.95, n)]
