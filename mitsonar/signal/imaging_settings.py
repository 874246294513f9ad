"""The settings of receive imaging's points rule (:mod:`mitsonar.signal.imaging`, whose module
docstring states rules 1-5) and the points an image gives."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsonar.validation import check_positive, check_range


@dataclass(frozen=True)
class ImagingSettings:
    """Grid and detection rule of receive imaging (module docstring).

    Attributes:
        step: spacing of the receive directions at broadside [rad] (sin(step) in direction
            cosines).
        detection_snr: threshold over the RMS noise envelope (a cell of noise exceeds it with
            probability exp(-detection_snr^2)).
        detection_floor: absolute threshold on the image [Pa] (needed without receiver noise).
        side_lobe_margin: factor over the side-lobe level predicted from any other single return
            at the same instant that a point must exceed.
        clutter_margin: factor over the RMS of the image over the grid at the same instant that a
            point must exceed.
        min_coherence: fraction in [0, 1] of the receive channels' power at a point's instant
            that one plane wave from its direction must explain (module docstring, rule 5).
        coherence_bands: sub-bands the coherence is read in and averaged over (rule 5): 1
            reads it on the whole band; n > 1 splits the drive's band (where the system
            spectrum is within 6 dB of its peak) into n half-overlapping Hann windows, so every
            part of a wide sweep counts alike instead of the low end that carries most of the
            echoes' power, where the receive beam is widest.
        coherence_peak: place each point at the peak of the coherence (read as rule 5 reads it)
            around its grid direction instead of the image's: the sub-bands' mean weighs the
            narrower beams of a wide sweep's upper band as much as the widest.
    """

    step: float = np.radians(2.0)
    detection_snr: float = 5.0
    detection_floor: float = 0.0
    side_lobe_margin: float = 2.0
    clutter_margin: float = 3.0
    min_coherence: float = 0.4
    coherence_bands: int = 1
    coherence_peak: bool = False

    def __post_init__(self):
        check_range("ImagingSettings.step [rad]", self.step, 1e-3, np.radians(10))
        check_positive("ImagingSettings.detection_snr", self.detection_snr)
        for name in ("detection_floor", "side_lobe_margin", "clutter_margin"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"ImagingSettings.{name} must be >= 0, got {value}")
        if not 0 <= self.min_coherence <= 1:
            raise ValueError(f"ImagingSettings.min_coherence must be in [0, 1], "
                             f"got {self.min_coherence}")
        if not (int(self.coherence_bands) == self.coherence_bands and self.coherence_bands >= 1):
            raise ValueError(f"ImagingSettings.coherence_bands must be a whole number >= 1, "
                             f"got {self.coherence_bands}")


@dataclass(frozen=True)
class ImagePoints:
    """The P points of one image.

    Attributes:
        points: (P, 3) reflectors in the sensor frame [m].
        direction: (P, 3) unit arrival directions (from the receive origin).
        path_length: (P,) transmit centre -> reflector -> receive origin [m].
        amplitude: (P,) image value at the point [Pa].
        snr: (P,) amplitude over the RMS noise envelope.
        coherence: (P,) share of the channels' power that one plane wave from the point's grid
            direction explains (rule 5).
        cell: (P, 2) grid direction and sample of each point's cell.
        passed: cells of the field of view that pass each rule in turn (1-5 of the module
            docstring): 'threshold', 'range_peak', 'main_lobe_peak', 'side_lobe',
            'range_side_lobe', 'clutter', 'trusted' (the points).
    """

    points: np.ndarray
    direction: np.ndarray
    path_length: np.ndarray
    amplitude: np.ndarray
    snr: np.ndarray
    coherence: np.ndarray
    cell: np.ndarray
    passed: dict

    def __len__(self) -> int:
        return len(self.points)


#: The points rule for a wide sweep (20-80 kHz, ``SonarConfig.with_wide_sweep``): the trust rule
#: read in three sub-bands at threshold 0.2, each point at that coherence's peak (docs/imaging.md,
#: "Points"; as accurate as the whole band's 0.4 with 1.4-1.7 x its points), and the clutter
#: rule at 2 x the image's RMS instead of 3: behind this trust rule the cells between 2 and 3 x
#: are 82-84 % within 2 cm and add surface the stricter margin refused.
WIDE_SWEEP_SETTINGS = ImagingSettings(min_coherence=0.2, coherence_bands=3, coherence_peak=True,
                                      clutter_margin=2.0)


def imaging_settings_for(pulse) -> ImagingSettings:
    """The points rule for images driven by ``pulse``: :data:`WIDE_SWEEP_SETTINGS` for a sweep
    over an octave or more (its receive beam narrows by half or more from the band's low end to
    its top, and the whole band's coherence would be read mostly at the low end, where the
    echoes' power is), else ``ImagingSettings()``."""
    start, stop = (getattr(pulse, name, None) for name in ("start", "stop"))
    if start is not None and stop is not None and max(start, stop) >= 2 * min(start, stop):
        return WIDE_SWEEP_SETTINGS
    return ImagingSettings()
