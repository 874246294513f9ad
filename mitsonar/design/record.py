"""What a design run leaves: the layout file (its JSON record, reading it back, the shipped path)
and the printed summary of uniform against optimised beams (degrees and dB)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np

from mitsonar.design.evaluation import BeamCriteria, LayoutMetrics, named_units
from mitsonar.design.genetic import DesignResult
from mitsonar.physics.array import APERTURE, LAYOUT_FILE, MIN_SPACING, ArrayGeometry, ArrayLayout


def default_layout_path() -> Path:
    """Path of the shipped layout file, mitsonar/physics/array_layout.json."""
    return Path(str(resources.files("mitsonar.physics").joinpath(LAYOUT_FILE)))


def layout_record(result: DesignResult, metrics: LayoutMetrics,
                  uniform: LayoutMetrics) -> dict:
    """The JSON record of a design: positions, metrics (optimised and uniform), seed, settings."""
    def pos(layout):
        return [[round(float(x), 6), round(float(y), 6)] for x, y in layout.positions]

    s = result.settings
    return {
        "name": f"GA-optimised interleaved 5x5 pair (seed {s.seed})",
        "note": ("Written by `mitsonar array design` (mitsonar.design.genetic). Positions in "
                 "metres, tx relative to the transmit origin (sensor origin), rx relative to the "
                 "receive origin at (baseline, 0) in the sensor plane. Metrics: exact evaluation "
                 "over the field of view (one-way PSLL of each array, two-way PSLL of the pair, "
                 "3 dB widths of the one-way patterns)."),
        "baseline": result.baseline,
        "tx": pos(result.tx),
        "rx": pos(result.rx),
        "metrics": metrics.to_dict(),
        "uniform_metrics": uniform.to_dict(),
        "design": {
            "method": "genetic algorithm over the 50 element centres, joint spacing constraint",
            "seed": s.seed,
            "ga_settings": s.to_dict(),
            "criteria": criteria_record(result.criteria),
            "min_spacing_m": MIN_SPACING,
            "aperture_m": APERTURE,
            "fast_objective_worst_psll_db": round(result.psll_db, 3),
            "objective_db_history": [round(float(v), 3) for v in result.objective_db],
            "runtime_s": round(result.seconds, 1),
        },
    }


def criteria_record(criteria: BeamCriteria) -> dict:
    """Criteria for the JSON record; every key carries its unit."""
    d = criteria.to_dict()
    d["medium"] = named_units(d["medium"], {"temperature": "K", "relative_humidity": "percent",
                                            "pressure": "Pa"})
    d["transducer"] = named_units(d["transducer"], {"radius": "m", "resonance_frequency": "Hz",
                                                    "bandwidth_6db": "Hz",
                                                    "source_amplitude": "Pa"})
    d["wavelength_m"] = round(criteria.wavelength, 7)
    d["speed_of_sound_m_per_s"] = round(criteria.medium.speed_of_sound, 4)
    return d


def load_layout_file(path) -> tuple[ArrayLayout, ArrayLayout, float, dict]:
    """(tx, rx, baseline, whole record) from a layout JSON file; clear errors on bad files."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
        name = data.get("name", path.name)
        tx = ArrayLayout(np.asarray(data["tx"], dtype=float), name=f"{name} (tx)")
        rx = ArrayLayout(np.asarray(data["rx"], dtype=float), name=f"{name} (rx)")
        baseline = float(data["baseline"])
    except FileNotFoundError:
        raise
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as err:
        raise ValueError(f"{path}: not a layout file ({type(err).__name__}: {err})") from None
    ArrayGeometry(tx=tx, rx=rx, baseline=baseline)  # validates the joint spacing
    return tx, rx, baseline, data


def format_summary(metrics: LayoutMetrics, uniform: LayoutMetrics,
                   result: DesignResult | None = None) -> str:
    """Human-readable comparison of uniform and optimised layouts (degrees and dB)."""
    lines = []
    if result is not None:
        s = result.settings
        lines.append(f"GA: seed {s.seed}, population {s.population}, generations {s.generations}, "
                     f"{result.seconds:.0f} s.")
    fov = np.degrees([np.ptp(uniform.steering_horizontal), np.ptp(uniform.steering_vertical)])
    lines.append(f"Worst PSLL over the {fov[0]:.0f} x {fov[1]:.0f} deg field of view (beams "
                 "steered over the field of view, side lobes inside it, element directivity "
                 "included):")
    for label, m in (("uniform 5x5 @ 25 mm", uniform), ("optimised", metrics)):
        lines.append(f"  {label:20s} transmit {m.worst_psll_db('tx'):6.2f} dB, receive "
                     f"{m.worst_psll_db('rx'):6.2f} dB, "
                     f"two-way {m.worst_psll_db('two_way'):6.2f} dB")
    lines.append(f"  improvement (one-way, worse of TX/RX): "
                 f"{uniform.worst_psll_db('one_way') - metrics.worst_psll_db('one_way'):.2f} dB")
    lines.append("Broadside 3 dB width (horizontal x vertical):")
    for label, m in (("uniform 5x5 @ 25 mm", uniform), ("optimised", metrics)):
        w = {n: np.degrees(m.broadside_width[n]) for n in ("tx", "rx")}
        lines.append(f"  {label:20s} transmit {w['tx'][0]:.2f} x {w['tx'][1]:.2f} deg, receive "
                     f"{w['rx'][0]:.2f} x {w['rx'][1]:.2f} deg")
    return "\n".join(lines)
