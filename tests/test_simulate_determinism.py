"""The compiled kernels compute the IEEE result of their source, whichever compiled copy runs.

numba compiles a prange body twice (on its own: the code that runs right after a compile; and
linked into the caller: the code of the on-disk cache). With value-changing fast-math flags the
two copies rounded differently and a cached and a freshly compiled quasi-static kernel gave
different sweeps (1 ulp at the 7th sample, then up to the signal's size: freeplay dynamics
amplify it). The fast tests hold every compiled copy to a NumPy evaluation of the same operations
in the same order, bit for bit (float64); the slow one compares a fresh compile with a cache load
directly.
"""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from freeplayid.simulate import build_modal_form, design_decimator, rk4_step_limit
from freeplayid.simulate.engines import MODES, numba_available
from freeplayid.simulate.quasistatic import condense_modal_form
from freeplayid.simulate.resample import derivative_taps

pytestmark = pytest.mark.skipif(not numba_available(), reason="numba not installed")

CH = ("uz_top_left", "uz_lower_right")
QS_HZ = 1500.0  # [Hz] condensation threshold of the default fin (6 of 12 modes slow)


# ----------------------------------------------------------------------------- exact fma
# arith.fma is llvm.fma: a * b + c rounded once. numpy has no fma, so it is emulated in float64
# by error-free transformations (Dekker's product, Knuth's sum) and the round-to-odd sum of
# Boldo & Melquiond ("Emulation of FMA and correctly rounded sums: proved algorithms using
# rounding to odd", IEEE Trans. Computers 57, 2008), exact when nothing over- or underflows;
# test_fma_emulation_is_correctly_rounded checks it against exact rational arithmetic.
def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _split(a):
    t = 134217729.0 * a  # 2**27 + 1
    hi = t - (t - a)
    return hi, a - hi


def _two_prod(a, b):
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _sum_odd(a, b):
    """a + b rounded to odd: truncated, then the last bit set if inexact."""
    s, e = _two_sum(a, b)
    s, e = np.asarray(s, dtype=np.float64), np.asarray(e, dtype=np.float64)
    even = (s.view(np.int64) & 1) == 0
    toward = np.where(e > 0, np.inf, -np.inf)
    return np.where((e != 0) & even, np.nextafter(s, toward), s)


def _fma(a, b, c):
    a, b, c = (np.asarray(x, dtype=np.float64) for x in (a, b, c))
    uh, ul = _two_prod(a, b)
    th, tl = _two_sum(c, uh)
    return th + _sum_odd(tl, ul)


# ----------------------------------------------------------------------------- NumPy references
# Transcriptions of engines/numba/rk4.py and rk4_qs.py over the whole (padded) batch: every
# kernel line is elementwise over the members, so a member's arithmetic is the same in both; the
# only member reduction (the count of members whose contact state changed) only decides whether
# to look.
def _solve_state(F, c, st, b, kn, d):
    H = F.shape[0]
    A = np.empty((H, H))
    tv = np.empty(H)
    for i in range(H):
        r = c[i, b]
        for j in range(H):
            sj = st[j, b]
            a = kn * F[i, j] * abs(sj)
            A[i, j] = a + (1.0 if i == j else 0.0)
            r += a * sj * d
        tv[i] = r
    for k in range(H):
        piv = 1.0 / A[k, k]
        for i in range(k + 1, H):
            m = A[i, k] * piv
            for j in range(k + 1, H):
                A[i, j] -= m * A[k, j]
            tv[i] -= m * tv[k]
    for i in range(H - 1, -1, -1):
        r = tv[i]
        for j in range(i + 1, H):
            r -= A[i, j] * tv[j]
        tv[i] = r / A[i, i]
    return tv


def _consistent(tv, c, st, b, d, tol):
    ok = True
    for j in range(len(tv)):
        x, t, sj = tv[j], tol * (d + abs(c[j, b])), st[j, b]
        if sj > 0.5:
            ok = ok and x >= d - t
        elif sj < -0.5:
            ok = ok and x <= -d + t
        else:
            ok = ok and abs(x) <= d + t
    return ok


