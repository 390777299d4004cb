"""matplotlib figures: bone lengths and heights across subjects, dataset summaries."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from mocapviz.viz.figures import save_figure

# The segment each VICON/CMU joint's offset measures (the bone that ends at that joint).
# Joints whose offset is zero in every VICON tree (LHipJoint, LowerBack, ...) are absent.
VICON_BONE_NAMES = {
    "LeftUpLeg": "pelvis L", "LeftLeg": "thigh L", "LeftFoot": "shin L", "LeftToeBase": "foot L",
    "RightUpLeg": "pelvis R", "RightLeg": "thigh R", "RightFoot": "shin R", "RightToeBase": "foot R",
    "Spine": "lower back", "Spine1": "upper back", "Neck": "thorax", "Neck1": "lower neck",
    "Head": "upper neck",
    "LeftShoulder": "thorax→clav. L", "LeftArm": "clavicle L", "LeftForeArm": "upper arm L",
    "LeftHand": "forearm L",
    "RightShoulder": "thorax→clav. R", "RightArm": "clavicle R", "RightForeArm": "upper arm R",
    "RightHand": "forearm R",
}


def bone_length_table(skeletons: dict, bones: dict | None = None) -> pd.DataFrame:
    """Bone lengths in metres, one row per skeleton (name -> Skeleton), one column per bone.

    Columns follow ``bones`` (joint name -> label; default :data:`VICON_BONE_NAMES`); a
    skeleton without that joint gets NaN. A ``height`` column holds standing_height().
    """
    bones = VICON_BONE_NAMES if bones is None else bones
    rows = {}
    for name, sk in skeletons.items():
        lengths = sk.bone_lengths()
        rows[name] = {label: (lengths[sk.index(j)] if j in sk.names else np.nan) for j, label in bones.items()}
        rows[name]["height"] = sk.standing_height()
    return pd.DataFrame.from_dict(rows, orient="index")


def plot_bone_lengths(table: pd.DataFrame, colors: dict | None = None, path: str | Path | None = None,
                      title: str = "Skeletons: standing height and bone lengths"):
    """Two panels: standing height per subject (bars), bone lengths as a heat map (cm).

    ``table`` comes from :func:`bone_length_table`. Returns the figure; saves it if ``path``.
    """
    heights = table["height"]
    lengths = table.drop(columns="height") * 100.0
    n = len(table)
    fig, (ax_h, ax_m) = plt.subplots(1, 2, figsize=(15, 0.32 * n + 2.2), width_ratios=[1, 5.5],
                                     sharey=True, layout="constrained")
    y = np.arange(n)
    bar_colors = [colors.get(s, "grey") for s in table.index] if colors else "grey"
    ax_h.barh(y, heights.values, color=bar_colors)
    for yi, h in zip(y, heights.values):
        ax_h.text(h - 0.03, yi, f"{h:.2f}", va="center", ha="right", fontsize=8, color="white")
    ax_h.set_xlim(max(0.0, heights.min() - 0.35), heights.max() + 0.05)
    ax_h.set_xlabel("standing height (m)")
    ax_h.set_yticks(y, table.index)
    ax_h.invert_yaxis()
    im = ax_m.imshow(lengths.values, aspect="auto", cmap="viridis")
    ax_m.set_xticks(np.arange(lengths.shape[1]), lengths.columns, rotation=45, ha="right")
    vmid = np.nanmean(lengths.values)
    for (i, j), v in np.ndenumerate(lengths.values):
        if np.isfinite(v):
            ax_m.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=7,
                      color="white" if v < vmid else "black")
    fig.colorbar(im, ax=ax_m, label="bone length (cm)", shrink=0.8)
    fig.suptitle(title)
    save_figure(fig, path, dpi=120)
    return fig


def plot_dataset_minutes(catalog: pd.DataFrame, order=None, path: str | Path | None = None):
    """Seconds of motion per subject, stacked by motion type, total written above each bar.

    ``order``: subjects left to right (default: catalog order).
    """
    seconds = catalog.pivot_table(index="subject", columns="motion_type", values="duration_s",
                                  aggfunc="sum", fill_value=0.0, sort=False)
    seconds = seconds.reindex(list(order) if order is not None else seconds.index)
    fig, ax = plt.subplots(figsize=(11, 4), layout="constrained")
    seconds.plot.bar(stacked=True, ax=ax, width=0.8, colormap="tab20", legend=True)
    for x, total in enumerate(seconds.sum(axis=1)):
        ax.text(x, total + 1.5, f"{total:.0f}" if total >= 10 else f"{total:.1f}", ha="center", fontsize=7)
    ax.set_ylim(0, seconds.sum(axis=1).max() * 1.1)
    ax.set_ylabel("seconds of motion")
    ax.set_xlabel("")
    ax.set_title("Motion per subject and type (HDM05 actors left, CMU subjects right)")
    ax.legend(fontsize=7, ncol=2, bbox_to_anchor=(1.01, 1), loc="upper left")
    save_figure(fig, path, dpi=120)
    return fig
