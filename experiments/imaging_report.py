"""The strategy chart's report (``experiments/imaging.py``): its Markdown tables and its figure
of points per second against accuracy and completeness, with issue 28's references and goals."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mitsonar.evaluation.coverage import SURFACE_CLASSES
from mitsonar.plots import _pyplot, save_png

#: Issue 28's references [points/s]: OFDM frames back to back on office, one echo per beam, 43
#: points per 208.5 ms frame with the paper preset and 24 with the physical default (broadband
#: transducers), and its goals as (multiple of the reference, share within 2 cm).
TODAY_POINTS_PER_S = {"paper": 208.0, "default": 115.0, "broadband": 115.0}
GOALS = {"paper": (10.0, 0.90), "default": (3.0, 0.70), "broadband": (3.0, 0.70)}
#: Marker colour per preset (the physical ones drawn open).
COLOURS = {"paper": "C0", "default": "C1", "broadband": "C2"}
#: Surface classes as the figure names them.
CLASS_LABELS = {"below": "horizontal,\nbelow the head",
                "above": "horizontal,\nabove the head"}
#: Completeness [%] below which the figure draws it at this value (log scale).
COMPLETENESS_FLOOR = 0.1
MARKERS = {"sequential_first": "s", "sequential_all": "D", "sequential_cells": "P",
           "ofdm_first": "o", "ofdm_all": "^", "ofdm_cells": "v", "ofdm_trusted": "p",
           "ofdm_image": "X", "imaging": "*", "imaging_trust_0.35": "<", "imaging_trust_0.5": ">",
           "imaging_chirp": "h", "imaging_chirp_trust_0.35": "3", "imaging_chirp_trust_0.5": "4",
           "imaging_chirp_wide": "d", "imaging_chirp_wide_trust_0.35": "1",
           "imaging_chirp_wide_trust_0.5": "2", "imaging_chirp_wide_bands": "$B$",
           "imaging_chirp_wide_bands_trust_0.35": "+", "imaging_chirp_wide_bands_trust_0.5": "x",
           "imaging_chirp_wide_defocused": "$D$", "imaging_chirp_wide_defocused_trust_0.35": "|",
           "imaging_chirp_wide_defocused_trust_0.5": "_"}


def markdown(rows) -> list[str]:
    """The chart as a Markdown table (fractions in %)."""
    md = ["| scene | preset | strategy | frames/s | frames simulated | points/frame | points/s | "
          "x today | within 2 cm % | completeness 5 cm % | VLP-16 5 cm % | in sonar's view % | "
          "sim s/frame |",
          "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    md += [f"| {r['scene']} | {r['preset']} | {r['strategy']} | {r['frame_rate_hz']:.2f} | "
           f"{r['frames_simulated']} of {r['frames_total']} | {r['points_per_frame']:.1f} | "
           f"{r['points_per_s']:.0f} | {r['points_per_s_vs_today']:.2f} | "
           f"{r['accuracy_pct']:.1f} | {r['completeness_5cm_pct']:.1f} | "
           f"{r['vlp16_completeness_5cm_pct']:.1f} | {r['sonar_in_view_pct']:.1f} | "
           f"{r['sim_seconds_per_frame']:.2f} |"
           for r in rows]
    return md + ["", "Completeness within 5 cm by surface class (share of the observable "
                 "surface; of each class: in the sonar's view, the VLP-16's, the strategy's):", ""
                 ] + surface_markdown(rows)


def surface_markdown(rows) -> list[str]:
    """Completeness by surface class (``<class>_*_pct`` columns) as a Markdown table."""
    md = ["| scene | preset | strategy | " + " | ".join(
              f"{c}: share / in view / VLP-16 / sonar %" for c in SURFACE_CLASSES[:3]) + " |",
          "|---|---|---|" + "---:|" * 3]
    md += [f"| {r['scene']} | {r['preset']} | {r['strategy']} | " + " | ".join(
               " / ".join(f"{r[f'{c}_{k}_pct']:.1f}" for k in
                          ("share", "in_view", "vlp16", "completeness"))
               for c in SURFACE_CLASSES[:3]) + " |" for r in rows]
    return md


def save_figure(path: Path, rows) -> None:
    """Points per second against accuracy (top) and completeness (bottom, log scale; values under
    ``COMPLETENESS_FLOOR`` drawn at it), a column per scene, a colour per preset (the physical
    ones open); issue 28's references dotted and goals dashed in each preset's colour (the
    physical default's and broadband's coincide), the VLP-16's completeness and half of it (the
    goal) in black, the share in the sonar's field of view (the ceiling) in grey."""
    plt = _pyplot()
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    presets = list(dict.fromkeys(r["preset"] for r in rows))
    fig, axes = plt.subplots(2, len(scenes), figsize=(6.5 * len(scenes), 9.5), squeeze=False)
    for col, scene in enumerate(scenes):
        mine = [r for r in rows if r["scene"] == scene]
        top, bottom = axes[0, col], axes[1, col]
        for r in mine:
            colour = COLOURS[r["preset"]]
            style = dict(marker=MARKERS[r["strategy"]], s=70, color=colour,
                         facecolors=colour if r["preset"] == "paper" else "none")
            x = max(r["points_per_s"], 1.0)
            top.scatter(x, r["accuracy_pct"], **style)
            bottom.scatter(x, max(r["completeness_5cm_pct"], COMPLETENESS_FLOOR), **style)
        lidar = mine[0]["vlp16_completeness_5cm_pct"]
        bottom.axhline(lidar, color="k", lw=1.2, label=f"VLP-16 at 10 Hz ({lidar:.1f} %)")
        bottom.axhline(lidar / 2, color="k", lw=1, ls=":", label="half the VLP-16's (goal)")
        in_view = mine[0]["sonar_in_view_pct"]
        bottom.axhline(in_view, color="grey", lw=1.2, ls="-.",
                       label=f"in the sonar's field of view ({in_view:.1f} %, its ceiling)")
        for preset in presets:
            colour, today = COLOURS[preset], TODAY_POINTS_PER_S[preset]
            times, accuracy = GOALS[preset]
            for ax in (top, bottom):
                ax.axvline(today, color=colour, ls=":", lw=1)
                ax.axvline(times * today, color=colour, ls="--", lw=1)
            top.axhline(100 * accuracy, color=colour, ls="--", lw=1,
                        label=f"{preset}: today {today:.0f} points/s (dotted), goal {times:g}x "
                              f"and {100 * accuracy:.0f} % within 2 cm (dashed)")
        for ax, label in ((top, "points within 2 cm [%]"),
                          (bottom, "completeness within 5 cm [%], simulated frames")):
            ax.set_xscale("log")
            ax.set_xlabel("points per second of driving")
            ax.set_ylabel(label)
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
        top.set_ylim(40, 101)
        bottom.set_yscale("log")
        bottom.set_ylim(COMPLETENESS_FLOOR / 1.5, 100)
        top.set_title(f"{scene}: 1 frame in {mine[0]['stride']} simulated")
        top.legend(loc="lower left", fontsize=7)
        bottom.legend(loc="center left", fontsize=8)
    handles = [plt.Line2D([], [], marker=m, ls="", color="grey",
                          label=s.replace("_", ", ", 1).replace("_", " "))
               for s, m in MARKERS.items()]
    handles += [plt.Line2D([], [], marker="o", ls="", color=COLOURS[p], label=p,
                           markerfacecolor=COLOURS[p] if p == "paper" else "none")
                for p in presets]
    fig.legend(handles=handles, loc="lower center", ncol=6, fontsize=8)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    save_png(fig, path)


