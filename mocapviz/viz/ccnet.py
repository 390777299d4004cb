"""matplotlib figures for CCNet: control signals over a clip, training curves, generated speed."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from mocapviz.features.ccnet import FPS, TRAJ_STEPS, FeatureLayout, integrate_root
from mocapviz.heading import yaw_matrix
from mocapviz.viz.figures import save_figure


def plot_controls(x: np.ndarray, traj: np.ndarray, start_root, start_heading: float, title: str = "",
                  every: int = 20, path: str | Path | None = None):
    """A clip's control signals: the root path seen from above with c^d (the next second's root
    positions, drawn back in world coordinates) every ``every`` frames, and over time the
    foot contacts, root speed and heading rate."""
    layout = FeatureLayout((x.shape[1] - 6) // 12)
    b = layout.x_blocks
    root, theta = integrate_root(x[:, b["root"]], start_root, start_heading)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5), gridspec_kw=dict(width_ratios=[1, 1.4]))
    ax0.plot(root[:, 0], root[:, 2], color="0.3", lw=2, label="root path")
    cmap = plt.get_cmap("viridis")
    for n in range(0, len(x), every):
        local = traj[n].reshape(-1, 2)
        world = np.einsum("ab,kb->ka", yaw_matrix(theta[n])[[0, 2]][:, [0, 2]], local) + root[n, [0, 2]]
        ax0.plot(*np.vstack([root[n, [0, 2]], world]).T, "o-", ms=3, lw=0.8, color=cmap(n / len(x)))
        fwd = np.array([np.sin(theta[n]), np.cos(theta[n])]) * 0.15
        ax0.arrow(root[n, 0], root[n, 2], *fwd, head_width=0.04, color="crimson")
    ax0.set_aspect("equal")
    ax0.set_xlabel("X (m)")
    ax0.set_ylabel("Z (m)")
    ax0.set_title(f"c^d: root {TRAJ_STEPS[0]}..{TRAJ_STEPS[-1]} frames ahead (red: heading)", fontsize=9)
    t = np.arange(len(x)) / FPS
    c = x[:, b["contact"]]
    ax1.fill_between(t, 0, c[:, 0] * 0.45, step="mid", color="tab:blue", alpha=0.35, label="left contact")
    ax1.fill_between(t, 0.55, 0.55 + c[:, 1] * 0.45, step="mid", color="tab:orange", alpha=0.35,
                     label="right contact")
    speed = np.hypot(x[:, b["root"]][:, 0], x[:, b["root"]][:, 1])
    ax1.plot(t, speed / max(speed.max(), 1e-6), color="k", label=f"root speed (max {speed.max():.2f} m/s)")
    ax1.plot(t, 0.5 + x[:, b["root"]][:, 2] / (2 * max(np.abs(x[:, b["root"]][:, 2]).max(), 1e-6)),
             color="crimson", lw=0.8, label="heading rate (scaled)")
    ax1.set_xlabel("time (s)")
    ax1.set_yticks([])
    ax1.legend(fontsize=8, loc="upper right")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    return fig


def plot_training_curves(runs: dict[str, str | Path], path: str | Path | None = None):
    """Training loss (smoothed); validation and test NLL per step of each run's ``losses.csv``.

    A dotted vertical line marks each run's best-by-validation step (the exported model).
    """
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4))
    for (name, csv), color in zip(runs.items(), plt.rcParams["axes.prop_cycle"].by_key()["color"]):
        df = pd.read_csv(csv)
        ax0.plot(df.step, df.loss.rolling(25, min_periods=1).mean(), color=color, label=f"{name} train L")
        ax0.plot(df.step, df.nll.rolling(25, min_periods=1).mean(), color=color, ls=":", label=f"{name} train L_G")
        ev = df.dropna(subset=["test_nll"])
        if "val_nll" in ev and ev.val_nll.notna().any():
            ax1.plot(ev.step, ev.val_nll, "o-", color=color, label=f"{name} validation L_G")
            best = ev.loc[ev.val_nll.idxmin()]
            ax1.axvline(best.step, color=color, ls=":", lw=1,
                        label=f"{name} best by validation (step {int(best.step)})")
        ax1.plot(ev.step, ev.test_nll, "s--", color=color, alpha=0.6, label=f"{name} test L_G")
    for ax, title in ((ax0, "training (25-step mean)"), (ax1, "validation (selects the model) and test")):
        ax.set_xlabel("step")
        ax.set_ylabel("nats per frame (normalised units)")
        ax.set_title(title)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    return fig
