"""Physics of the sensor and the medium: air (speed of sound, ISO 9613-1 absorption), the 40 kHz
transducer, acoustic materials, the 5x5 sparse array geometry, far-field beam patterns and the
transmitted waveforms. Arrays in, arrays out; nothing here knows about scenes or signals."""