def best_mapping(rows) -> dict:
    """The row of ``rows`` (one scene's) with the highest completeness among those meeting
    their preset's accuracy goal (:data:`GOALS`), or of all if none does."""
    good = [r for r in rows if r["accuracy_pct"] >= 100 * GOALS[r["preset"]][1]]
    return max(good or rows, key=lambda r: r["completeness_5cm_pct"])


def save_surface_figure(path: Path, rows) -> None:
    """Where the maps are incomplete: per scene (a panel each) and surface class, the share of
    the observable surface [%] that the class is, that lies in the sonar's view, that the
    VLP-16 covers within 5 cm and that the most complete strategy meeting its accuracy goal
    covers (:func:`best_mapping`); each bar a class's share times its fraction, so a colour's
    bars add up to its whole figure."""
    plt = _pyplot()
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    fig, axes = plt.subplots(1, len(scenes), figsize=(5.5 * len(scenes), 4.2), squeeze=False)
    for ax, scene in zip(axes.flat, scenes):
        best = best_mapping([r for r in rows if r["scene"] == scene])
        bars = {"observable surface": None, "in the sonar's view": "in_view",
                "VLP-16 at 10 Hz": "vlp16",
                f"{best['strategy']} ({best['preset']})": "completeness"}
        x = np.arange(len(SURFACE_CLASSES))
        share = np.array([best[f"{c}_share_pct"] for c in SURFACE_CLASSES])
        top = 0.0
        for k, (label, part) in enumerate(bars.items()):
            fraction = 1.0 if part is None else np.nan_to_num(
                [best[f"{c}_{part}_pct"] / 100 for c in SURFACE_CLASSES])
            value = share * fraction
            ax.bar(x + 0.2 * (k - 1.5), value, 0.2, color=("0.85", "0.55", "k", "C0")[k],
                   label=f"{label}: {value.sum():.1f} %")
            top = max(top, float(value.max()))
        ax.set_ylim(0, 1.45 * top)  # room for the legend above the bars
        ax.set_xticks(x, [CLASS_LABELS.get(c, c) for c in SURFACE_CLASSES], fontsize=8)
        ax.set_ylabel("share of the observable surface [%]")
        ax.set_title(f"{scene}: 1 frame in {int(best['stride'])} simulated", fontsize=10)
        ax.grid(True, axis="y", lw=0.3, alpha=0.5)
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_png(fig, path)
