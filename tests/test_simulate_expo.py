"""The exponential engine (``engine="expo"``) against references it did not produce."""

import numpy as np
import pytest
import scipy.integrate
import torch

import sdof_reference as ref
from freeplayid.model import (
    FreeplaySystem,
    default_fin,
    freeplay_force,
    rayleigh_damping,
    sdof_system,
)
from freeplayid.quantity import G
from freeplayid.simulate import Sweep, build_modal_form, simulate_sweeps
from freeplayid.simulate.engines import ENGINES, numba_available, resolve_engine
from freeplayid.simulate.engines.expo.steps import (
    MAX_STATE_SETS,
    STEPS_PER_RINGING_PERIOD,
    STEPS_PER_SWEEP_PERIOD,
    discretize,
    discretize_states,
    expo_step_limit,
    ringing_hz,
    state_code,
)
from freeplayid.simulate.formulation import static_equilibrium
from freeplayid.simulate.resample import design_decimator
from test_simulate import first_harmonic, linear_reference

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")
CPU = torch.device("cpu")


def chain3(*, stiff_tip: bool = False) -> FreeplaySystem:
    """3-DOF chain on the base, a freeplay spring between DOFs 2 and 1, Rayleigh damping (2 %
    at 30 and 50 Hz); ``stiff_tip``: a light, stiff tip DOF (top mode ~60 kHz, overdamped)."""
    m = np.array([1.0, 0.5, 0.002 if stiff_tip else 0.2])
    k = np.array([2e5, 6e4, 3e8 if stiff_tip else 3e4])
    K = np.array([[k[0] + k[1], -k[1], 0], [-k[1], k[1] + k[2], -k[2]], [0, -k[2], k[2]]])
    M = np.diag(m)
    return FreeplaySystem(M=M, K=K, C=rayleigh_damping(M, K, f1=30.0, f2=50.0, zeta=0.02),
                          dof_names=("a", "b", "c"), hinge_pairs=(("c", "b"),),
                          base_influence=np.ones(3))


def solve_ivp_reference(system, *, kn, delta, level, sweep, times, contact_damping=0.0):
    """Relative displacement (T, n) by DOP853 at rtol 1e-11 (freeplay force as a function;
    ``contact_damping``: each hinge's damper moment ``c theta'`` while |theta| > delta)."""
    M, C, K, B, r = system.M, system.damping, system.K, system.hinge_matrix(), system.influence
    n = M.shape[0]
    Mi = np.linalg.inv(M)
    c = np.broadcast_to(np.asarray(contact_damping, float), (B.shape[1],))

    def rhs(t, x):
        y, v = x[:n], x[n:]
        theta = B.T @ y
        f = freeplay_force(theta, kn, delta) + c * (np.abs(theta) > delta) * (B.T @ v)
        return np.concatenate([v, Mi @ (-K @ y - C @ v - B @ f) - r * level * G * np.sin(
            sweep.phase(t))])

    sol = scipy.integrate.solve_ivp(rhs, (0, times[-1]), np.zeros(2 * n), method="DOP853",
                                    rtol=1e-11, atol=1e-14, t_eval=times)
    return sol.y[:n].T


# ----------------------------------------------------------------------------- step matrices
def test_step_matrices_are_the_exact_integrals():
    # Phi, W, P against quadrature of exp(A (h - tau)) times the Lagrange / hat weights
    import scipy.linalg

    form = build_modal_form(chain3(), channels=("c",), quantity="displacement",
                            frame="relative", kn_max=1e4)
    h = 3e-4
    st = discretize(form, h)
    N = form.n_modes
    A = np.block([[np.zeros((N, N)), np.eye(N)], [-np.diag(form.lam), -form.Cm]])
    bg = np.concatenate([np.zeros(N), form.g])
    bf = np.concatenate([np.zeros((N, 1)), form.D])
    x, w = np.polynomial.legendre.leggauss(30)
    x, w = 0.5 * (x + 1), 0.5 * w
    E = np.stack([scipy.linalg.expm(A * h * (1 - xi)) for xi in x])
    quad = lambda wt: h * np.einsum("k,k,kij->ij", w, wt, E)  # noqa: E731
    np.testing.assert_allclose(st.Phi, scipy.linalg.expm(A * h), atol=1e-14)
    for row, wt in zip(st.W, ((1 - x) * (1 - 2 * x), 4 * x * (1 - x), x * (2 * x - 1))):
        np.testing.assert_allclose(row, quad(wt) @ bg, rtol=1e-10, atol=1e-16)
    np.testing.assert_allclose(st.P0, -quad(1 - x) @ -bf, rtol=1e-10, atol=1e-16)
    np.testing.assert_allclose(st.P1, -quad(x) @ -bf, rtol=1e-10, atol=1e-16)
    np.testing.assert_allclose(st.Gamma, form.D.T @ st.P1[:N], rtol=1e-12)


