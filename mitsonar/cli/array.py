"""``mitsonar array design|plot``: the sparse-array genetic algorithm and its figures."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from mitsonar.cli.arguments import command_group, output_directory, output_file
from mitsonar.io import write_json
from mitsonar.design.evaluation import BeamCriteria, evaluate_layout, uniform_pair
from mitsonar.design.figures import make_figures, metrics_rows
from mitsonar.design.genetic import GASettings, design_arrays
from mitsonar.design.record import default_layout_path, format_summary, layout_record


def add_cli(subparsers) -> None:
    """``mitsonar array design`` and ``mitsonar array plot``."""
    sub = command_group(subparsers, "array",
                        help="design and plot the sparse transmit/receive arrays",
                        description="Sparse 5x5 array design by genetic algorithm, and "
                                    "beam-pattern figures.")
    d = sub.add_parser(
        "design", help="run the genetic algorithm and write the layout JSON",
        description="Design the interleaved transmit and receive 5x5 layouts by a seeded genetic "
                    "algorithm that minimises the worst one-way PSLL over the field of view, with "
                    "the broadside 3 dB width held near 5 deg; print uniform vs optimised PSLL "
                    "and the widths; write the layout JSON (by default the shipped layout).")
    defaults = GASettings()
    d.add_argument("--seed", type=int, default=defaults.seed,
                   help=f"seed of the genetic algorithm (default {defaults.seed})")
    d.add_argument("--generations", type=int, default=defaults.generations,
                   help=f"generations the algorithm runs (default {defaults.generations})")
    d.add_argument("--population", type=int, default=defaults.population,
                   help=f"layouts per generation (default {defaults.population})")
    d.add_argument("--out", type=output_file, default=None,
                   help="layout JSON file to write, replaced if present (default: the shipped "
                        "mitsonar/physics/array_layout.json)")
    d.set_defaults(func=_run_design)
    _add_plot(sub)


def _run_design(args) -> int:
    from tqdm import tqdm

    settings = GASettings(seed=args.seed, generations=args.generations, population=args.population)
    criteria = BeamCriteria()
    out = args.out if args.out is not None else default_layout_path()
    with tqdm(total=settings.generations, desc="GA generations", unit="gen", file=sys.stderr) as bar:
        def progress(_, best, psll):
            bar.set_postfix_str(f"objective {best:.2f} dB, worst PSLL {psll:.2f} dB", refresh=False)
            bar.update()
        result = design_arrays(settings, criteria, progress=progress)
    t0 = time.perf_counter()
    metrics = evaluate_layout(result.tx.positions, result.rx.positions, criteria)
    grid = uniform_pair()
    uniform = evaluate_layout(grid[0], grid[1], criteria)
    record = layout_record(result, metrics, uniform)
    record["design"]["evaluation_s"] = round(time.perf_counter() - t0, 1)
    write_json(out, record)
    print(format_summary(metrics, uniform, result))
    print(f"Wrote {out}.")
    return 0


def _add_plot(subparsers) -> None:
    """``mitsonar array plot``."""
    p = subparsers.add_parser(
        "plot", help="beam-pattern figures and the PSLL / width table",
        description="Write the element pattern, the transducer frequency response, the layouts, "
                    "uniform vs optimised beam patterns at 0 deg and steered, PSLL and 3 dB width "
                    "over the field of view (PNG), and a table of PSLL and widths (CSV, Markdown).")
    p.add_argument("--layout", type=Path, default=None,
                   help="layout JSON file (default: the shipped "
                        "mitsonar/physics/array_layout.json)")
    p.add_argument("--out", type=output_directory, default="out/array",
                   help="output directory, created if absent; its files are replaced "
                        "(default out/array)")
    p.set_defaults(func=_run_plot)


def _run_plot(args) -> int:
    from tqdm import tqdm

    with tqdm(total=9, desc="array figures", unit="step", file=sys.stderr) as bar:
        metrics = make_figures(args.out, args.layout,
                               progress=lambda name: (bar.set_postfix_str(name), bar.update()))
    for row in metrics_rows(metrics):
        print(f"{row['layout']:22s} {row['pattern']:22s} worst PSLL {row['worst_psll_db']:6.2f} dB, "
              f"broadside 3 dB width {row['broadside_width_h_deg']:.2f} x "
              f"{row['broadside_width_v_deg']:.2f} deg")
    print(f"Wrote {args.out}/: element_pattern.png, frequency_response.png, layout.png, "
          "beam_patterns.png, beam_cuts.png, psll_width_fov.png, ga_convergence.png (if recorded), "
          "array_metrics.csv, array_metrics.md.")
    return 0