def _hinge_states(F, c, st, kn, dl, tol, count):
    H = F.shape[0]
    T = np.empty_like(c)
    A3 = np.empty((H, H) + c.shape[1:])
    for i in range(H):
        T[i] = c[i]
        for j in range(H):
            a = F[i, j] * kn * np.abs(st[j])
            A3[i, j] = a + (1.0 if i == j else 0.0)
            T[i] = _fma(a * st[j], dl, T[i])
    for k in range(H):
        for i in range(k + 1, H):
            m = A3[i, k] / A3[k, k]
            for j in range(k + 1, H):
                A3[i, j] = _fma(-m, A3[k, j], A3[i, j])
            T[i] = _fma(-m, T[k], T[i])
    for i in range(H - 1, -1, -1):
        r = T[i].copy()
        for j in range(i + 1, H):
            r = _fma(-A3[i, j], T[j], r)
        T[i] = r / A3[i, i]
    bad = np.zeros(c.shape[1])
    for j in range(H):
        x, sj = T[j], st[j]
        p = np.abs(sj)
        t = tol * (dl + np.abs(c[j]))
        bad = bad + ((1.0 - p) * np.maximum(np.abs(x) - dl - t, 0.0)
                     + p * np.maximum(dl - t - sj * x, 0.0))
    for b in np.flatnonzero(bad != 0.0):
        count["changed"] += 1
        d = dl[b]
        st[:, b] = np.where(T[:, b] > d, 1.0, np.where(T[:, b] < -d, -1.0, 0.0))
        for _ in range(H + 3):
            tv = _solve_state(F, c, st, b, kn[b], d)
            if _consistent(tv, c, st, b, d, tol):
                break
            st[:, b] = np.where(tv > d, 1.0, np.where(tv < -d, -1.0, 0.0))
        else:
            count["exhaustive"] += 1
            for idx in range(3**H):
                for j in range(H):
                    st[j, b] = float(idx % 3 - 1)
                    idx //= 3
                tv = _solve_state(F, c, st, b, kn[b], d)
                if _consistent(tv, c, st, b, d, tol):
                    break
        T[:, b] = tv
    return T


def _accel(eng, eta, v, s, qs, count):
    """Modal acceleration and hinge moments (rk4._accel / rk4_qs._accel_qs)."""
    N, H = eng.D.shape
    kn, dl, lev = eng.kn, eng.dl, eng.lev
    fo = np.empty((H, eta.shape[1]))
    if qs:
        c = np.empty_like(fo)
        for j in range(H):
            c[j] = eng.e[j] * s * lev
            for k in range(N):
                c[j] = _fma(-eng.gam[j, k], v[k], _fma(eng.D[k, j], eta[k], c[j]))
        T = _hinge_states(eng.F, c, eng.st, kn, dl, eng.coef[4], count)
        for j in range(H):
            fo[j] = kn * np.abs(eng.st[j]) * (T[j] - eng.st[j] * dl)
    else:
        for j in range(H):
            x = np.zeros_like(fo[j])
            for k in range(N):
                x = _fma(eng.D[k, j], eta[k], x)
            fo[j] = kn * (x - np.minimum(np.maximum(x, -dl), dl))
    acc = np.empty_like(eta)
    for i in range(N):
        acc[i] = _fma(-eng.lam[i], eta[i], eng.g[i] * s * lev)
        if eng.diag:
            acc[i] = _fma(-eng.cdiag[i], v[i], acc[i])
        else:
            for k in range(N):
                acc[i] = _fma(-eng.cm[i, k], v[k], acc[i])
        for j in range(H):
            acc[i] = _fma(-eng.D[i, j], fo[j], acc[i])
    return acc, fo