def test_state_matrices_are_the_exact_integrals():
    # per contact state: Phi_s = expm(A_s h) (contact stiffness inside A), W_s, c_s and the
    # residual input P1_s against Gauss-Legendre quadrature of exp(A_s (h - tau)), at each level
    import scipy.linalg

    form = build_modal_form(chain3(), channels=("c",), quantity="displacement",
                            frame="relative", kn_max=1e4)
    h, kn = 4e-4, 1e4
    ss = discretize_states(form, h, kn, levels=2)
    N = form.n_modes
    x, w = np.polynomial.legendre.leggauss(30)
    x, w = 0.5 * (x + 1), 0.5 * w
    for s in (-1, 0, 1):
        code = state_code([s])
        assert ss.states[code, 0] == s
        A = np.block([[np.zeros((N, N)), np.eye(N)],
                      [-np.diag(form.lam) - kn * abs(s) * form.D @ form.D.T, -form.Cm]])
        bg = np.concatenate([np.zeros(N), form.g])
        bc = np.concatenate([np.zeros(N), kn * s * form.D[:, 0]])
        for lv in range(3):
            hl = h / 2**lv
            E = np.stack([scipy.linalg.expm(A * hl * (1 - xi)) for xi in x])
            quad = lambda wt: hl * np.einsum("k,k,kij->ij", w, wt, E)  # noqa: B023, E731
            np.testing.assert_allclose(ss.Phi[lv, code], scipy.linalg.expm(A * hl), atol=1e-13)
            for row, wt in zip(ss.W[lv, code],
                               ((1 - x) * (1 - 2 * x), 4 * x * (1 - x), x * (2 * x - 1))):
                np.testing.assert_allclose(row, quad(wt) @ bg, rtol=1e-10, atol=1e-16)
            np.testing.assert_allclose(ss.c[lv, code], quad(np.ones_like(x)) @ bc, rtol=1e-10,
                                       atol=1e-16)
        np.testing.assert_allclose(ss.P1[code], quad(x) @ np.concatenate(
            [np.zeros((N, 1)), form.D]), rtol=1e-10, atol=1e-18)


# ----------------------------------------------------------------------------- (1) linear
@needs_numba
def test_linear_matches_solve_ivp():
    # delta larger than any motion: no contact, the linear part is exact; what is left is the
    # quadratic base load over a step and the FIR's pass-band ripple (<= 1e-6)
    system = chain3()
    sw = Sweep(20.0, 40.0, 20.0)
    res = simulate_sweeps(system, kn=1e4, delta=1.0, level_g=1.0, sweep=sw, channels=("a", "c"),
                          quantity="displacement", frame="relative", sample_rate=512.0,
                          dtype=torch.float64, engine="expo", progress=False)
    y = solve_ivp_reference(system, kn=1e4, delta=1.0, level=1.0, sweep=sw, times=res.time)
    y = y[:, [0, 2]].T
    i0 = 51  # after 0.1 s: the start transient of the modes above the FIR's pass band
    err = np.abs(res.signals[0][:, i0:] - y[:, i0:]).max() / np.abs(y).max()
    assert err < 3e-6, err


# ----------------------------------------------------------------------------- (2) freeplay
def _run_engine(form, *, kn, delta, level, v0, sweep, fs, m):
    # the engine driven directly (simulate_sweeps starts at rest; the SDOF reference starts on
    # the in-gap steady state): one chunk, outputs at fs
    from freeplayid.simulate.engines.expo.kernel import NumbaExpo

    h = 1.0 / (fs * m)
    taps = design_decimator(m)
    n_out = int(np.floor(sweep.duration * fs + 1e-9)) + 1
    look = (len(taps) - 1) // 2 // m + 1
    L = (n_out - 1 + look) * m + 1
    eng = NumbaExpo(form, np.array([kn]), np.array([delta]), np.array([level]),
                    np.zeros((1, 1)), np.array([[v0]]), h=h, quantity="displacement",
                    dtype=torch.float64, taps=taps, factor=m)
    out = np.empty((1, 1, n_out))
    eng.run(np.sin(sweep.phase(0.5 * np.arange(2 * L + 1) * h)), out)
    return out[0, 0], eng


