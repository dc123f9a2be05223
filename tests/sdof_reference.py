"""Reference SDOF freeplay sweep for tests, the docs figure and the benchmark.

A self-contained plain-Python RK4 (independent of ``freeplayid.simulate``) of the base-excited
freeplay oscillator whose exact backbone is known (docs/backbone.md),
``w(A) = w_n / (1 + 2 delta / (pi (A - delta)))``; f_n = 50 Hz in contact, 4 % damping,
delta = 1.2e-4 m.
"""

import math

import numpy as np

from freeplayid.quantity import G

FS = 2048.0  # [Hz] the paper's sampling rate
F_N = 50.0  # [Hz] contact (closed-hinge) frequency
ZETA = 0.04  # [-] damping ratio at F_N
DELTA = 1.2e-4  # [m] half-gap


def exact_backbone_hz(amplitude):
    """Exact SDOF freeplay backbone frequency [Hz] at peak displacement ``amplitude`` [m]."""
    return F_N / (1.0 + 2.0 * DELTA / (math.pi * (np.asarray(amplitude) - DELTA)))


def simulate_sdof_sweep(level_g, sweep, *, fs=FS, substeps=2):
    """RK4 of ``y'' + 2 zeta w_n y' + f(y) = -a_g(t)`` (m = 1), y relative to the base.

    Plain-Python scalar loop (~1 us per stage), step 1/(fs substeps) (6.1e-4 s / 2 at 2048 Hz,
    finer than the paper's 6.25e-4 s). Starts on the in-gap steady state (y = 0, y' = a_g / w0)
    so a weak run does not drift into contact (a weakly excited freeplay oscillator can stay on
    its in-gap branch).

    Parameters
    ----------
    level_g : float [g]
    sweep : freeplayid.simulate.Sweep

    Returns
    -------
    y, v, a, a_g : ndarray, shape (T,) [m, m/s, m/s^2, m/s^2]
        Displacement, velocity, acceleration relative to the base, and the base acceleration.
    """
    wn = 2 * math.pi * F_N
    kn, c = wn * wn, 2 * ZETA * wn
    amp = level_g * G
    f0, s = sweep.start_hz, sweep.signed_rate
    n = int(round(sweep.duration * fs)) + 1
    h = 1.0 / (fs * substeps)
    twopi = 2 * math.pi

    def acc(t, y, v):
        ag = amp * math.sin(twopi * (f0 * t + 0.5 * s * t * t))
        fp = kn * (y - DELTA) if y > DELTA else (kn * (y + DELTA) if y < -DELTA else 0.0)
        return -ag - c * v - fp

    y, v, t = 0.0, amp / (twopi * f0), 0.0
    ys, vs = np.empty(n), np.empty(n)
    for k in range(n):
        ys[k], vs[k] = y, v
        for _ in range(substeps):
            a1 = acc(t, y, v)
            y2, v2 = y + 0.5 * h * v, v + 0.5 * h * a1
            a2 = acc(t + 0.5 * h, y2, v2)
            y3, v3 = y + 0.5 * h * v2, v + 0.5 * h * a2
            a3 = acc(t + 0.5 * h, y3, v3)
            y4, v4 = y + h * v3, v + h * a3
            a4 = acc(t + h, y4, v4)
            y += h / 6 * (v + 2 * v2 + 2 * v3 + v4)
            v += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            t += h
    tt = np.arange(n) / fs
    ag = amp * np.sin(twopi * (f0 * tt + 0.5 * s * tt * tt))
    fp = np.where(ys > DELTA, kn * (ys - DELTA), np.where(ys < -DELTA, kn * (ys + DELTA), 0.0))
    return ys, vs, -ag - c * vs - fp, ag
