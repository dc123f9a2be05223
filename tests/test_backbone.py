import warnings

import numpy as np
import pytest

from freeplayid.backbone import BACKBONE_METHODS, backbone_curve, dfa_backbone, hb_backbone
from freeplayid.model import (
    FreeplaySystem,
    describing_function,
    modal_analysis,
    sdof_system,
    two_dof_system,
)


def exact_sdof_omega(peak, delta, omega_n):
    """Exact backbone of the pure freeplay oscillator (docs/backbone.md)."""
    return omega_n / (1.0 + 2.0 * delta / (np.pi * (peak - delta)))


def two_hinge_system():
    """Inboard mass on a root spring carrying two unequal outboard masses on freeplay springs."""
    return FreeplaySystem(
        M=np.diag([2.0, 0.5, 0.8]),
        K=np.diag([5.0e4, 0.0, 0.0]) + 3.0e3 * np.array([[0, 0, 0], [0, 1, -1], [0, -1, 1.0]]),
        dof_names=("a", "b", "c"),
        hinge_pairs=(("b", "a"), ("c", "a")),
        base_influence=[1.0, 1.0, 1.0],
    )


def test_dfa_sdof_is_the_describing_function_frequency():
    bc = dfa_backbone(sdof_system(mass=2.0), kn=[8.0e4, 2.0e4], delta=[1e-3, 2e-3])
    amp = bc.channel("x")
    wn = np.sqrt(np.array([8.0e4, 2.0e4]) / 2.0)[:, None]
    expected = wn * np.sqrt(describing_function(amp, bc.delta[:, None])) / (2 * np.pi)
    np.testing.assert_allclose(bc.frequency_hz, expected, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("peak_over_delta, max_err", [(1.2, 0.004), (1.5, 0.001), (3.0, 1e-4)])
def test_hb_matches_exact_sdof_backbone_where_dfa_fails(peak_over_delta, max_err):
    delta, kn = 1.0, 1.0
    s = np.linspace(1.02, 3.5, 60)
    hb = hb_backbone(sdof_system(), kn=kn, delta=delta, s=s, n_harmonics=7, n_time=1024)
    assert hb.converged.all()
    peak = hb.peak_amplitude[0, :, 0]
    err = hb.frequency_hz[0] * 2 * np.pi / exact_sdof_omega(peak, delta, 1.0) - 1
    # error at the requested peak amplitude (interpolated along the curve)
    assert abs(np.interp(peak_over_delta, peak, err)) < max_err
    # the DFA at the exact solution's first harmonic: -53 % at 1.2 delta, -7 % at 1.5, -0.15 % at 3
    a1 = np.interp(peak_over_delta, peak, hb.amplitude[0, :, 0])
    w_dfa = np.sqrt(describing_function(a1, delta))
    dfa_err = w_dfa / exact_sdof_omega(peak_over_delta, delta, 1.0) - 1
    expected = {1.2: -0.53, 1.5: -0.07, 3.0: -0.0015}[peak_over_delta]
    assert dfa_err == pytest.approx(expected, rel=0.1)


def test_scale_invariance_of_the_backbone():
    sys_ = two_hinge_system()
    a = dfa_backbone(sys_, kn=2.0e3, delta=1e-3)
    b = dfa_backbone(sys_, kn=2.0e3, delta=3.7e-3)
    np.testing.assert_allclose(b.frequency_hz, a.frequency_hz, rtol=1e-12)
    np.testing.assert_allclose(b.amplitude, 3.7 * a.amplitude, rtol=1e-10)


def test_backbone_limits_open_and_closed_hinge():
    sys_ = two_dof_system()
    kn = 2.0e4
    bc = dfa_backbone(sys_, kn=kn, delta=1e-3, s=np.array([1.000001, 1e6]))
    closed = modal_analysis(sys_.M, sys_.closed_stiffness(kn)).frequencies_hz[0]
    open_ = modal_analysis(sys_.M, sys_.K).frequencies_hz[0]
    assert bc.frequency_hz[0, -1] == pytest.approx(closed, rel=1e-5)
    assert bc.frequency_hz[0, 0] == pytest.approx(open_, abs=1e-2 * closed)
    assert np.all(np.diff(dfa_backbone(sys_, kn=kn, delta=1e-3).frequency_hz[0]) > 0)


def test_unequal_hinges_fixed_point_equals_one_harmonic_balance():
    sys_ = two_hinge_system()
    s = np.geomspace(1.05, 20, 25)
    dfa = dfa_backbone(sys_, kn=4.0e3, delta=2e-3, s=s)
    assert dfa.converged.all()
    ratio = dfa.hinge_amplitude[0].min(axis=1) / dfa.hinge_amplitude[0].max(axis=1)
    assert ratio.min() < 0.95  # the hinges really are unequal here
    hb1 = hb_backbone(sys_, kn=4.0e3, delta=2e-3, s=s, n_harmonics=1, n_time=8192)
    np.testing.assert_allclose(hb1.frequency_hz, dfa.frequency_hz, rtol=2e-5)
    np.testing.assert_allclose(hb1.amplitude, dfa.amplitude, rtol=1e-4, atol=1e-9)
    # the equal-hinge approximation differs from the consistent solution
    eq = dfa_backbone(sys_, kn=4.0e3, delta=2e-3, s=s, equal_hinges=True)
    assert np.max(np.abs(eq.frequency_hz / dfa.frequency_hz - 1)) > 1e-3


def test_a_hinges_own_gap_is_its_describing_function():
    """One hinge with its half-gap 1.7 x delta: the describing function of 1.7 delta exactly;
    two hinges, the second's gap so large that it never closes: the curve of the system
    without that hinge (the same amplitudes, the same frequencies); gaps equal to c: delta x c."""
    bc = dfa_backbone(sdof_system(mass=2.0), kn=8.0e4, delta=1e-3, gaps=[1.7])
    wn = np.sqrt(8.0e4 / 2.0)
    expected = wn * np.sqrt(describing_function(bc.channel("x")[0], 1.7e-3)) / (2 * np.pi)
    np.testing.assert_allclose(bc.frequency_hz[0], expected, rtol=1e-10)

    two = two_hinge_system()
    one = FreeplaySystem(
        M=two.M, K=two.K, dof_names=two.dof_names, hinge_pairs=two.hinge_pairs[:1],
        base_influence=two.base_influence)
    far = dfa_backbone(two, kn=4.0e3, delta=2e-3, gaps=[1.0, 1e3], s=np.geomspace(1.05, 20, 40))
    assert far.converged.all()
    s1 = far.hinge_amplitude[0, :, 0] / 2e-3  # hinge 1's amplitude over its gap
    ref = dfa_backbone(one, kn=4.0e3, delta=2e-3, s=s1[s1 > 1.0])
    np.testing.assert_allclose(far.frequency_hz[0, s1 > 1.0], ref.frequency_hz[0], rtol=1e-7)
    np.testing.assert_allclose(far.amplitude[0, s1 > 1.0], ref.amplitude[0], rtol=1e-6)
    s = np.geomspace(2.2, 20, 30)
    same = dfa_backbone(two, kn=4.0e3, delta=1e-3, gaps=[2.0, 2.0], s=s)
    ref = dfa_backbone(two, kn=4.0e3, delta=2e-3, s=s / 2.0)
    np.testing.assert_allclose(same.frequency_hz, ref.frequency_hz, rtol=1e-9)
    np.testing.assert_allclose(same.amplitude, ref.amplitude, rtol=1e-7)
    with pytest.raises(ValueError, match="gaps"):
        dfa_backbone(two, kn=4.0e3, delta=1e-3, gaps=[1.0])


def test_batched_kn_equals_individual_calls_and_frequency_at():
    sys_ = two_dof_system()
    kns = np.array([5e3, 2e4, 8e4])
    batch = dfa_backbone(sys_, kn=kns, delta=1e-3)
    for i, k in enumerate(kns):
        one = dfa_backbone(sys_, kn=k, delta=1e-3)
        np.testing.assert_allclose(batch.frequency_hz[i], one.frequency_hz[0], rtol=1e-12)
    x = batch.channel("uz_out")[1, 80]
    assert batch.frequency_at([x], "uz_out")[1, 0] == pytest.approx(batch.frequency_hz[1, 80])
    assert np.isnan(batch.frequency_at([1e9], "uz_out")).all()


def test_backbone_input_errors():
    with pytest.raises(ValueError, match="delta"):
        dfa_backbone(two_dof_system(), kn=1.0, delta=0.0)
    with pytest.raises(ValueError, match="broadcast"):
        dfa_backbone(two_dof_system(), kn=[1.0, 2.0], delta=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="no hinge"):
        dfa_backbone(
            FreeplaySystem(M=np.eye(1), K=np.eye(1), dof_names=("x",), hinge_pairs=()),
            kn=1.0,
            delta=1.0,
        )
    with pytest.raises(KeyError, match="unknown channel"):
        dfa_backbone(two_dof_system(), kn=1.0, delta=1.0).channel("nope")


def test_inconsistent_points_are_flagged_not_hidden():
    # nearly decoupled outboard masses: near contact the softer hinge falls into its gap and the
    # lowest mode switches hinge, so no consistent DFA point exists there; it must be flagged
    weak = FreeplaySystem(
        M=np.diag([2.0, 0.5, 0.8]),
        K=np.diag([5.0e4, 0.0, 0.0]) + 300.0 * np.array([[0, 0, 0], [0, 1, -1], [0, -1, 1.0]]),
        dof_names=("a", "b", "c"),
        hinge_pairs=(("b", "a"), ("c", "a")),
    )
    bc = dfa_backbone(weak, kn=4.0e3, delta=2e-3, s=np.array([1.1, 1.3, 20.0]))
    assert not bc.converged[0, 0] and bc.converged[0, -1]


def test_backbone_comparison_figure_draws_every_curve():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from freeplayid.plots import plot_backbone_comparison

    s = np.array([1.1, 1.5, 2.0, 4.0])
    bc = dfa_backbone(sdof_system(), kn=1.0, delta=1.0, s=s)
    fig, ax = plt.subplots()
    peak = np.linspace(1.05, 4.0, 20)
    plot_backbone_comparison(
        ax,
        [("DFA", bc.channel("x")[0], bc.frequency_hz[0])],
        exact=(peak, 1.0 / (1.0 + 2.0 / (np.pi * (peak - 1.0)))),
    )
    lines = ax.get_lines()
    assert len(lines) == 2
    np.testing.assert_allclose(lines[1].get_ydata(), 2 * np.pi * bc.frequency_hz[0])
    plt.close(fig)


def test_hb_continuation_caught_on_an_internal_resonance_falls_back_to_dfa():
    """Default fin, kn = 720: 5 x f meets the second mode (252 Hz) at f = 50.5 Hz. The HB
    continuation then stays on that branch (frequency flat in s) instead of the fundamental;
    those points must be flagged, warned about and replaced by the DFA ones."""
    import warnings

    from freeplayid.model import default_fin

    fin = default_fin()
    s = np.geomspace(1.05, 20.0, 60)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hb = hb_backbone(fin, kn=720.0, delta=3e-3, s=s, n_harmonics=5)
    msgs = [str(w.message) for w in caught if "internal resonance" in str(w.message)]
    assert msgs and "harmonic [5]" in msgs[0]
    dfa = dfa_backbone(fin, kn=720.0, delta=3e-3, s=s)
    f, fd = hb.frequency_hz[0], dfa.frequency_hz[0]
    locked = ~hb.converged[0]
    assert locked[:10].all() and not locked[-10:].any()
    np.testing.assert_allclose(f[locked], fd[locked], rtol=1e-12)
    assert np.all(np.diff(f) > -1e-6 * f[1:])  # the hardening backbone rises with s again
    # with harmonics 1 and 3 only, 3 f stays far from every mode in this band: no fallback
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hb2 = hb_backbone(fin, kn=720.0, delta=3e-3, s=s, n_harmonics=2)
    assert hb2.converged[0].all()


def _assert_same_curve(a, b):
    for name in ("frequency_hz", "amplitude", "hinge_amplitude", "kappa", "kn", "delta",
                 "converged"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.dof_names == b.dof_names and a.method == b.method


def test_backbone_curve_dispatches_by_name_to_the_registered_method():
    sys_ = two_hinge_system()
    s = np.array([1.2, 2.0, 5.0])
    by_name = backbone_curve(sys_, method="dfa", kn=[4.0e3, 8.0e3], delta=2e-3, s=s)
    _assert_same_curve(by_name, dfa_backbone(sys_, kn=[4.0e3, 8.0e3], delta=2e-3, s=s))
    assert by_name.method == "dfa"
    # the default method is the DFA; options reach the method
    _assert_same_curve(backbone_curve(sys_, kn=4.0e3, delta=2e-3, s=s, equal_hinges=True),
                       dfa_backbone(sys_, kn=4.0e3, delta=2e-3, s=s, equal_hinges=True))
    hb = backbone_curve(sdof_system(), method="hb", kn=2.0, delta=1e-3, s=s, n_harmonics=3)
    _assert_same_curve(hb, hb_backbone(sdof_system(), kn=2.0, delta=1e-3, s=s, n_harmonics=3))
    assert BACKBONE_METHODS["dfa"] is dfa_backbone and BACKBONE_METHODS["hb"] is hb_backbone


def test_unknown_backbone_method_lists_the_registered_names():
    with pytest.raises(ValueError) as err:
        backbone_curve(two_dof_system(), method="x", kn=1.0, delta=1.0)
    assert str(err.value) == f"`method` must be one of {sorted(BACKBONE_METHODS)}, got 'x'"
    assert "['dfa', 'hb']" in str(err.value)  # the two methods of today, in the message


def test_a_mode_whose_hinge_is_at_rest_gives_no_curve_and_no_warning():
    # found where a fit's lost start ran to kn ~ 3e25 on a hinged beam: the mode's hinge
    # rotation rounded to zero and numpy warned of 0/0 in the user's console. Here mode 0 is a
    # mass the hinge does not touch, so its hinge rotation is exactly zero at any kn.
    from freeplayid.model import FreeplaySystem

    system = FreeplaySystem(M=np.diag([1.0, 1.0, 1.0]), K=np.diag([4.0e4, 0.0, 1.0e2]),
                            dof_names=("a", "b", "c"), hinge_pairs=(("b", "a"),),
                            base_influence=[1.0, 1.0, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bc = dfa_backbone(system, kn=1.0e3, delta=1.0e-3, s=np.array([2.0, 3.0]))
    assert bc.frequency_hz[0] == pytest.approx(np.sqrt(1.0e2) / (2 * np.pi))  # the lone mass
    assert not np.any(np.isfinite(bc.hinge_amplitude))  # no hinge amplitude sets its scale


def _hinge_chain():
    """A mass on a root spring, then two flaps in series, each on its own freeplay hinge: with
    both hinges open there are two mechanisms, so the lowest mode flips from one hinge to the
    other near contact and the DFA's Newton points there cycle instead of converging."""
    return FreeplaySystem(
        M=np.diag([2.0, 0.5, 0.3]),
        K=np.diag([5.0e4, 0.0, 0.0]),
        dof_names=("a", "b", "c"),
        hinge_pairs=(("b", "a"), ("c", "b")),
        base_influence=[1.0, 1.0, 1.0],
    )


@pytest.mark.parametrize("max_iter", [100, 99])
def test_newton_points_that_cycle_are_settled_as_the_full_loop_would_leave_them(
        monkeypatch, max_iter):
    """Points whose Newton iterates repeat (period 2: the hinges' kappas swapped) are set at
    once to the iterate of ``max_iter`` (either parity), not run there: the same curve as the
    loop that runs them, in a fraction of its eigen-batches."""
    import freeplayid.backbone.dfa as dfa

    calls = []
    eigh = np.linalg.eigh
    monkeypatch.setattr(dfa.np.linalg, "eigh", lambda a: calls.append(1) or eigh(a))
    fast = dfa_backbone(_hinge_chain(), kn=[4.0e3, 2.0e4], delta=1e-3, max_iter=max_iter)
    n_fast = len(calls)
    monkeypatch.setattr(dfa._Cycles, "settle", lambda self, active, *a: active)
    calls.clear()
    full = dfa_backbone(_hinge_chain(), kn=[4.0e3, 2.0e4], delta=1e-3, max_iter=max_iter)
    assert 0.2 < full.converged.mean() < 0.6  # the flipping part of the curve is there
    assert len(calls) == 1 + 3 * max_iter  # the loop ran every point to max_iter
    assert n_fast < 40
    np.testing.assert_array_equal(fast.converged, full.converged)
    for field in ("frequency_hz", "amplitude", "hinge_amplitude", "kappa"):
        np.testing.assert_allclose(getattr(fast, field), getattr(full, field), rtol=1e-9,
                                   atol=1e-12, err_msg=field)
