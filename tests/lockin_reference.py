"""The lock-in as numpy composes it (undecimated): the reference of the compiled loops in
``freeplayid.signal.lockin`` (tests/test_signal.py) and the alternative that
``benchmarks/extract.py`` times beside them."""

import numpy as np

from freeplayid.signal import bandwidth_weight
from freeplayid.signal.acmp import ChirpMode
from freeplayid.signal.banded import smooth_second_difference


def numpy_lockin(x, fs, sweep, bandwidth_hz=2.0) -> ChirpMode:
    t = np.arange(x.size) / fs
    phi = sweep.phase(t)
    a = 0.5 * bandwidth_weight(bandwidth_hz, fs)
    zr = smooth_second_difference(2 * x * np.cos(phi), a)
    zi = smooth_second_difference(-2 * x * np.sin(phi), a)
    theta = np.unwrap(np.arctan2(zi, zr))
    amp = np.hypot(zr, zi)
    phase = phi + theta
    freq = sweep.frequency(t) + np.gradient(theta) * fs / (2 * np.pi)
    mode = amp * np.cos(phase)
    snr = 10 * np.log10(float(mode @ mode) / float(np.sum((x - mode) ** 2)))
    return ChirpMode(amp, freq, phase, mode, snr, 0, True, bandwidth_hz, fs)