@needs_numba
def test_sdof_freeplay_matches_the_independent_reference():
    # tests/sdof_reference.py: plain-Python RK4 of the SDOF freeplay oscillator (8 substeps per
    # sample, 61 us: ~2e-6 of its own error at the peak), started on the in-gap steady state
    sw = Sweep(30.0, 50.0, 1.0)
    level = 1.0
    y_ref = ref.simulate_sdof_sweep(level, sw, substeps=8)[0]
    wn = 2 * np.pi * ref.F_N
    system = sdof_system(mass=1.0, stiffness=0.0, damping=2 * ref.ZETA * wn)
    form = build_modal_form(system, channels=("x",), quantity="displacement", frame="relative",
                            kn_max=wn**2)
    h_rule = expo_step_limit(form, top_hz=sw.stop_hz, kn_max=wn**2)
    m = int(np.ceil(1 / (ref.FS * h_rule) - 1e-9))
    y, _ = _run_engine(form, kn=wn**2, delta=ref.DELTA, level=level,
                       v0=level * G / (2 * np.pi * sw.start_hz), sweep=sw, fs=ref.FS, m=m)
    t = np.arange(len(y)) / ref.FS
    a = first_harmonic(y[None], t, sw)[0]
    b = first_harmonic(y_ref[None], t, sw)[0]
    assert b.max() > 3 * ref.DELTA  # the run jumps onto the resonance branch
    assert abs(a.max() / b.max() - 1) < 1e-4, a.max() / b.max() - 1
    assert abs(int(a.argmax()) - int(b.argmax())) <= 2  # samples (1 ms of the 1 Hz/s sweep)


@needs_numba
def test_sdof_freeplay_matches_rk4_at_a_small_step():
    # both from rest, through simulate_sweeps; RK4 at a 15 us step (on the SDOF its own step
    # would be 0.5 ms: RK4 across the contact kinks needs a short one)
    wn = 2 * np.pi * ref.F_N
    system = sdof_system(mass=1.0, stiffness=0.0, damping=2 * ref.ZETA * wn)
    sw = Sweep(38.0, 50.0, 3.0)
    kw = dict(kn=wn**2, delta=ref.DELTA, level_g=[0.5, 0.8], sweep=sw, channels=("x",),
              quantity="acceleration", frame="relative", sample_rate=1024.0,
              dtype=torch.float64, progress=False)
    a = simulate_sweeps(system, engine="expo", **kw)
    b = simulate_sweeps(system, engine="numba", steps_per_sample=64, **kw)
    ha = first_harmonic(a.signals, a.time, sw)
    hb = first_harmonic(b.signals, b.time, sw)
    assert hb.max() > 0  # noqa: PLR2004
    err = np.abs(ha.max(-1) / hb.max(-1) - 1).max()
    assert err < 1e-4, err
    assert np.abs(ha.argmax(-1) - hb.argmax(-1)).max() <= 2


@needs_numba
@pytest.mark.parametrize("static_g", [1.0, -0.5])
def test_a_static_load_matches_the_independent_reference(static_g):
    # gravity on a vertical shaker: the panel rests on one stop, the response holds even
    # harmonics. tests/sdof_reference.py's plain RK4 with the constant added to a_g, started on
    # the stop, against simulate_sweeps(static_g=) through the exponential engine
    sw = Sweep(30.0, 50.0, 2.0)
    level = 1.0
    y_ref = ref.simulate_sdof_sweep(level, sw, substeps=8, static_g=static_g)[0]
    wn = 2 * np.pi * ref.F_N
    system = sdof_system(mass=1.0, stiffness=0.0, damping=2 * ref.ZETA * wn)
    res = simulate_sweeps(system, kn=wn**2, delta=ref.DELTA, level_g=level, sweep=sw,
                          channels=("x",), quantity="displacement", frame="relative",
                          sample_rate=ref.FS, dtype=torch.float64, progress=False,
                          static_g=static_g)
    assert res.engine == "expo" and res.static_g == static_g
    y = res.signals[0, 0]
    rest = -np.sign(static_g) * ref.DELTA - static_g * G / wn**2
    # on the stop from the start (the first sample: through the decimating filter)
    assert abs(y[0] / rest - 1) < 1e-4 and abs(y_ref[0] / rest - 1) < 1e-12
    t = np.arange(len(y)) / ref.FS
    a = first_harmonic(y[None], t, sw)[0]
    b = first_harmonic(y_ref[None], t, sw)[0]
    assert b.max() > 3 * ref.DELTA
    assert abs(a.max() / b.max() - 1) < 1e-3, a.max() / b.max() - 1
    assert abs(int(a.argmax()) - int(b.argmax())) <= 2
    # the record itself (its mean offset and even harmonics with it) up to the jump, past the
    # filter's start (after the jump the impacts make two exact integrators part in phase)
    k, j = int(0.1 * ref.FS), int(b.argmax())
    err = np.abs(y[k:j] - y_ref[k:j]).max() / np.abs(y_ref[k:j]).max()
    assert err < 1e-3, err
    # the same run without the load is another record: the load is what the check sees
    plain = simulate_sweeps(system, kn=wn**2, delta=ref.DELTA, level_g=level, sweep=sw,
                            channels=("x",), quantity="displacement", frame="relative",
                            sample_rate=ref.FS, dtype=torch.float64, progress=False)
    off = np.abs(plain.signals[0, 0, k:j] - y_ref[k:j]).max() / np.abs(y_ref[k:j]).max()
    assert off > 50 * err, (off, err)


