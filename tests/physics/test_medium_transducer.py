"""Medium and transducer models against published values and analytic formulas."""

import numpy as np
import pytest

from mitsonar import Medium, Transducer

# ISO 9613-2:1996 Table 2, attenuation [dB/km] at the exact octave midband frequencies
# 1000 * 10^(0.3 n), 70 % relative humidity, 101.325 kPa; values rounded to 0.1 dB/km
# (three significant figures above 100).
ISO_TABLE = {
    10.0: [0.4, 1.0, 1.9, 3.7, 9.7, 32.8, 117.0],
    20.0: [0.3, 1.1, 2.8, 5.0, 9.0, 22.9, 76.6],
    30.0: [0.3, 1.0, 3.1, 7.4, 12.7, 23.1, 59.3],
}


@pytest.mark.parametrize("celsius", sorted(ISO_TABLE))
def test_absorption_matches_iso_table(celsius):
    medium = Medium(temperature=273.15 + celsius, relative_humidity=70.0)
    f = 1000.0 * 10 ** (0.3 * np.arange(-3, 4))
    computed = 1000.0 * medium.absorption_db_per_m(f)
    table = np.array(ISO_TABLE[celsius])
    # Tolerance: the table's rounding (0.05 dB/km, or 0.5 in the third digit) plus 0.5 %.
    tolerance = np.where(table >= 100, 0.51, 0.051) + 0.005 * table
    assert np.all(np.abs(computed - table) <= tolerance), (computed.round(2), table)


def test_absorption_at_40khz_is_order_one_db_per_metre():
    alpha = Medium().absorption_db_per_m(40e3)  # 20 degC, 50 % RH
    assert 1.0 < alpha < 1.6


def test_speed_of_sound_and_impedance():
    air = Medium(temperature=293.15)
    assert air.speed_of_sound == pytest.approx(343.21, abs=0.01)
    assert Medium(temperature=273.15).speed_of_sound == pytest.approx(331.3)
    assert air.impedance == pytest.approx(413.2, rel=0.005)  # rho c of air at 20 degC


@pytest.mark.parametrize("field,value", [("temperature", np.nan), ("relative_humidity", 120.0),
                                         ("pressure", -1.0)])
def test_medium_rejects_bad_values(field, value):
    with pytest.raises(ValueError, match=field):
        Medium(**{field: value})


def test_piston_half_beam_angle_matches_datasheet():
    element = Transducer()
    k = Medium().wavenumber(40e3)
    # Datasheet: total beam angle 85 deg at -6 dB.
    d = element.directivity(np.cos(np.radians(42.5)), k)
    assert 20 * np.log10(d) == pytest.approx(-6.02, abs=0.05)
    assert element.directivity(1.0, k) == pytest.approx(1.0)
    assert element.directivity(-0.5, k) == 0.0  # behind the baffle


def test_resonator_bandwidth_and_phase():
    element = Transducer()
    f0 = element.resonance_frequency
    h = element.frequency_response(np.array([f0 - 1000.0, f0, f0 + 1000.0]))
    assert abs(h[1]) == pytest.approx(1.0) and np.angle(h[1]) == pytest.approx(0.0)
    # -6 dB points 2 kHz apart (the datasheet bandwidth), to 2 % of the bandwidth.
    f = np.linspace(f0 - 3000, f0 + 3000, 600001)
    above = f[np.abs(element.frequency_response(f)) >= 0.5]
    assert above[-1] - above[0] == pytest.approx(2000.0, rel=0.02)
    assert element.frequency_response(0.0) == 0.0
