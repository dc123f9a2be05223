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


def simulate_sdof_sweep(level_g, sweep, *, fs=FS, substeps=2, jit=False, static_g=0.0):
    """RK4 of ``y'' + 2 zeta w_n y' + f(y) = -a_g(t)`` (m = 1), y relative to the base.

    Plain-Python scalar loop (~1 us per stage), step 1/(fs substeps) (6.1e-4 s / 2 at 2048 Hz,
    finer than the paper's 6.25e-4 s). Starts on the in-gap steady state (y = 0, y' = a_g / w0)
    so a weak run does not drift into contact (a weakly excited freeplay oscillator can stay on
    its in-gap branch). With ``static_g``, a constant ``static_g * G`` is added to a_g (gravity
    on a vertical shaker) and the run starts at rest on the stop it pushes to,
    ``y = -(delta + static_g G / kn)`` (sign of ``static_g``); a_g, returned, leaves it out.

    Parameters
    ----------
    level_g : float [g]
    sweep : freeplayid.simulate.Sweep
    jit : bool
        Compile the same loop with numba (for long records at high rates: the benchmarks).
    static_g : float [g]

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

    loop = _jit_loop() if jit else _loop
    a_s = static_g * G
    if a_s:
        y0, v0 = -math.copysign(DELTA, a_s) - a_s / kn, 0.0
    else:
        y0, v0 = 0.0, amp / (twopi * f0)
    ys, vs = loop(amp, f0, s, n, h, substeps, kn, c, DELTA, a_s, y0, v0)
    tt = np.arange(n) / fs
    ag = amp * np.sin(twopi * (f0 * tt + 0.5 * s * tt * tt))
    fp = np.where(ys > DELTA, kn * (ys - DELTA), np.where(ys < -DELTA, kn * (ys + DELTA), 0.0))
    return ys, vs, -ag - a_s - c * vs - fp, ag


def _loop(amp, f0, s, n, h, substeps, kn, c, delta, a_s, y0, v0):
    """The RK4 steps of :func:`simulate_sdof_sweep`: (y, v) at every ``substeps``-th step."""
    twopi = 2 * math.pi

    def acc(t, y, v):
        ag = amp * math.sin(twopi * (f0 * t + 0.5 * s * t * t)) + a_s
        fp = kn * (y - delta) if y > delta else (kn * (y + delta) if y < -delta else 0.0)
        return -ag - c * v - fp

    y, v, t = y0, v0, 0.0
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
    return ys, vs


_JITTED = []


def _jit_loop():
    if not _JITTED:
        import numba

        _JITTED.append(numba.njit(cache=False)(_loop))
    return _JITTED[0]


def cycle_amplitudes(y, fs):
    """First-harmonic amplitude of every response cycle of a densely sampled record.

    A cycle runs from one zero up-crossing of ``y`` to the next (crossings linearly
    interpolated); its first Fourier coefficients over its own period T are the trapezoidal
    integrals ``(2/T) int y cos, sin (2 pi (t - t_a) / T) dt``. No filter and no sweep law: the
    reference the extractors are checked against.

    Parameters
    ----------
    y : ndarray, shape (T,) [m]
    fs : float [Hz]

    Returns
    -------
    t_mid : ndarray, shape (C,) [s]
        Middle of each cycle.
    amplitude : ndarray, shape (C,) [m]
    """
    t = np.arange(y.size) / fs
    neg = np.signbit(y)
    up = np.nonzero(neg[:-1] & ~neg[1:])[0]
    tc = t[up] - y[up] / (y[up + 1] - y[up]) / fs
    t_mid, amp = [], []
    for a, b, ta, tb in zip(up[:-1], up[1:], tc[:-1], tc[1:], strict=True):
        tt = np.concatenate(([ta], t[a + 1 : b + 1], [tb]))
        yy = np.concatenate(([0.0], y[a + 1 : b + 1], [0.0]))
        w = 2 * np.pi / (tb - ta)
        cos_c = np.trapezoid(yy * np.cos(w * (tt - ta)), tt)
        sin_c = np.trapezoid(yy * np.sin(w * (tt - ta)), tt)
        t_mid.append(0.5 * (ta + tb))
        amp.append(2 / (tb - ta) * math.hypot(cos_c, sin_c))
    return np.array(t_mid), np.array(amp)


def jump_reference(y, fs, sweep):
    """The true jump point of a clean, densely sampled displacement record.

    The largest cycle (:func:`cycle_amplitudes`), refined by a parabola through it and its two
    neighbours; the excitation frequency is the sweep law at that time.

    Returns
    -------
    time_s, f_hz, amplitude_m : float [s], [Hz], [m]
    """
    tm, amp = cycle_amplitudes(y, fs)
    k = int(np.argmax(amp))
    tk, ak = tm[k], amp[k]
    if 0 < k < amp.size - 1:
        p = np.polyfit(tm[k - 1 : k + 2] - tm[k], amp[k - 1 : k + 2], 2)
        if p[0] < 0:
            dt = float(np.clip(-p[1] / (2 * p[0]), tm[k - 1] - tm[k], tm[k + 1] - tm[k]))
            tk, ak = tm[k] + dt, float(np.polyval(p, dt))
    return float(tk), float(sweep.frequency(tk)), float(ak)