def test_static_equilibrium_is_the_physical_one_on_the_fin():
    # the modal solve (contact state by state) against K y + sum_j b_j f(b_j^T y) = -M r a_s in
    # physical coordinates, each hinge on the stop the load pushes it to
    system = default_fin()
    kn, delta = 480.0, 3e-3
    form = build_modal_form(system, channels=system.dof_names, quantity="displacement",
                            frame="relative", kn_max=kn)
    for s_g in (1.0, -1.0, 0.3):
        eta = static_equilibrium(form, [kn, 2 * kn], [delta, delta], s_g)
        Bh = system.hinge_matrix()
        for i, k in enumerate((kn, 2 * kn)):
            th = form.D.T @ eta[i]
            side = np.sign(th)
            assert np.all(np.abs(th) > delta)  # every hinge rests on a stop
            Kc = system.K + k * Bh @ Bh.T
            y = np.linalg.solve(Kc, -system.M @ system.influence * s_g * G
                                + k * Bh @ (side * delta))
            np.testing.assert_allclose(th, Bh.T @ y, rtol=1e-8)
            np.testing.assert_allclose(form.S @ eta[i], y, rtol=1e-7,
                                       atol=1e-9 * np.abs(y).max())


def test_a_static_load_is_checked_before_the_run():
    system = sdof_system(mass=1.0, stiffness=0.0, damping=1.0)
    kw = dict(kn=1e5, delta=1e-4, level_g=0.5, sweep=Sweep(30.0, 50.0, 2.0), channels=("x",),
              progress=False)
    with pytest.raises(ValueError, match="static_g.*within"):
        simulate_sweeps(system, static_g=2.0, **kw)
    with pytest.raises(ValueError, match="method='relative'"):
        simulate_sweeps(system, static_g=1.0, method="large_mass", **kw)
    with pytest.raises(NotImplementedError, match="static load.*expo"):
        simulate_sweeps(system, static_g=1.0, engine="torch", **kw)
    with pytest.raises(ValueError, match="no static equilibrium"):
        simulate_sweeps(system, static_g=1.0, **{**kw, "kn": 0.0})


# ----------------------------------------------------------------------------- (3) two hinges
@needs_numba
def test_contact_solve_matches_the_exhaustive_search():
    # theta + Gamma f(theta) = a, Gamma of either sign structure, against the quasi-static
    # module's exhaustive search (the same equation, another implementation)
    from freeplayid.simulate.engines.expo.kernel import _contact
    from freeplayid.simulate.quasistatic import solve_hinge_states

    rng = np.random.default_rng(5)
    for H in (1, 2, 3):
        for _ in range(40):
            q = rng.normal(size=(H, H))
            Gm = q @ q.T * 10.0 ** rng.uniform(-6, -3) + rng.normal(size=(H, H)) * 1e-8
            kn, d = 10.0 ** rng.uniform(2, 5), rng.choice([0.0, 3e-3])
            a = rng.normal(size=H) * 5e-3
            st, tv = np.empty(H), np.empty(H)
            assert _contact(Gm, a, st, kn, np.full(H, d), np.empty((H, H)), tv, 1e-12)
            th_b, _ = solve_hinge_states(Gm, a, kn, d, exhaustive=True)
            np.testing.assert_allclose(tv, th_b, rtol=0, atol=1e-12)
            assert np.abs(tv + Gm @ freeplay_force(tv, kn, d) - a).max() < 1e-12


@needs_numba
@pytest.mark.parametrize("quantity, frame", [("displacement", "relative"),
                                             ("velocity", "absolute"),
                                             ("acceleration", "absolute")])
