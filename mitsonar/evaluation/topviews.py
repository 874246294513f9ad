"""Top views of scored reconstructions side by side (the paper's Fig. 7): a row per scene, a
panel per reconstruction, points coloured by their distance to the ground truth."""

from __future__ import annotations

import textwrap
from dataclasses import dataclass

import numpy as np

from mitsonar.plots import _pyplot, save_png

#: Top views drop points this close to the floor and to the ceiling [m].
FLOOR_MARGIN = 0.15
CEILING_MARGIN = 0.3
#: Colour scale of the distances is clipped here [m].
ERROR_CLIP = 0.10
#: Characters of the 10 pt title per inch of figure width (wrapped to fit).
TITLE_CHARS_PER_INCH = 13


@dataclass(frozen=True)
class Panel:
    """One reconstruction in the figure.

    Attributes:
        title: what is drawn and its scores (one or two lines).
        points: (N, 3) [m]; distance: (N,) their distance to the ground truth [m].
        note: drawn in red across the panel (e.g. why it is nearly empty); '' for none.
    """

    title: str
    points: np.ndarray
    distance: np.ndarray
    note: str = ""


@dataclass(frozen=True)
class SceneView:
    """What a row needs about its scene: ceiling height [m], interior extent {'x': (lo, hi),
    'y': (lo, hi)} [m], viewpoints (V, 3) [m] of the sensor head along the drive and outline
    (P, 3) [m], ground-truth samples drawn in grey."""

    height: float
    extent: dict
    viewpoints: np.ndarray
    outline: np.ndarray


def save_top_views(path, rows: dict, title: str, max_points: int = 80_000) -> None:
    """``rows``: scene name -> (:class:`SceneView`, list of :class:`Panel`); the grid has as
    many columns as the longest row. Floor and ceiling are left out (they would hide the rest);
    points are drawn lowest first, at most ``max_points`` a panel (a seeded subset)."""
    plt = _pyplot()
    cols = max(len(panels) for _, panels in rows.values())
    height = 4.3 * len(rows) + 1.2  # [inches]; the colour bar and its label take the last 1.2
    fig, axes = plt.subplots(len(rows), cols, squeeze=False, figsize=(4.6 * cols, height))
    rng = np.random.default_rng(0)
    im = None
    for row, (view, panels) in zip(axes, rows.values()):
        for ax, panel in zip(row, panels):
            z = panel.points[:, 2]
            keep = (z > FLOOR_MARGIN) & (z < view.height - CEILING_MARGIN)
            p, d = panel.points[keep], panel.distance[keep]
            if len(p) > max_points:
                pick = rng.choice(len(p), max_points, replace=False)
                p, d = p[pick], d[pick]
            order = np.argsort(p[:, 2], kind="stable")
            ax.scatter(*view.outline[:, :2].T, c="0.8", s=0.2, linewidths=0)
            im = ax.scatter(p[order, 0], p[order, 1], c=100 * d[order], cmap="turbo", vmin=0,
                            vmax=100 * ERROR_CLIP,
                            s=float(np.clip(3000 / max(len(p), 1), 0.6, 6)), linewidths=0)
            ax.plot(*view.viewpoints[:, :2].T, "k.-", lw=0.6, ms=3)
            ax.set_xlim(np.add(view.extent["x"], [-0.3, 0.3]))
            ax.set_ylim(np.add(view.extent["y"], [-0.3, 0.3]))
            ax.set_aspect("equal")
            ax.set_title(panel.title, fontsize=8)
            ax.tick_params(labelsize=7)
            if panel.note:
                ax.text(0.5, 0.04, panel.note, transform=ax.transAxes, ha="center",
                        va="bottom", fontsize=7, color="firebrick",
                        bbox=dict(facecolor="white", alpha=0.8, edgecolor="firebrick", lw=0.5))
        for ax in row[len(panels):]:
            ax.set_visible(False)
    lines = textwrap.wrap(title, width=int(TITLE_CHARS_PER_INCH * 4.6 * cols))  # fits the width
    # The title hangs from 0.1 in below the top edge, its 10 pt lines 0.2 in apart: a fixed
    # height in inches, not a fraction of the figure (which grows with the rows).
    fig.suptitle("\n".join(lines), fontsize=10, y=1 - 0.1 / height, va="top")
    fig.tight_layout(rect=(0, 1.2 / height, 1, 1 - (0.2 + 0.2 * len(lines)) / height))
    if im is not None:
        bar = fig.add_axes((0.25, 0.75 / height, 0.5, 0.1 / height))
        fig.colorbar(im, cax=bar, orientation="horizontal",
                     label=f"distance to ground truth [cm] (clipped at {100 * ERROR_CLIP:.0f})")
    save_png(fig, path)
