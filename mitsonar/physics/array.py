"""Transmit and receive arrays: element layouts, their placement on the sensor head, steering.

Both arrays are 5x5 sparse layouts of the same transducer, each inside a 10 cm x 10 cm aperture
(element centres within +-5 cm of its own origin), in the sensor XY plane, facing +z. They are
interleaved on one board: the receive array's origin sits ``baseline`` = 12.5 mm to the right of
the transmit origin (sensor +x), and no two of the 50 elements are closer than the 10 mm can
diameter. Interleaving keeps the baseline small, so the receive beam sees what the transmit beam
lights even at 0.3 m; the depth still uses the bistatic equation (7) with this baseline.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from importlib import resources

import numpy as np

from mitsonar.physics.beampattern import in_fov
from mitsonar.frames import direction_from_fov_angles, fov_angles
from mitsonar.validation import check_finite, check_positive, check_positive_integer

#: Side of the square aperture that holds the element centres [m].
APERTURE = 0.10
#: Smallest centre-to-centre spacing: the 10 mm transducer can diameter [m].
MIN_SPACING = 0.010
#: File with the shipped element layouts (mitsonar/physics).
LAYOUT_FILE = "array_layout.json"


def _shipped_data() -> dict:
    return json.loads(resources.files("mitsonar.physics").joinpath(LAYOUT_FILE).read_text())


@dataclass(frozen=True)
class ArrayLayout:
    """Element centres of one planar array.

    Attributes:
        positions: (N, 2) element centres in the array plane [m], relative to the array origin.
        name: where the layout comes from.
    """

    positions: np.ndarray
    name: str = "custom"

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 1:
            raise ValueError(f"ArrayLayout '{self.name}': positions must be (N, 2), got {p.shape}")
        check_finite(f"ArrayLayout '{self.name}' positions [m]", p)
        if np.any(np.abs(p) > APERTURE / 2 + 1e-9):
            raise ValueError(f"ArrayLayout '{self.name}': element centres must lie within "
                             f"+-{APERTURE / 2} m of the origin")
        d = np.linalg.norm(p[:, None] - p[None], axis=-1) + np.eye(len(p))
        if np.min(d) < MIN_SPACING - 1e-9:
            raise ValueError(f"ArrayLayout '{self.name}': elements closer than {MIN_SPACING} m "
                             f"(minimum spacing {np.min(d):.4f} m)")
        object.__setattr__(self, "positions", p)

    @classmethod
    def uniform(cls, n: int = 5, pitch: float = 0.025) -> "ArrayLayout":
        """Regular n x n grid with the given pitch [m], centred on the origin."""
        c = (np.arange(n) - (n - 1) / 2) * pitch
        xx, yy = np.meshgrid(c, c, indexing="xy")
        return cls(np.stack([xx.ravel(), yy.ravel()], axis=1), name=f"uniform {n}x{n} @ {pitch} m")

    @classmethod
    def shipped(cls, which: str) -> "ArrayLayout":
        """The shipped layout of the transmit (``which='tx'``) or receive (``'rx'``) array."""
        data = _shipped_data()
        if which not in ("tx", "rx"):
            raise ValueError(f"which must be 'tx' or 'rx', got {which!r}")
        return cls(np.asarray(data[which]), name=f"{data['name']} ({which})")

    @staticmethod
    def shipped_baseline() -> float:
        """Baseline [m] the shipped layouts were designed for."""
        return float(_shipped_data()["baseline"])

    @property
    def count(self) -> int:
        return len(self.positions)

    def positions_3d(self) -> np.ndarray:
        """(N, 3) element centres in the array frame (z = 0) [m]."""
        return np.concatenate([self.positions, np.zeros((self.count, 1))], axis=1)


@dataclass(frozen=True)
class ArrayGeometry:
    """Sensor head: transmit and receive arrays, their offset and the field of view.

    Attributes:
        tx: transmit layout (origin = sensor origin).
        rx: receive layout.
        baseline: distance from the transmit to the receive array origin, along sensor +x [m];
            the receive layout is placed there.
        tx_phase_offsets: per-element initial phase phi_i of (1) [rad], shape (N_tx,).
        rx_phase_offsets: per-element receive phase error [rad], shape (N_rx,).
        fov_horizontal: full horizontal field of view [rad].
        fov_vertical: full vertical field of view [rad].
    """

    tx: ArrayLayout = field(default_factory=lambda: ArrayLayout.shipped("tx"))
    rx: ArrayLayout = field(default_factory=lambda: ArrayLayout.shipped("rx"))
    baseline: float = field(default_factory=lambda: ArrayLayout.shipped_baseline())
    tx_phase_offsets: np.ndarray | None = None
    rx_phase_offsets: np.ndarray | None = None
    fov_horizontal: float = np.radians(60.0)
    fov_vertical: float = np.radians(40.0)

    def __post_init__(self):
        check_positive("ArrayGeometry.baseline [m]", self.baseline)
        for name, layout in (("tx_phase_offsets", self.tx), ("rx_phase_offsets", self.rx)):
            value = getattr(self, name)
            value = np.zeros(layout.count) if value is None else np.asarray(value, dtype=float)
            if value.shape != (layout.count,):
                raise ValueError(f"ArrayGeometry.{name} must have shape ({layout.count},)")
            check_finite(f"ArrayGeometry.{name} [rad]", value)
            object.__setattr__(self, name, value)
        both = np.concatenate([self.tx_positions, self.rx_positions])
        dist = np.linalg.norm(both[:, None] - both[None], axis=-1) + np.eye(len(both))
        if np.min(dist) < MIN_SPACING - 1e-9:
            i, j = np.unravel_index(np.argmin(dist), dist.shape)
            raise ValueError(f"ArrayGeometry: transmit and receive elements overlap (elements {i} "
                             f"and {j} of the combined list are {dist[i, j] * 1000:.1f} mm apart, "
                             f"minimum {MIN_SPACING * 1000:.0f} mm)")
        for name in ("fov_horizontal", "fov_vertical"):
            value = getattr(self, name)
            check_positive(f"ArrayGeometry.{name} [rad]", value)
            if value >= np.pi:
                raise ValueError(f"ArrayGeometry.{name} must be below 180 degrees")

    @property
    def fov_half_diagonal(self) -> float:
        """Angle between broadside and the field of view's corners [rad]."""
        return float(np.arctan(np.hypot(np.tan(self.fov_horizontal / 2),
                                        np.tan(self.fov_vertical / 2))))

    def with_random_phase_errors(self, std: float, seed: int) -> "ArrayGeometry":
        """Copy with seeded Gaussian per-element phase errors of ``std`` [rad] (uncalibrated array)."""
        rng = np.random.default_rng(seed)
        return replace(self, tx_phase_offsets=rng.normal(0.0, std, self.tx.count),
                       rx_phase_offsets=rng.normal(0.0, std, self.rx.count))

    @property
    def rx_origin(self) -> np.ndarray:
        """(3,) receive array origin in the sensor frame [m]."""
        return np.array([self.baseline, 0.0, 0.0])

    @property
    def tx_positions(self) -> np.ndarray:
        """(N_tx, 3) transmit element centres in the sensor frame [m]."""
        return self.tx.positions_3d()

    @property
    def rx_positions(self) -> np.ndarray:
        """(N_rx, 3) receive element centres in the sensor frame [m]."""
        return self.rx.positions_3d() + self.rx_origin

    def steering_delays(self, direction, speed_of_sound: float) -> np.ndarray:
        """Firing times t_i^D [s] that steer a plane wave towards ``direction`` (3,) or (B, 3).

        Relative to a virtual element at the transmit origin (negative values fire earlier).
        Returns (N_tx,) or (B, N_tx).
        """
        return np.asarray(direction, dtype=float) @ self.tx_positions.T / speed_of_sound

    def fov_grid(self, step: float, offset=(0.0, 0.0)) -> np.ndarray:
        """Directions (n_v * n_h, 3) on a grid of ``step`` [rad] over the field of view, row-major
        from top-left (vertical outer, horizontal inner); 60 x 40 deg at 5 deg gives 9 x 13.

        ``offset``: (horizontal, vertical) shift of the whole grid [rad], each within half a
        step; beams it moves past the field of view's edge stay on the edge (a dithered grid,
        :func:`dither_offsets`)."""
        check_positive("scan step [rad]", step)
        shift = np.asarray(offset, dtype=float)
        if shift.shape != (2,) or not np.all(np.abs(shift) <= step / 2 + 1e-12):
            raise ValueError(f"grid offset [rad] must be (horizontal, vertical), each within half "
                             f"the step ({step / 2:.4g} rad), got {offset}")
        h = np.clip(_centred_range(self.fov_horizontal / 2, step) + shift[0],
                    -self.fov_horizontal / 2, self.fov_horizontal / 2)
        v = np.clip(_centred_range(self.fov_vertical / 2, step) + shift[1],
                    -self.fov_vertical / 2, self.fov_vertical / 2)
        vv, hh = np.meshgrid(v, h, indexing="ij")
        return direction_from_fov_angles(hh, vv).reshape(-1, 3)

    def check_in_fov(self, directions) -> None:
        """Raise ValueError naming the first direction (..., 3) outside the field of view."""
        u = np.asarray(directions, dtype=float).reshape(-1, 3)
        check_finite("beam direction", u)
        bad = ~in_fov(u, self.fov_horizontal, self.fov_vertical)
        if np.any(bad):
            i = int(np.argmax(bad))
            h, v = fov_angles(u[i])
            raise ValueError(
                f"beam direction {u[i].round(4).tolist()} (horizontal {np.degrees(h):.1f} deg, "
                f"vertical {np.degrees(v):.1f} deg) lies outside the "
                f"{np.degrees(self.fov_horizontal):.0f} x {np.degrees(self.fov_vertical):.0f} deg "
                "field of view")


def dither_offsets(step: float, dither: int) -> np.ndarray:
    """(dither^2, 2) grid offsets [rad] (horizontal, vertical) that together sample the field of
    view ``dither`` times more finely than a ``step`` grid: each axis at the centres of ``dither``
    equal parts of one step, every pair once, in an order where each ``dither`` consecutive
    offsets from the first visit every part of both axes (row k: horizontal part k mod n,
    vertical part (k // n + k) mod n). ``dither`` 1: no offset."""
    check_positive("scan step [rad]", step)
    check_positive_integer("grid dither", dither)
    n = int(dither)
    k = np.arange(n * n)
    parts = (np.stack([k % n, (k // n + k) % n], axis=1) + 0.5) / n - 0.5
    return parts * step


def _centred_range(half: float, step: float) -> np.ndarray:
    """Multiples of ``step`` within [-half, half]."""
    n = int(np.floor(half / step + 1e-9))
    return np.arange(-n, n + 1) * step
