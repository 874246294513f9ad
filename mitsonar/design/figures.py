"""Figures and tables of the array design: ``mitsonar array plot``. Degrees appear only here.

Writes into the output directory (PNG, CSV, Markdown; every file atomically):

* ``element_pattern.png``: piston directivity of one element (TCT40-10 class) at 32/40/48 kHz.
* ``frequency_response.png``: resonant transducer response over 25-55 kHz, one element and
  transmit x receive, with the OFDM tones.
* ``layout.png``: uniform and optimised transmit/receive layouts on the board.
* ``beam_patterns.png``: one-way patterns over the hemisphere in front, uniform vs optimised,
  steered to 0 deg and two steered directions (like the paper's Fig. 3).
* ``beam_cuts.png``: horizontal cuts of the same beams, dB.
* ``psll_width_fov.png``: PSLL and 3 dB widths of the beam steered to each direction of the field
  of view, uniform vs optimised.
* ``ga_convergence.png``: best objective per generation (if the layout file records it).
* ``array_metrics.csv`` / ``array_metrics.md``: worst PSLL and 3 dB widths, uniform vs optimised.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from mitsonar.design.evaluation import BeamCriteria, evaluate_layout, uniform_pair
from mitsonar.design.record import default_layout_path, load_layout_file
from mitsonar.physics.beampattern import steered_patterns
from mitsonar.frames import direction_from_fov_angles
from mitsonar.io import atomic_path
from mitsonar.plots import _pyplot, save_png

#: Steering directions (horizontal, vertical) [rad] of the beam-pattern figures.
FIGURE_STEERS = (np.radians([0.0, 0.0]), np.radians([20.0, 0.0]), np.radians([30.0, 20.0]))
#: OFDM tones of the repeated-scanning mode [Hz].
OFDM_TONES = np.array([32e3, 36e3, 40e3, 44e3, 48e3])


def _write_text(path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def _db(x, floor: float = -60.0):
    return np.maximum(20 * np.log10(np.maximum(x, 1e-12)), floor)


def plot_element_pattern(path, criteria: BeamCriteria) -> None:
    """Piston directivity D(theta) of one element, dB, at 32, 40 and 48 kHz."""
    plt = _pyplot()
    t = criteria.transducer
    theta = np.radians(np.linspace(-90, 90, 721))
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for f, style in ((32e3, "--"), (40e3, "-"), (48e3, ":")):
        d = t.directivity(np.cos(theta), criteria.medium.wavenumber(f))
        ax.plot(np.degrees(theta), _db(d), style, label=f"{f / 1e3:.0f} kHz")
    ax.axhline(-6.02, color="0.5", lw=0.8)
    ax.axvline(-42.5, color="0.5", lw=0.8)
    ax.axvline(42.5, color="0.5", lw=0.8)
    ax.text(44, -5.5, "datasheet -6 dB\nbeam angle 85 deg", fontsize=8, va="bottom")
    for half, label in ((criteria.fov_horizontal / 2, "horizontal FOV"),
                        (criteria.fov_vertical / 2, "vertical FOV")):
        ax.axvspan(-np.degrees(half), np.degrees(half), alpha=0.08,
                   color="C2" if "hor" in label else "C3", label=label)
    ax.set_xlim(-90, 90)
    ax.set_ylim(-30, 1)
    ax.set_xlabel("angle from the element normal [deg]")
    ax.set_ylabel("directivity D [dB]")
    ax.set_title(f"Element pattern: baffled piston, a = {t.radius * 1e3:.2f} mm "
                 f"(TCT40-10 class), 2 J1(ka sin t)/(ka sin t)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower center", fontsize=8, ncol=3)
    fig.tight_layout()
    save_png(fig, path)


def plot_frequency_response(path, criteria: BeamCriteria) -> None:
    """|H(f)| and phase of the resonant transducer over 25-55 kHz, one way and two way."""
    plt = _pyplot()
    t = criteria.transducer
    f = np.linspace(25e3, 55e3, 3001)
    h = t.frequency_response(f)
    fig, (ax, axp) = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True,
                                  gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(f / 1e3, _db(np.abs(h)), label="one transducer |H|")
    ax.plot(f / 1e3, _db(np.abs(h) ** 2), label="transmit x receive |H|^2")
    ax.axhline(-6.02, color="0.5", lw=0.8)
    f0, bw = t.resonance_frequency, t.bandwidth_6db
    ax.axvspan((f0 - bw / 2) / 1e3, (f0 + bw / 2) / 1e3, color="C2", alpha=0.15,
               label=f"datasheet -6 dB band {bw / 1e3:.0f} kHz")
    tones = t.frequency_response(OFDM_TONES)
    ax.plot(OFDM_TONES / 1e3, _db(np.abs(tones) ** 2), "kv", label="OFDM tones (two-way)")
    for ft, g in zip(OFDM_TONES, _db(np.abs(tones) ** 2)):
        ax.annotate(f"{g:.0f} dB", (ft / 1e3, g), textcoords="offset points", xytext=(0, -14),
                    ha="center", fontsize=8)
    ax.set_ylim(-60, 3)
    ax.set_ylabel("response [dB re f0]")
    ax.set_title(f"Transducer frequency response: resonator f0 = {f0 / 1e3:.0f} kHz, "
                 f"Q = {t.quality_factor:.1f} (from the 2 kHz -6 dB bandwidth)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    axp.plot(f / 1e3, np.degrees(np.angle(h)), label="one transducer")
    axp.plot(f / 1e3, np.degrees(np.angle(h ** 2)), label="transmit x receive")
    axp.set_ylabel("phase [deg]")
    axp.set_xlabel("frequency [kHz]")
    axp.set_xlim(25, 55)
    axp.grid(alpha=0.3)
    axp.legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path)


def plot_layouts(path, layouts: dict, baseline: float) -> None:
    """Element centres and 10 mm cans of each (tx, rx) pair on the board (sensor x right, y down)."""
    plt = _pyplot()
    from matplotlib.patches import Circle, Rectangle

    from mitsonar.physics.array import APERTURE, MIN_SPACING

    fig, axes = plt.subplots(1, len(layouts), figsize=(5.2 * len(layouts), 5))
    for ax, (title, (tx, rx)) in zip(np.atleast_1d(axes), layouts.items()):
        for pos, origin, colour, label in ((tx, 0.0, "C0", "transmit"), (rx, baseline, "C3", "receive")):
            p = (np.asarray(pos)[:, :2] + [origin, 0.0]) * 1e3
            for x, y in p:
                ax.add_patch(Circle((x, y), MIN_SPACING / 2 * 1e3, fc=colour, alpha=0.25, ec=colour))
            ax.plot(p[:, 0], p[:, 1], "+", color=colour, label=f"{label} ({len(p)})")
            half = APERTURE / 2 * 1e3
            ax.add_patch(Rectangle((origin * 1e3 - half, -half), 2 * half, 2 * half, fill=False,
                                   ec=colour, ls="--", lw=0.8))
        ax.set_aspect("equal")
        ax.set_xlim(-60, 60 + baseline * 1e3)
        ax.set_ylim(60, -60)
        ax.set_xlabel("sensor x (right) [mm]")
        ax.set_ylabel("sensor y (down) [mm]")
        ax.set_title(title, fontsize=10)
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"Element layouts: 10 mm cans, dashed: +-5 cm apertures, receive origin "
                 f"{baseline * 1e3:.1f} mm right of the transmit origin", fontsize=10)
    fig.tight_layout()
    save_png(fig, path)


def plot_beam_patterns(path, arrays: dict, criteria: BeamCriteria) -> None:
    """Fig. 3-like maps: one-way pattern (dB re the steered main lobe) over +-80 x +-60 deg."""
    plt = _pyplot()
    from matplotlib.patches import Rectangle

    k = criteria.wavenumber
    h = np.radians(np.linspace(-80, 80, 321))
    v = np.radians(np.linspace(-60, 60, 241))
    hh, vv = np.meshgrid(h, v, indexing="xy")
    u = direction_from_fov_angles(hh, vv).reshape(-1, 3)
    steers = direction_from_fov_angles(*np.array(FIGURE_STEERS).T)
    fig, axes = plt.subplots(len(arrays), len(steers), figsize=(4.4 * len(steers), 3.1 * len(arrays)),
                             squeeze=False, sharex=True, sharey=True, layout="constrained")
    extent = [-80, 80, 60, -60]
    for row, (name, pos) in zip(axes, arrays.items()):
        pat = steered_patterns(pos, steers, u, criteria.transducer, k)
        peak = criteria.transducer.directivity(steers[:, 2], k)
        for ax, p, pk, (sh, sv) in zip(row, pat, peak, FIGURE_STEERS):
            im = ax.imshow(_db(p / pk).reshape(len(v), len(h)), extent=extent, vmin=-30, vmax=5,
                           cmap="magma", aspect="equal")
            fh, fv = np.degrees(criteria.fov_horizontal), np.degrees(criteria.fov_vertical)
            ax.add_patch(Rectangle((-fh / 2, -fv / 2), fh, fv, fill=False, ec="w", ls="--", lw=0.8))
            ax.plot(np.degrees(sh), np.degrees(sv), "c+", ms=10)
            ax.set_title(f"{name}, steered ({np.degrees(sh):.0f}, {np.degrees(sv):.0f}) deg",
                         fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel("horizontal angle [deg]")
    for ax in axes[:, 0]:
        ax.set_ylabel("vertical angle [deg] (down +)")
    fig.colorbar(im, ax=axes, shrink=0.8, label="one-way pattern [dB re steered main lobe]")
    fig.suptitle("One-way beam patterns (element x array factor); dashed: 60 x 40 deg field of view",
                 fontsize=11)
    save_png(fig, path)


def plot_beam_cuts(path, arrays: dict, criteria: BeamCriteria) -> None:
    """Horizontal cuts (vertical angle of the steering) of the beams of :func:`plot_beam_patterns`."""
    plt = _pyplot()
    k = criteria.wavenumber
    h = np.radians(np.linspace(-85, 85, 1701))
    fig, axes = plt.subplots(1, len(FIGURE_STEERS), figsize=(5.2 * len(FIGURE_STEERS), 4),
                             squeeze=False)
    for ax, (sh, sv) in zip(axes[0], FIGURE_STEERS):
        steer = direction_from_fov_angles(sh, sv)[None]
        u = direction_from_fov_angles(h, np.full_like(h, sv))
        for name, pos in arrays.items():
            p = steered_patterns(pos, steer, u, criteria.transducer, k)[0]
            ax.plot(np.degrees(h), _db(p / criteria.transducer.directivity(steer[0, 2], k)),
                    lw=1.0, label=name)
        fh = np.degrees(criteria.fov_horizontal) / 2
        ax.axvspan(-fh, fh, color="0.5", alpha=0.08, label="field of view")
        near = np.sum((u[:, :2] - steer[0, :2]) ** 2, axis=-1) < np.sin(criteria.main_lobe_radius) ** 2
        ax.axvspan(np.degrees(h[near].min()), np.degrees(h[near].max()), color="C2", alpha=0.12,
                   label="main-lobe exclusion")
        ax.axhline(-3.01, color="0.4", lw=0.6, ls=":")
        ax.set_ylim(-40, 5)
        ax.set_xlim(-85, 85)
        ax.set_xlabel("horizontal angle [deg]")
        ax.set_ylabel("one-way pattern [dB re main lobe]")
        ax.set_title(f"steered ({np.degrees(sh):.0f}, {np.degrees(sv):.0f}) deg, cut at vertical "
                     f"{np.degrees(sv):.0f} deg", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    save_png(fig, path)


def plot_psll_width_maps(path, metrics: dict) -> None:
    """PSLL and 3 dB widths of the beam steered to each direction of the field of view."""
    plt = _pyplot()
    panels = []
    for label, (m, name) in metrics.items():
        panels.append((label, m, name))
    fig, axes = plt.subplots(3, len(panels), figsize=(4.0 * len(panels), 8.4), squeeze=False,
                             sharex=True, sharey=True, layout="constrained")
    first = panels[0][1]
    hs, vs = np.degrees(first.steering_horizontal), np.degrees(first.steering_vertical)
    dh, dv = hs[1] - hs[0], vs[1] - vs[0]
    extent = [hs[0] - dh / 2, hs[-1] + dh / 2, vs[-1] + dv / 2, vs[0] - dv / 2]
    psll_all = np.concatenate([m.psll_db[n].ravel() for _, m, n in panels])
    pmin, pmax = np.floor(psll_all.min()), np.ceil(psll_all.max())
    w_all = np.degrees(np.concatenate([m.width[n].ravel() for _, m, n in panels]))
    wmin, wmax = np.nanmin(w_all), np.nanmax(w_all)
    for col, (label, m, name) in enumerate(panels):
        im0 = axes[0, col].imshow(m.psll_db[name], extent=extent, vmin=pmin, vmax=pmax,
                                  cmap="viridis", aspect="equal")
        axes[0, col].set_title(f"{label}\nPSLL, worst {m.worst_psll_db(name):.1f} dB", fontsize=9)
        for r, cut in ((1, "horizontal"), (2, "vertical")):
            w = np.degrees(m.width[name][..., r - 1])
            im1 = axes[r, col].imshow(w, extent=extent, vmin=wmin, vmax=wmax, cmap="cividis",
                                      aspect="equal")
            axes[r, col].set_title(f"3 dB width, {cut} cut ({np.nanmin(w):.1f}-{np.nanmax(w):.1f} deg)",
                                   fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel("steering horizontal [deg]")
    for ax in axes[:, 0]:
        ax.set_ylabel("steering vertical [deg]")
    fig.colorbar(im0, ax=axes[0].tolist(), label="PSLL [dB]", shrink=0.9)
    fig.colorbar(im1, ax=axes[1:].ravel().tolist(), label="3 dB width [deg]", shrink=0.9)
    fig.suptitle("Beam quality over the 60 x 40 deg field of view (side lobes searched inside it)",
                 fontsize=11)
    save_png(fig, path)


def plot_convergence(path, history) -> None:
    """Best objective per GA generation."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 3.8))
    ax.plot(np.arange(len(history)), history)
    ax.set_xlabel("generation")
    ax.set_ylabel("best objective [dB]")
    ax.set_title("Genetic algorithm: worst one-way PSLL (+ width penalty), best of each generation",
                 fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_png(fig, path)


METRIC_COLUMNS = ("layout", "pattern", "worst_psll_db", "broadside_psll_db",
                  "broadside_width_h_deg", "broadside_width_v_deg", "max_width_over_fov_deg")


def metrics_rows(metrics: dict) -> list[dict]:
    """Table rows: label -> (LayoutMetrics, pattern name)."""
    rows = []
    for label, (m, name) in metrics.items():
        layout, pattern = label.split(": ")
        w = np.degrees(m.broadside_width[name])
        rows.append({"layout": layout, "pattern": pattern,
                     "worst_psll_db": round(m.worst_psll_db(name), 2),
                     "broadside_psll_db": round(m.broadside_psll_db(name), 2),
                     "broadside_width_h_deg": round(float(w[0]), 2),
                     "broadside_width_v_deg": round(float(w[1]), 2),
                     "max_width_over_fov_deg": round(float(np.degrees(np.nanmax(m.width[name]))), 2)})
    return rows


def write_tables(out: Path, rows: list[dict], criteria: BeamCriteria) -> None:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=METRIC_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    _write_text(out / "array_metrics.csv", buf.getvalue())
    head = ["layout", "pattern", "worst PSLL over FOV [dB]", "broadside PSLL [dB]",
            "broadside 3 dB width H x V [deg]", "largest 3 dB width over FOV [deg]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append(f"| {r['layout']} | {r['pattern']} | {r['worst_psll_db']:.2f} | "
                     f"{r['broadside_psll_db']:.2f} | {r['broadside_width_h_deg']:.2f} x "
                     f"{r['broadside_width_v_deg']:.2f} | {r['max_width_over_fov_deg']:.2f} |")
    note = (f"\nBeams steered over the {np.degrees(criteria.fov_horizontal):.0f} x "
            f"{np.degrees(criteria.fov_vertical):.0f} deg field of view every "
            f"{np.degrees(criteria.steering_step):g} deg; side lobes searched inside it every "
            f"{np.degrees(criteria.direction_step):g} deg outside a "
            f"{np.degrees(criteria.main_lobe_radius):g} deg main-lobe radius; element directivity "
            f"included; {criteria.frequency / 1e3:g} kHz, c = {criteria.medium.speed_of_sound:.1f} m/s.\n")
    _write_text(out / "array_metrics.md", "\n".join(lines) + "\n" + note)


def make_figures(out, layout_path=None, criteria: BeamCriteria = BeamCriteria(), progress=None) -> dict:
    """Write every figure and table into ``out``; returns {label: (LayoutMetrics, pattern)}.

    Args:
        out: output directory.
        layout_path: layout JSON (default: the shipped one).
        criteria: evaluation criteria.
        progress: optional callable(step_name) after each step.
    """
    out = Path(out)
    tick = progress or (lambda _: None)
    layout_path = Path(layout_path) if layout_path is not None else default_layout_path()
    tx, rx, baseline, record = load_layout_file(layout_path)
    grid = uniform_pair()
    plot_element_pattern(out / "element_pattern.png", criteria)
    tick("element pattern")
    plot_frequency_response(out / "frequency_response.png", criteria)
    tick("frequency response")
    plot_layouts(out / "layout.png", {"uniform 5x5 @ 25 mm (start)": (grid[0], grid[1]),
                                      record.get("name", "optimised"): (tx.positions, rx.positions)},
                 baseline)
    tick("layouts")
    arrays = {"uniform 5x5 @ 25 mm": grid[0], "optimised transmit": tx.positions,
              "optimised receive": rx.positions}
    plot_beam_patterns(out / "beam_patterns.png", arrays, criteria)
    tick("beam patterns")
    plot_beam_cuts(out / "beam_cuts.png", arrays, criteria)
    tick("beam cuts")
    m_uni = evaluate_layout(grid[0], grid[1], criteria)
    tick("uniform metrics")
    m_opt = evaluate_layout(tx.positions, rx.positions, criteria)
    tick("optimised metrics")
    metrics = {"uniform 5x5 @ 25 mm: one-way (TX = RX)": (m_uni, "tx"),
               "optimised: transmit one-way": (m_opt, "tx"),
               "optimised: receive one-way": (m_opt, "rx"),
               "uniform 5x5 @ 25 mm: two-way": (m_uni, "two_way"),
               "optimised: two-way": (m_opt, "two_way")}
    plot_psll_width_maps(out / "psll_width_fov.png",
                         {k: v for k, v in metrics.items() if "uniform 5x5 @ 25 mm: two" not in k})
    tick("PSLL and width maps")
    history = record.get("design", {}).get("objective_db_history")
    if history:
        plot_convergence(out / "ga_convergence.png", history)
    write_tables(out, metrics_rows(metrics), criteria)
    tick("tables")
    return metrics
