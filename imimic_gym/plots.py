"""Figures a person would rather look at than read: angle tracking like the paper's Fig. 4."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from imimic_gym.kinematics import wrap_angle
from imimic_gym.metrics import OCCLUDED
from imimic_gym.rollout import Trajectory

__all__ = ["plot_tracking"]


def plot_tracking(trajectory: Trajectory, path: str | Path, title: str = "",
                  target_label: str = "human") -> Path:
    """Two panels over time: target (the human's true angle, or ``target_label``) vs robot
    angle per joint (deg), and the error (deg).

    Frames where more than 10% of the moving links are hidden are shaded.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = trajectory.time
    human, robot = np.degrees(trajectory.target), np.degrees(trajectory.robot)
    error = np.degrees(wrap_angle(trajectory.robot - trajectory.target))
    fig, (ax_angle, ax_error) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j in range(human.shape[1]):
        c = colours[j % len(colours)]
        ax_angle.plot(t, human[:, j], color=c, lw=2, alpha=0.45, label=f"{target_label} q{j + 1}")
        ax_angle.plot(t, robot[:, j], color=c, lw=1.2, ls="--", label=f"robot q{j + 1}")
        ax_error.plot(t, error[:, j], color=c, lw=1.2, label=f"q{j + 1}")
    hidden = trajectory.occlusion > OCCLUDED
    for ax in (ax_angle, ax_error):
        if hidden.any():
            ax.fill_between(t, 0, 1, where=hidden, color="grey", alpha=0.15,
                            transform=ax.get_xaxis_transform(), label="occluded > 10%")
        ax.grid(alpha=0.3)
    ax_angle.set_ylabel("joint angle (deg)")
    ax_error.set_ylabel(f"robot - {target_label} (deg)")
    ax_error.set_xlabel("time (s)")
    ax_error.axhline(0, color="black", lw=0.6)
    ax_angle.legend(loc="upper right", fontsize=8, ncol=2)
    ax_error.legend(loc="upper right", fontsize=8)
    if title:
        ax_angle.set_title(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
