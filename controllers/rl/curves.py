"""Training curves (reward, episode length, value loss) from a training log, as PNG (matplotlib, no torch)."""

from __future__ import annotations

import csv
from pathlib import Path

LOG_FIELDS = ("timesteps", "wall_s", "ep_rew_mean", "ep_len_mean", "value_loss", "policy_loss", "entropy")


def read_log(path: Path) -> dict[str, list[float]]:
    """Columns of a training log CSV (empty cells as NaN)."""
    columns: dict[str, list[float]] = {name: [] for name in LOG_FIELDS}
    with path.open() as fh:
        for row in csv.DictReader(fh):
            for name in LOG_FIELDS:
                value = row.get(name, "")
                columns[name].append(float(value) if value not in ("", None) else float("nan"))
    return columns


def plot_curves(log: Path, png: Path, title: str = "") -> Path:
    """Draw reward, episode length and value loss against environment steps into ``png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = read_log(log)
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for ax, key, label in zip(
        axes,
        ("ep_rew_mean", "ep_len_mean", "value_loss"),
        ("mean episode reward", "mean episode length [decisions]", "value loss"),
    ):
        ax.plot(data["timesteps"], data[key])
        ax.set_xlabel("environment steps")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return png