def _reference_chunk(eng, s_half, qs, count):
    """One ``eng.run(s_half)`` in NumPy: updates eng's state and returns the emitted outputs
    (padded batch, channels, samples)."""
    h, h2, h6, two = eng.coef[:4]
    C = eng.S.shape[0]
    R, ntap, m, half = eng.ring.shape[0], len(eng.taps), eng.m, eng.half
    e, w = eng.eta, eng.v
    rows = []
    for step in range((len(s_half) - 1) // 2):
        s0, s1, s2 = s_half[2 * step: 2 * step + 3]
        k, fo = _accel(eng, e, w, s0, qs, count)
        src = (e, w, k)[eng.mode]
        val = np.zeros((eng.width,) + e.shape[1:])
        valf = np.zeros_like(val)
        dst = val if eng.mode == 0 else valf
        for c in range(C):
            for i in range(len(e)):
                val[c] = _fma(eng.S[c, i], src[i], val[c])
            if qs:
                for j in range(fo.shape[0]):
                    dst[c] = _fma(eng.hout[c, j], fo[j], dst[c])
                for i in range(len(e)):
                    dst[c] = _fma(eng.vout[c, i], w[i], dst[c])
        # fir.fir_add (fir.fir_add2 for the fast part's derivative)
        two_src = qs and eng.mode != 0
        gi = eng.gi + step
        j = gi + half
        if gi == 0:
            pairs = [(kk, eng.w0[kk], eng.w0d[kk] if two_src else 0.0)
                     for kk in range(len(eng.w0))]
        else:
            pairs = [(kk, eng.taps[j - kk * m], eng.taps_d[j - kk * m] if two_src else 0.0)
                     for kk in range(max(0, (j - ntap + m) // m), j // m + 1)]
        for kk, wk, wd in pairs:
            r = _fma(wk, val, eng.ring[kk % R])
            eng.ring[kk % R] = _fma(wd, valf, r) if two_src else r
        # fir.fir_emit
        jd = j - ntap + 1
        if jd >= 0 and jd % m == 0:
            rows.append(eng.ring[(jd // m) % R].copy())
            eng.ring[(jd // m) % R] = 0.0
        # RK4 stages
        se, sv = w.copy(), k.copy()
        et, vt = _fma(h2, w, e), _fma(h2, k, w)
        k = _accel(eng, et, vt, s1, qs, count)[0]
        se, sv = _fma(two, vt, se), _fma(two, k, sv)
        et, vt = _fma(h2, vt, e), _fma(h2, k, w)
        k = _accel(eng, et, vt, s1, qs, count)[0]
        se, sv = _fma(two, vt, se), _fma(two, k, sv)
        et, vt = _fma(h, vt, e), _fma(h, k, w)
        k = _accel(eng, et, vt, s2, qs, count)[0]
        e, w = _fma(h6, se + vt, e), _fma(h6, sv + k, w)
    eng.eta, eng.v = e, w
    eng.gi += (len(s_half) - 1) // 2
    return np.array(rows).reshape((-1,) + eng.ring.shape[1:]).transpose(2, 1, 0)


# ----------------------------------------------------------------------------- tests
def test_fma_emulation_is_correctly_rounded():
    from fractions import Fraction

    rng = np.random.default_rng(0)
    n = 3000
    a = rng.normal(size=n) * 2.0 ** rng.integers(-30, 30, n)
    b = rng.normal(size=n) * 2.0 ** rng.integers(-30, 30, n)
    c = -a * b * (1 + rng.choice([0.0, 2.0**-52, -(2.0**-53), 1e-9, 1.0], n))  # cancellation
    c[::7] = rng.normal(size=len(c[::7]))
    got = _fma(a, b, c)
    want = [float(Fraction(x) * Fraction(y) + Fraction(z)) for x, y, z in zip(a, b, c)]
    np.testing.assert_array_equal(got, want)  # Fraction -> float rounds to nearest, ties even
    assert np.any(got != a * b + c)  # cases where the fused and the unfused results differ


def _engine(system, kn, qs, quantity, batch, seed):
    """A float64 numba engine of the default fin with a random batch in every contact state."""
    from freeplayid.simulate.engines.numba.rk4 import NumbaRK4
    from freeplayid.simulate.engines.numba.rk4_qs import NumbaQSRK4

    rng = np.random.default_rng(seed)
    kn = kn * rng.uniform(0.5, 2.0, batch)  # [N m/rad]
    form = build_modal_form(system, channels=CH, quantity=quantity, frame="relative",
                            kn_max=kn.max())
    if qs:
        qform = condense_modal_form(form, threshold_hz=QS_HZ, quantity=quantity,
                                    kn_max=kn.max())
        form = qform.slow
    m = 2  # FIR of 81 taps: outputs from step 40 on
    h = rk4_step_limit(form.omega_max, omega_dt=2.0)
    delta = rng.uniform(1e-3, 4e-3, batch)  # [rad]
    level = rng.uniform(0.3, 1.5, batch)  # [g]
    # modal states with hinge rotations of 0-4 delta (open, closed on either side) and modal
    # velocities of their frequencies
    eta = rng.normal(size=(batch, form.n_modes))
    theta = np.abs(eta @ form.D).max(1)
    eta *= (rng.uniform(0.0, 4.0, batch) * delta / theta)[:, None]
    v = rng.normal(size=eta.shape) * np.sqrt(form.lam) * np.abs(eta).mean(1, keepdims=True)
    kw = dict(h=h, quantity=quantity, dtype=np.float64, taps=design_decimator(m), factor=m)
    if qs:
        if quantity != "displacement":
            kw["taps"], taps_d = derivative_taps(kw["taps"], m, h, MODES[quantity])
            kw["taps_d"] = taps_d
        return NumbaQSRK4(qform, kn, delta, level, eta, v, **kw), h
    return NumbaRK4(form, kn, delta, level, eta, v, **kw), h


@pytest.fixture(scope="module")
def default_fin_model():
    from freeplayid.model import default_fin, default_fin_parameters

    return default_fin(), default_fin_parameters()


# the default fin's two hinges take rk4_qs._solve_block2; one hinge (the mid one dropped) and
# three (a third spring from q1 to the base) the general elimination rk4_qs._solve_block
HINGES = {2: None, 1: (("rx_left_out", "rx_left_in"),),
          3: (("rx_left_out", "rx_left_in"), ("rx_mid_out", "rx_mid_in"), ("q1", ""))}


@pytest.mark.parametrize("qs,quantity,hinges", [(True, "displacement", 2),
                                                (True, "acceleration", 2),
                                                (False, "acceleration", 2),
                                                (True, "acceleration", 1),
                                                (True, "acceleration", 3)])
def test_kernel_is_its_ieee_arithmetic(default_fin_model, qs, quantity, hinges):
    system, hinge = default_fin_model
    if HINGES[hinges] is not None:
        system = system.replace(hinge_pairs=HINGES[hinges])
    assert system.n_hinges == hinges
    # 100 members: two blocks, the second padded; two chunks: the start-up path of the FIR
    # (gi = 0), the ring carried over a chunk boundary, emitted outputs
    eng, h = _engine(system, hinge["kn"], qs, quantity, 100, seed=5)
    ref, _ = _engine(system, hinge["kn"], qs, quantity, 100, seed=5)
    assert ref.mode == MODES[quantity]
    count = {"changed": 0, "exhaustive": 0}
    t0 = 0.0
    for L in (24, 40):
        s_half = np.sin(2 * np.pi * 40.0 * (t0 + 0.5 * h * np.arange(2 * L + 1)))
        t0 += L * h
        out = eng.run(s_half)
        out_ref = _reference_chunk(ref, s_half, qs, count)
        np.testing.assert_array_equal(out, out_ref)
        np.testing.assert_array_equal(eng.eta, ref.eta)
        np.testing.assert_array_equal(eng.v, ref.v)
        np.testing.assert_array_equal(eng.ring, ref.ring)
        if qs:
            np.testing.assert_array_equal(eng.st, ref.st)
    assert len(out) > 0
    if qs:
        # the contact states changed, through the scalar active-set solve
        assert count["changed"] > 50, count


@pytest.mark.slow
def test_cached_kernel_equals_fresh_compile(tmp_path):
    # ~2-4 min: one compile of the quasi-static kernel into an empty cache, then a second process
    # that loads it; both run the same float32 sweep (chaotic enough that any rounding
    # difference grows to the signal's size: 122-256 of 256 members differed before the fix)
    code = textwrap.dedent("""
        import sys, numpy as np, torch
        from freeplayid.model import default_fin
        from freeplayid.simulate import Sweep, simulate_sweeps
        from freeplayid.simulate.engines.numba.rk4_qs import rk4_qs_chunk
        r = simulate_sweeps(default_fin(), kn=480.0, delta=3e-3,
                            level_g=np.linspace(0.6, 1.2, 128), sweep=Sweep(38.0, 46.0, 4.0),
                            channels=("uz_top_left", "uz_lower_right"), dtype=torch.float32,
                            engine="numba", quantity="acceleration", frame="absolute",
                            quasi_static_hz=1500.0)
        np.save(sys.argv[1], r.signals)
        print(sum(rk4_qs_chunk.stats.cache_hits.values()))
    """)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    path = os.pathsep.join([os.path.join(root, "src")] + os.environ.get("PYTHONPATH", "").split(
        os.pathsep))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": path}
    hits = []
    for name in ("fresh", "cached"):
        p = subprocess.run([sys.executable, "-c", code, str(tmp_path / f"{name}.npy")], env=env,
                           capture_output=True, text=True, check=True, cwd=root)
        hits.append(int(p.stdout.split()[-1]))
    fresh, cached = (np.load(tmp_path / f"{n}.npy") for n in ("fresh", "cached"))
    assert hits[0] == 0 and hits[1] > 0, hits
    assert np.isfinite(fresh).all() and np.abs(fresh).max() > 50.0
    np.testing.assert_array_equal(fresh, cached)


@pytest.mark.parametrize("kernel,inlined", [("numba.rk4", ("arith", "fir")),
                                            ("numba.rk4_qs", ("arith", "fir", "rk4")),
                                            ("expo.kernel", ("arith", "fir"))])
def test_each_kernel_file_records_the_sources_it_inlines(kernel, inlined):
    # numba keys a cached kernel on its own file alone; the kernels inline functions of other
    # files, so an edit of those must come with an edit of the digest recorded in every file
    # that inlines them (else the cache would serve the kernel compiled from the old sources)
    import importlib

    from freeplayid.simulate.cache import CACHE, source_digest

    mod = importlib.import_module(f"freeplayid.simulate.engines.{kernel}")
    deps = [importlib.import_module(f"freeplayid.simulate.engines.numba.{d}") for d in inlined]
    digest = source_digest(*deps)
    assert digest == mod.INLINED_SHA256, (
        f"{', '.join(inlined)} changed: set INLINED_SHA256 = {digest!r} in {kernel}")
    assert mod._CACHE == CACHE
