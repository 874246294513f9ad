"""The narrow-band side-lobe check (Beamformer.off_beam) against the whole grid formed for every
window: the bound that spares most windows the grid may not change a decision."""

import numpy as np

import mitsonar
from mitsonar.frames import direction_from_fov_angles
from mitsonar.signal.band import Band
from mitsonar.signal.beamforming import BOUND_ROUNDING, Beamformer, dot
from mitsonar.signal.detection import DetectionSettings

CARRIER = 40e3  # [Hz]


def _beamformer() -> Beamformer:
    """The default configuration's receive array on a complex baseband band."""
    cfg = mitsonar.SonarConfig()
    band = Band(cfg.pulse, cfg.transducer, cfg.sample_rate, 0.0, 0.01, baseband=True)
    return Beamformer(cfg.geometry, band, cfg.medium.speed_of_sound, DetectionSettings())


def _channels(beamformer: Beamformer, arrivals, amplitudes, n: int, noise: float, seed: int):
    """(1, N_rx, n) channels demodulated at CARRIER: plane waves from ``arrivals`` (A, 3) with
    ``amplitudes`` (A,) and slowly varying envelopes, plus complex white noise of RMS
    ``noise``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / beamformer.band.sample_rate
    # Channel j hears a plane wave from u t_j^B(u) late (the beam reads it at t + t_j^B).
    lag = beamformer.receive_delays(np.asarray(arrivals))  # (A, N_rx) [s]
    envelope = np.exp(-(((t - lag[..., None]) - 0.5 * t[-1]) / (0.3 * t[-1])) ** 2)
    waves = np.asarray(amplitudes)[:, None, None] * envelope \
        * np.exp(-2j * np.pi * CARRIER * lag[..., None])
    channels = waves.sum(axis=0) + noise * (rng.normal(size=waves.shape[1:])
                                            + 1j * rng.normal(size=waves.shape[1:]))
    return channels[None]


def _brute_force(beamformer: Beamformer, channels, samples, directions) -> np.ndarray:
    """off_beam's answer from every direction of the grid, formed for every window."""
    s = beamformer.settings
    windows = beamformer.windows(channels, np.zeros(len(samples), np.int64), samples)
    beam = np.abs(beamformer.operator(directions, CARRIER, blocks=np.arange(len(samples)))
                  @ windows.T.ravel())
    grid = beamformer.ghost_grid
    ghosts = np.abs(beamformer.operator(grid, CARRIER) @ windows)  # (G, E)
    outside = dot(grid[:, None, :], directions) < np.cos(s.ghost_exclusion)
    return np.where(outside, ghosts, 0.0).max(axis=0) > s.ghost_margin * beam


def test_the_side_lobe_check_decides_as_the_whole_grid_would():
    """Two plane waves (one along the first beams, one 30 deg aside: absent, weaker, as strong,
    stronger) in noise, read by 60 windows along beams that point at either or elsewhere: the
    check's answers equal those of the whole grid formed for every window; both answers occur,
    and the bound spares the grid for some windows."""
    beamformer = _beamformer()
    g = mitsonar.SonarConfig().geometry
    along = direction_from_fov_angles(np.radians(4.0), np.radians(-3.0))
    aside = direction_from_fov_angles(np.radians(-26.0), np.radians(10.0))
    off, spared = [], []
    for seed, strength in enumerate((0.0, 0.3, 1.0, 3.0)):
        channels = _channels(beamformer, [along, aside], [1.0, strength], 400, 0.02, seed)
        rng = np.random.default_rng(seed)
        samples = rng.integers(0, 400, 60)
        directions = np.concatenate([np.repeat([along, aside], 20, axis=0),
                                     g.fov_grid(np.radians(10.0))[:20]])
        checked = beamformer.off_beam(channels, np.zeros(60, np.int64), samples,
                                      np.full(60, CARRIER), directions)
        np.testing.assert_array_equal(checked,
                                      _brute_force(beamformer, channels, samples, directions))
        off.append(checked)
        windows = beamformer.windows(channels, np.zeros(60, np.int64), samples)
        beam = np.abs(beamformer.operator(directions, CARRIER, blocks=np.arange(60))
                      @ windows.T.ravel())
        spared.append(_bound(beamformer, windows) * (1 + BOUND_ROUNDING)
                      <= beamformer.settings.ghost_margin * beam)
    assert np.concatenate(off).any() and not np.concatenate(off).all()
    assert np.concatenate(spared).any()


