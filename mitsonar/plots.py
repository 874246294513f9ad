"""Figures people look at instead of reading numbers. Degrees appear only here and at the CLI."""

from __future__ import annotations

import numpy as np

from mitsonar.frames import fov_angles
from mitsonar.io import atomic_path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path) -> None:
    """Save a matplotlib figure as PNG (110 dpi), atomically, and close it."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    _pyplot().close(fig)


def save_scan_figure(path, scan, title: str = "") -> None:
    """Depth and echo amplitude over the scanned directions, plus a top view of the points."""
    plt = _pyplot()
    h, v = (np.degrees(a) for a in fov_angles(scan.directions))
    hs, vs = np.unique(np.round(h, 6)), np.unique(np.round(v, 6))
    grid_shape = (len(vs), len(hs))
    depth = np.full(grid_shape, np.nan)
    amp = np.full(grid_shape, np.nan)
    iv = np.searchsorted(vs, np.round(v, 6))
    ih = np.searchsorted(hs, np.round(h, 6))
    depth[iv, ih] = scan.depth
    amp[iv, ih] = 20 * np.log10(np.maximum(scan.amplitude, 1e-12))
    extent = [hs[0] - 0.5 * _step(hs), hs[-1] + 0.5 * _step(hs),
              vs[-1] + 0.5 * _step(vs), vs[0] - 0.5 * _step(vs)]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    cmap = plt.get_cmap("viridis").with_extremes(bad="0.75")
    im = axes[0].imshow(depth, extent=extent, cmap=cmap, aspect="equal")
    fig.colorbar(im, ax=axes[0], label="depth [m] (grey: no detection)")
    axes[0].set_title("depth per beam")
    im = axes[1].imshow(amp, extent=extent, cmap="magma", aspect="equal")
    fig.colorbar(im, ax=axes[1], label="echo amplitude [dB re 1 Pa]")
    axes[1].set_title("strongest echo per beam")
    for ax in axes[:2]:
        ax.set_xlabel("horizontal angle [deg] (right +)")
        ax.set_ylabel("vertical angle [deg] (down +)")
    p = scan.points_sensor[scan.detected]
    axes[2].scatter(p[:, 0], p[:, 2], c=p[:, 1], s=12, cmap="coolwarm")
    axes[2].plot([0], [0], "k^", label="sensor")
    axes[2].set_xlabel("sensor x (right) [m]")
    axes[2].set_ylabel("sensor z (forward) [m]")
    axes[2].set_title("detected points, top view (colour: height, down +)")
    axes[2].set_aspect("equal", adjustable="datalim")
    axes[2].legend(loc="lower right")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    save_png(fig, path)


def _step(values) -> float:
    return float(np.min(np.diff(values))) if len(values) > 1 else 1.0