def test_two_hinge_fin_matches_rk4(quantity, frame):
    # default fin (two hinges, dense modal damping, knuckle modes to 9 kHz in the hinge
    # rotation), a segment through the jump at 4 Hz/s, at the rule's step (~206 us): first-harmonic
    # jump of both channels vs RK4 at omega_dt 0.5 (8.7 us), whose record is the quantity itself.
    # The linear-hold scheme erred 1e-2 here at 43 us. Level 1.2 g (a lower level rattles before
    # the jump: there RK4 at two small steps differs by ~1e-3 itself). The acceleration is the
    # replay's record: the engine takes it (and the velocity) as the displacement's derivative
    # inside its decimating FIR, so the ringing after each switch does not set the step; point
    # samples of the acceleration at this step alias that ringing into the band (first
    # harmonic 6 % off, docs/simulate.md)
    from freeplayid.model import default_fin

    fin = default_fin()
    sw = Sweep(38.0, 46.0, 4.0)
    kw = dict(kn=480.0, delta=3e-3, level_g=[1.2, 1.4], sweep=sw,
              channels=("uz_top_left", "uz_lower_right"), quantity=quantity, frame=frame,
              sample_rate=256.0, dtype=torch.float64, progress=False)
    b = simulate_sweeps(fin, engine="numba", omega_dt=0.5, **kw)
    a = simulate_sweeps(fin, engine="expo", **kw)
    assert not a.diverged.any() and a.dt > 2e-4 and b.dt < 1e-5
    ha = first_harmonic(a.signals, a.time, sw)
    hb = first_harmonic(b.signals, b.time, sw)
    assert np.abs(ha.max(-1) / hb.max(-1) - 1).max() < 2e-4
    assert np.abs(ha.argmax(-1) - hb.argmax(-1)).max() == 0
    # the record itself (after the FIR's start, 1 s), not only its first harmonic
    i0 = 256
    err = np.abs(a.signals[..., i0:] - b.signals[..., i0:]).max() / np.abs(b.signals).max()
    assert err < 1e-3, err


def test_the_plan_differentiates_the_displacement_through_a_decimating_filter():
    # the engine that differentiates gets the FIR of the displacement's derivative of the
    # quantity's order (velocity 1, acceleration 2), and at least two steps per sample so that a
    # decimating FIR exists (m = 1 would be the bare 5-point stencil); displacement: plain taps
    from freeplayid.model import default_fin
    from freeplayid.simulate.plan import step_plan
    from freeplayid.simulate.resample import derivative_taps

    fin, sw = default_fin(), Sweep(30.0, 46.5, 0.1)
    kw = dict(kn_max=480.0, sweep=sw, channels=("uz_top_left",), frame="absolute",
              method="relative", cutoff_hz=None, quasi_static_hz=None, omega_dt=1.5,
              steps_per_sample=None, large_mass_ratio=1e6, max_step=ENGINES["expo"].max_step,
              differentiate=True)
    for quantity, order in (("velocity", 1), ("acceleration", 2)):
        plan = step_plan(fin, sample_rate=256.0, quantity=quantity, **kw)
        assert plan.m == int(np.ceil(STEPS_PER_SWEEP_PERIOD * 46.5 / 256.0)) == 19
        taps, taps_d = derivative_taps(design_decimator(plan.m), plan.m, plan.h, order)
        np.testing.assert_array_equal(plan.taps, taps)
        np.testing.assert_array_equal(plan.taps_d, taps_d)
    assert step_plan(fin, sample_rate=8192.0, quantity="acceleration", **kw).m == 2
    assert step_plan(fin, sample_rate=256.0, quantity="displacement", **kw).taps_d is None