def _bound(beamformer: Beamformer, windows: np.ndarray) -> np.ndarray:
    """(E,) the bound off_beam spares the grid with: each channel's largest magnitude among the
    window samples the grid reads, summed over the channels."""
    reach = beamformer.ghost_reach()
    return np.where(reach[..., None], np.abs(windows).reshape(reach.shape + (-1,)),
                    0.0).max(axis=1).sum(axis=0)


def test_no_grid_direction_beats_the_bound_and_one_plane_wave_reaches_it():
    """The bound holds for every direction of the grid on noise alone (the samples the grid
    reads: fewer for channels near the receive origin); a plane wave from a grid direction
    reaches it there (within the rounding allowed for)."""
    beamformer = _beamformer()
    samples = np.arange(30, 270, 10)  # windows inside the recording
    sets = np.zeros(len(samples), np.int64)
    operator = beamformer.operator(beamformer.ghost_grid, CARRIER)
    noise = beamformer.windows(_channels(beamformer, np.zeros((0, 3)), np.zeros(0), 300, 1.0, 7),
                               sets, samples)
    assert np.all(np.abs(operator @ noise) <= _bound(beamformer, noise) * (1 + BOUND_ROUNDING))
    assert beamformer.ghost_reach().sum() < beamformer.ghost_reach().size
    arrival = beamformer.ghost_grid[700]
    lag = beamformer.receive_delays(arrival)[:, None]  # (N_rx, 1) [s]
    wave = beamformer.windows(np.exp(-2j * np.pi * CARRIER * lag) * np.ones((1, 1, 300)), sets,
                              samples)
    np.testing.assert_allclose(np.abs(operator[700] @ wave).ravel(), _bound(beamformer, wave),
                               rtol=BOUND_ROUNDING)


def test_aligned_channels_sum_to_the_operators_beam_also_at_the_recordings_edges():
    """Beamformer.aligned gathers only the two samples each channel interpolates between; its
    sum over the channels is the operator's beam on the whole window (the same numbers to 1e-12
    relative), for looks of two channel sets at fractional samples inside the recording and
    within a window of either end (samples beyond it read as zeros)."""
    beamformer = _beamformer()
    g = mitsonar.SonarConfig().geometry
    rng = np.random.default_rng(3)
    channels = np.concatenate([_channels(beamformer, [g.fov_grid(np.radians(10.0))[k]], [1.0],
                                         300, 0.1, k) for k in (0, 5)])  # (2, N_rx, 300)
    lag = beamformer.window_lag
    samples = np.concatenate([rng.uniform(lag, 300 - lag, 30), rng.uniform(-lag, lag, 15),
                              rng.uniform(300 - lag, 300 + lag, 15)])
    sets = rng.integers(0, 2, len(samples))
    directions = g.fov_grid(np.radians(5.0))[rng.integers(0, 117, len(samples))]
    carriers = rng.choice([38e3, 40e3, 42e3], len(samples))
    k = np.floor(samples).astype(np.int64)
    beam = beamformer.operator(directions, carriers, samples - k, np.arange(len(k))) \
        @ beamformer.windows(channels, sets, k).T.ravel()
    aligned = beamformer.aligned(channels, sets, carriers, samples, directions)
    assert aligned.shape == (len(samples), g.rx.count)
    np.testing.assert_allclose(aligned.sum(axis=1), beam, rtol=1e-12, atol=1e-12)
    assert np.abs(beam[30:]).min() < np.abs(beam[:30]).max()  # the edges read fewer samples
