"""What B beams listen for: their drive waveforms, matched filters and looks.

A beam's looks are the parts of its code (an OFDM code: two tones, each matched-filtered and
demodulated at its own carrier, :class:`~mitsonar.signal.ofdm.Code`), or its waveform itself.
The side-lobe check (:mod:`mitsonar.signal.sidelobe`), the part balance and the arrival
direction read the receive channels of every look at the instants of their candidates
(:class:`~mitsonar.signal.beamforming.Beamformer`'s narrow-band operators); :class:`Looks`
holds those channels, each computed once, and :meth:`Looks.each` walks the looks of many
candidates, a look index at a time (a code's parts: two at most).
"""

from __future__ import annotations

import numpy as np

#: Channel sets of the looks transformed together (bounds the memory of an OFDM cycle's looks:
#: ~10 MB per set of 25 channels).
LOOK_BATCH = 4


class Looks:
    """The looks of B beams for the side-lobe check and the arrival direction: channels
    (N_rx, N) matched-filtered for a look waveform (a code's part, or the waveform itself) and
    demodulated at its carrier; each distinct (recording, look waveform) computed once, when
    first asked for.

    Args:
        band: the recordings' band.
        spectra: channel spectra on the band, (N_rx, nb) shared or (B, N_rx, nb) per beam.
        waves: the beams' waveforms.
        start_time: time of sample 0 [s].
        n: samples per channel.
        beamformed: (B, nb) the beams' own delay-and-sum spectra (:attr:`beamformed`).
    """

    def __init__(self, band, spectra: np.ndarray, waves: Waveforms, start_time: float, n: int,
                 beamformed: np.ndarray):
        self.band = band
        self.waves = waves
        #: (B, nb) each beam's delay-and-sum of the channels towards its own direction.
        self.beamformed = beamformed
        self.per_beam = spectra.ndim == 3
        self.spectra = spectra.reshape((-1,) + spectra.shape[-2:])
        #: (sets, N_rx, n): set r x T + t is recording r's look waveform t (T of them); filled
        #: when first asked for by :meth:`sets`.
        self.channels = np.empty((len(self.spectra) * len(waves.carriers),) + spectra.shape[-2:-1]
                                 + (n,), dtype=complex)
        self._ready = np.zeros(len(self.channels), bool)
        self._start, self._n = start_time, n  # the channels' first sample time [s], samples

    def sets(self, beams, look) -> np.ndarray:
        """Sets (E,) in :attr:`channels` of looks ``look`` ((E,) or one for all) of ``beams``
        (E,), computed where new: an inverse FFT for every ``LOOK_BATCH`` of them."""
        n_looks = len(self.waves.carriers)
        keys = (beams if self.per_beam else 0) * n_looks + self.waves.looks[beams, look]
        new = np.unique(keys[~self._ready[keys]])
        for first in range(0, len(new), LOOK_BATCH):
            batch = new[first: first + LOOK_BATCH]
            recording, waveform = np.divmod(batch, n_looks)
            # The band's analytic signals are already demodulated by its own carrier.
            shift = self.band.demodulation(self.waves.carriers, self._start, self._n)[waveform]
            analytic = self.band.to_analytic(self.spectra[recording]
                                             * self.waves.look_filters[waveform][:, None])
            analytic = analytic[..., : self._n]
            self.channels[batch] = np.multiply(analytic, shift[:, None, :], out=analytic)
            self._ready[batch] = True
        return keys

    def each(self, beams: np.ndarray, where: np.ndarray | None = None):
        """Walks the looks of rows of ``beams`` (E,), a look index at a time: yields (look,
        rows (R,) that have it, their channel sets (R,) (:meth:`sets`), their carriers (R,)
        [Hz]), skipping looks no row has. ``where`` (E,), if given, is read anew before each
        look: rows it no longer holds (e.g. rejected in an earlier look) are left out."""
        table = self.waves.looks[beams]
        for look in range(table.shape[1]):
            has = table[:, look] >= 0
            rows = np.flatnonzero(has if where is None else has & where)
            if len(rows):
                yield (look, rows, self.sets(beams[rows], look),
                       self.waves.carriers[table[rows, look]])


class Waveforms:
    """The drive waveforms of B beams, by kind (distinct waveform, :attr:`kinds`): matched
    filters (K, nb) and noise envelope levels (K,) [Pa]; and their looks (the parts of a code,
    or the waveform itself): matched filters (T, nb) and carriers (T,) [Hz].

    Attributes:
        kind: (B,) each beam's kind.
        looks: (B, P) each beam's looks (-1: none).
        has_parts: (B,) whether a beam's looks are parts of its waveform (with envelopes of their
            own, for the part balance).
        part_gains: (B, P) the envelope peak that an echo of the beam's own waveform of unit
            amplitude leaves through each look's matched filter (1 without parts;
            :meth:`EchoProcessor.part_gain <mitsonar.signal.receiver.EchoProcessor.part_gain>`):
            the part balance compares the parts' envelopes divided by these.
    """

    def __init__(self, processor, waveforms, count: int):
        """``processor``: the receiver (its matched filters and noise levels); ``waveforms``:
        the B = ``count`` beams' drive waveforms (None: the pulse for every beam; an entry
        None: the pulse)."""
        pulse = processor.band.pulse
        if waveforms is None:
            kinds, self.kind = [pulse], np.zeros(count, np.int64)
        else:
            kinds, self.kind = distinct([pulse if w is None else w for w in waveforms])
        self.kinds = kinds
        self.filters = np.stack([processor.matched_filter(w)[0] for w in kinds])
        self.noise = np.array([processor.noise_envelope_rms(w) for w in kinds])
        parts = [tuple(getattr(w, "parts", ())) for w in kinds]
        looks = [p or (w,) for p, w in zip(parts, kinds)]
        tones = list(dict.fromkeys(t for look in looks for t in look))
        table = np.full((len(kinds), max(map(len, looks))), -1)
        for k, look in enumerate(looks):
            table[k, : len(look)] = [tones.index(t) for t in look]
        self.looks = table[self.kind]
        self.has_parts = np.array([len(p) > 0 for p in parts])[self.kind]
        gains = np.ones(table.shape)
        for k, part in enumerate(parts):  # a code's parts (two at most)
            gains[k, : len(part)] = [processor.part_gain(kinds[k], t) for t in part]
        self.part_gains = gains[self.kind]
        self.look_filters = np.stack([processor.matched_filter(t)[0] for t in tones])
        self.carriers = np.array([float(t.frequency) for t in tones])

    def range_profiles(self, processor) -> tuple[np.ndarray, np.ndarray]:
        """(|R| by lag (K, N), tau_r (K,) [samples]) of each kind
        (:meth:`EchoProcessor.range_profile
        <mitsonar.signal.receiver.EchoProcessor.range_profile>`)."""
        lobes, resolution = zip(*map(processor.range_profile, self.kinds))
        return np.stack(lobes), np.array(resolution)


def distinct(items) -> tuple[list, np.ndarray]:
    """(the distinct items in order of first appearance, index (len(items),) of each among them)."""
    index: dict = {}
    which = np.array([index.setdefault(w, len(index)) for w in items], np.int64)
    return list(index), which