def chain_two_hinges() -> FreeplaySystem:
    """A base mass with two flaps on freeplay hinges of different inertia: their hinges close
    and open at different times."""
    m = np.array([1.0, 0.3, 0.12])
    M = np.diag(m)
    K = np.array([[2e5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    K = K + np.diag([0.0, 2e3, 5e2])
    return FreeplaySystem(M=M, K=K, C=rayleigh_damping(M, K + np.diag([0, 1e4, 1e4]), f1=30.0,
                                                      f2=50.0, zeta=0.02),
                          dof_names=("a", "b", "c"), hinge_pairs=(("b", "a"), ("c", "a")),
                          base_influence=np.ones(3))


@needs_numba
def test_two_hinges_switching_at_different_times_match_dop853():
    system = chain_two_hinges()
    sw = Sweep(20.0, 40.0, 10.0)
    kn, delta, level = 1e4, 2e-4, 0.5
    res = simulate_sweeps(system, kn=kn, delta=delta, level_g=level, sweep=sw,
                          channels=("b", "c"), quantity="displacement", frame="relative",
                          sample_rate=1024.0, dtype=torch.float64, engine="expo",
                          progress=False)
    assert res.engine == "expo" and not res.diverged.any()
    y = solve_ivp_reference(system, kn=kn, delta=delta, level=level, sweep=sw, times=res.time)
    B = system.hinge_matrix()
    theta = y @ B
    closed = np.abs(theta) > delta
    assert closed.any(0).all() and (~closed).any(0).all()  # both hinges switch ...
    assert (closed[:, 0] != closed[:, 1]).mean() > 0.05  # ... at different times
    # first harmonic (the raw record holds the contact's high-frequency content, which the
    # engine's anti-aliasing FIR removes and the reference keeps)
    ha = first_harmonic(res.signals, res.time, sw)[0]
    hb = first_harmonic(y[None, :, 1:].transpose(0, 2, 1), res.time, sw)[0]
    err = np.abs(ha.max(-1) / hb.max(-1) - 1).max()
    assert err < 1e-4, err
    assert np.abs(ha.argmax(-1) - hb.argmax(-1)).max() <= 1


@needs_numba
def test_damping_in_contact_matches_dop853():
    # a damper across each hinge acting only in contact (contact_damping), two hinges that
    # switch at different times: against DOP853 with the damper's moment in the hinge law.
    # Without it the peaks differ by 84 %. The damper acts in the state of the start of the
    # finest sub-step that holds a switch: 2.6e-4 here, 7.3e-5 and 1.1e-5 with that sub-step
    # 4 and 16 times shorter (SWITCH_STEPS_PER_RINGING_PERIOD), whatever the step
    system = chain_two_hinges()
    sw = Sweep(20.0, 40.0, 10.0)
    kn, delta, level, c = 1e4, 2e-4, 0.5, (4.0, 1.5)
    kw = dict(kn=kn, delta=delta, level_g=level, sweep=sw, channels=("b", "c"),
              quantity="displacement", frame="relative", sample_rate=1024.0,
              dtype=torch.float64, progress=False)
    res = simulate_sweeps(system, contact_damping=c, **kw)  # "auto": the expo engine
    assert res.engine == "expo" and res.contact_damping == c and not res.diverged.any()
    y = solve_ivp_reference(system, kn=kn, delta=delta, level=level, sweep=sw, times=res.time,
                            contact_damping=c)
    ha = first_harmonic(res.signals, res.time, sw)[0]
    hb = first_harmonic(y[None, :, 1:].transpose(0, 2, 1), res.time, sw)[0]
    err = np.abs(ha.max(-1) / hb.max(-1) - 1).max()
    assert err < 5e-4, err
    assert np.abs(ha.argmax(-1) - hb.argmax(-1)).max() <= 1
    free = first_harmonic(simulate_sweeps(system, engine="expo", **kw).signals, res.time, sw)[0]
    assert np.abs(free.max(-1) / hb.max(-1) - 1).max() > 50 * err
    # all zero: no damper (the same run as without); the RK4 engines refuse one
    same = simulate_sweeps(system, engine="expo", contact_damping=(0.0, 0.0), **kw)
    assert same.contact_damping is None
    np.testing.assert_array_equal(first_harmonic(same.signals, res.time, sw)[0], free)
    with pytest.raises(NotImplementedError, match="contact_damping"):
        simulate_sweeps(system, engine="numba", contact_damping=c, **kw)
    with pytest.raises(ValueError, match="contact_damping"):
        simulate_sweeps(system, contact_damping=(1.0, -1.0), **kw)


@needs_numba
@pytest.mark.parametrize("scheme", ["per_state", "linear_hold"])
def test_unequal_gaps_match_dop853(scheme, monkeypatch):
    # each hinge its own half-gap (gap_shares): against DOP853 with the per-hinge gaps in the
    # freeplay law, in both contact schemes; one common gap (the mean) is far off
    from freeplayid.simulate.engines.expo import steps as steps_expo

    kw = {}
    if scheme == "linear_hold":  # converged by its step (at its default: 0.6 %, equal gaps too)
        monkeypatch.setattr(steps_expo, "MAX_STATE_SETS", 0)
        kw["steps_per_sample"] = 64
    system = chain_two_hinges()
    sw = Sweep(20.0, 40.0, 10.0)
    kn, level = 1e4, 0.5
    gaps = np.array([1.4e-4, 2.6e-4])
    delta = gaps.mean()
    kw.update(kn=kn, delta=delta, level_g=level, sweep=sw, channels=("b", "c"),
              quantity="displacement", frame="relative", sample_rate=1024.0,
              dtype=torch.float64, engine="expo", progress=False)
    res = simulate_sweeps(system, gap_shares=gaps / delta, **kw)
    common = simulate_sweeps(system, **kw)
    assert res.gap_shares == pytest.approx(tuple(gaps / delta)) and common.gap_shares is None
    y = solve_ivp_reference(system, kn=kn, delta=gaps, level=level, sweep=sw, times=res.time)
    hb = first_harmonic(y[None, :, 1:].transpose(0, 2, 1), res.time, sw)[0]

    def err(r):
        return np.abs(first_harmonic(r.signals, r.time, sw)[0].max(-1) / hb.max(-1) - 1).max()

    assert err(res) < 1e-4, err(res)
    assert err(common) > 1e-2, err(common)


def test_unequal_gaps_torch_matches_expo_and_shares_of_one_change_nothing():
    system = chain_two_hinges()
    sw = Sweep(25.0, 35.0, 20.0)
    kw = dict(kn=1e4, delta=2e-4, level_g=0.5, sweep=sw, channels=("b", "c"),
              quantity="displacement", frame="relative", sample_rate=1024.0,
              dtype=torch.float64, progress=False)
    shares = (0.7, 1.3)
    rk4 = simulate_sweeps(system, engine="torch", gap_shares=shares, steps_per_sample=32, **kw)
    rk4_common = simulate_sweeps(system, engine="torch", **kw)
    assert np.array_equal(simulate_sweeps(system, engine="torch", gap_shares=(1, 1), **kw).signals,
                          rk4_common.signals)
    if numba_available():
        ex = simulate_sweeps(system, engine="expo", gap_shares=shares, **kw)
        assert ex.engine == "expo"
        a, b = first_harmonic(ex.signals, ex.time, sw)[0], first_harmonic(rk4.signals, rk4.time,
                                                                           sw)[0]
        assert np.abs(a.max(-1) / b.max(-1) - 1).max() < 1e-4
        assert np.array_equal(simulate_sweeps(system, engine="expo", gap_shares=[1.0, 1.0],
                                              **kw).signals,
                              simulate_sweeps(system, engine="expo", **kw).signals)
        # "auto" takes the exponential engine for unequal gaps (its RK4 kernel does not)
        assert simulate_sweeps(system, engine="auto", gap_shares=shares, **kw).engine == "expo"


def test_unequal_gaps_are_checked():
    system = chain_two_hinges()
    kw = dict(kn=1e4, delta=2e-4, level_g=0.5, sweep=Sweep(25.0, 26.0, 20.0), channels=("b",),
              sample_rate=256.0, progress=False)
    for bad in ((1.0,), (1.0, 0.0), (1.0, float("nan")), (1.0, 1.0, 1.0)):
        with pytest.raises(ValueError, match="`gap_shares` must be 2 finite values > 0"):
            simulate_sweeps(system, engine="torch", gap_shares=bad, **kw)
    if numba_available():
        with pytest.raises(NotImplementedError,
                           match="`gap_shares`.*engines \\['torch', 'expo'\\]"):
            simulate_sweeps(system, engine="numba", gap_shares=(0.8, 1.2), **kw)


# ----------------------------------------------------------------------------- (4) stiff, damped
@needs_numba
def test_overdamped_high_modes_are_stable_at_a_large_step():
    # a light, stiff tip: top mode ~60 kHz, Rayleigh-overdamped (an eigenvalue near -1e7/s):
    # RK4 would need dt < 0.3 us; the exponential engine takes its accuracy step, > 100x that,
    # and matches the closed-hinge (delta = 0) matrix-exponential reference
    system = chain3(stiff_tip=True)
    sw = Sweep(30.0, 40.0, 20.0)
    kw = dict(kn=1e4, delta=0.0, level_g=1.0, sweep=sw, channels=("a", "c"),
              quantity="displacement", frame="relative", sample_rate=512.0,
              dtype=torch.float64, engine="expo", progress=False)
    res = simulate_sweeps(system, **kw)
    assert res.dt * res.omega_max > 100 * 2.785
    assert not res.diverged.any()
    y = linear_reference(system, 1e4, 1.0, sw, res.time)[0][:, [0, 2]].T
    i0 = 51
    err = np.abs(res.signals[0][:, i0:] - y[:, i0:]).max() / np.abs(y).max()
    assert err < 1e-4, err


# ----------------------------------------------------------------------------- (5) batches
@needs_numba
@pytest.mark.parametrize("scheme", ["per_state", "linear_hold"])
def test_members_do_not_depend_on_the_batch(scheme, monkeypatch):
    # per_state: 3 distinct kn (a matrix set each); linear_hold: the fallback for batches with
    # more distinct kn than MAX_STATE_SETS (forced here for all)
    from freeplayid.model import default_fin
    from freeplayid.simulate.engines.expo import steps as steps_expo

    if scheme == "linear_hold":
        monkeypatch.setattr(steps_expo, "MAX_STATE_SETS", 0)
    fin = default_fin()
    sw = Sweep(40.0, 40.5, 1.0)
    rng = np.random.default_rng(0)
    lv = rng.uniform(0.4, 1.2, 24)
    kn = rng.choice([300.0, 480.0, 700.0], 24)
    kw = dict(delta=3e-3, sweep=sw, channels=("uz_top_left",), quantity="acceleration",
              frame="absolute", sample_rate=256.0, dtype=torch.float64, engine="expo",
              progress=False, steps_per_sample=8)
    full = simulate_sweeps(fin, kn=kn, level_g=lv, **kw)
    for idx in ([3], [0, 1, 2, 3, 4], list(range(24))):
        part = simulate_sweeps(fin, kn=kn[idx], level_g=lv[idx], **kw)
        assert np.array_equal(part.signals, full.signals[idx])


@needs_numba
def test_mixed_kn_falls_back_to_the_linear_hold():
    # more distinct kn than MAX_STATE_SETS: the linear-hold scheme, which converges to the
    # per-state one (same model, another contact treatment)
    from freeplayid.simulate.engines.expo import kernel as kernel_expo

    system = chain3()
    kn = np.linspace(5e3, 2e4, kernel_expo.MAX_STATE_SETS + 1)
    sw = Sweep(40.0, 60.0, 20.0)
    kw = dict(delta=2e-5, level_g=0.3, sweep=sw, channels=("c",), quantity="displacement",
              frame="relative", sample_rate=512.0, dtype=torch.float64, engine="expo",
              progress=False, steps_per_sample=64)
    mixed = simulate_sweeps(system, kn=kn, **kw)
    one = simulate_sweeps(system, kn=kn[[-1]], **kw)
    assert not mixed.diverged.any()
    y = one.signals[0]
    assert np.abs(mixed.signals[-1] - y).max() < 1e-3 * np.abs(y).max()
    assert not np.array_equal(mixed.signals[-1], y)  # the two schemes did run


# ----------------------------------------------------------------------------- (6) registry
def test_expo_is_registered_and_declares_its_step_rule(monkeypatch):
    cls = ENGINES["expo"]
    assert cls.decimates and not cls.quasi_static
    # its step is set by accuracy: expo_step_limit at the sweep's top frequency, whatever omega_dt
    form = build_modal_form(chain3(stiff_tip=True), channels=("a",), quantity="acceleration",
                            frame="absolute", kn_max=1e4)
    h = expo_step_limit(form, top_hz=40.0, kn_max=1e4, per_state=True)
    assert h == 1.0 / (STEPS_PER_SWEEP_PERIOD * 40.0)
    for sw, omega_dt in ((Sweep(30.0, 40.0, 50.0), 1.5), (Sweep(40.0, 30.0, 50.0), 0.1)):
        assert cls.max_step(form, sweep=sw, kn_max=1e4, omega_dt=omega_dt) == h
    # more distinct kn than the per-state scheme takes: the linear hold, whose step also
    # resolves the ringing of the closed-hinge modes
    h_hold = expo_step_limit(form, top_hz=40.0, kn_max=1e4)
    assert h_hold == min(h, 1.0 / (STEPS_PER_RINGING_PERIOD * ringing_hz(form, 1e4)))
    assert cls.max_step(form, sweep=sw, kn_max=1e4, omega_dt=1.5,
                        distinct_kn=MAX_STATE_SETS + 1) == h_hold
    assert cls.differentiates and not ENGINES["numba"].differentiates
    assert ENGINES["numba"].max_step(form, sweep=sw, kn_max=1e4, omega_dt=1.5) < h / 100
    assert cls.available() == numba_available()
    # "auto" stays RK4 (the training bank's cache key and pinned results depend on it)
    assert resolve_engine("auto", device=CPU)[0] in ("numba", "torch")
    import freeplayid.simulate.engines.expo.engine as expo

    monkeypatch.setattr(expo, "numba_available", lambda: False)
    assert not cls.available()
    with pytest.raises(ValueError, match="runs on the CPU only"):
        resolve_engine("expo", device=torch.device("cuda"))
    with pytest.raises(NotImplementedError, match="quasi_static_hz"):
        resolve_engine("expo", device=CPU, quasi_static=True)


@needs_numba
def test_simulate_sweeps_uses_the_accuracy_step():
    system = chain3(stiff_tip=True)
    sw = Sweep(30.0, 40.0, 50.0)
    res = simulate_sweeps(system, kn=1e4, delta=1e-4, level_g=1.0, sweep=sw, channels=("a",),
                          sample_rate=512.0, dtype=torch.float64, engine="expo", progress=False)
    form = build_modal_form(system, channels=("a",), quantity="acceleration", frame="absolute",
                            kn_max=1e4)
    m = int(np.ceil(1 / (512.0 * expo_step_limit(form, top_hz=40.0, kn_max=1e4, per_state=True))
                    - 1e-9))
    assert res.engine == "expo" and res.steps_per_sample == m

