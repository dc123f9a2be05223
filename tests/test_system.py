import numpy as np
import pytest

from freeplayid.model import (
    FreeplaySystem,
    SystemFileError,
    load_system,
    mac,
    modal_analysis,
    modal_damping,
    pair_modes,
    rayleigh_damping,
    save_system,
    sdof_system,
    two_dof_system,
)


def _system():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(4, 4))
    M = a @ a.T + 4 * np.eye(4)
    b = rng.normal(size=(4, 4))
    K = b @ b.T * 1e3
    return FreeplaySystem(
        M=M,
        K=K,
        dof_names=("uz_a", "uz_b", "rx_in", "rx_out"),
        hinge_pairs=(("rx_out", "rx_in"),),
        C=0.01 * K,
        base_influence=[1.0, 1.0, 0.0, 0.0],
    )


def test_hinge_matrix_and_closed_stiffness():
    s = _system()
    B = s.hinge_matrix()
    np.testing.assert_array_equal(B[:, 0], [0, 0, -1, 1])
    Kc = s.closed_stiffness(10.0)
    assert Kc[3, 3] - s.K[3, 3] == pytest.approx(10.0)
    assert Kc[2, 3] - s.K[2, 3] == pytest.approx(-10.0)


def test_npz_round_trip(tmp_path):
    s = _system()
    p = save_system(tmp_path / "m.npz", s)
    t = load_system(p)
    for key in ("M", "K", "C", "base_influence"):
        np.testing.assert_array_equal(getattr(t, key), getattr(s, key))
    assert t.dof_names == s.dof_names and t.hinge_pairs == s.hinge_pairs
    assert t.fingerprint() == s.fingerprint()
    # ground springs (empty inboard name) survive the round trip too
    u = load_system(save_system(tmp_path / "sdof.npz", sdof_system()))
    assert u.hinge_pairs == (("x", ""),)


def _write(tmp_path, **fields):
    s = _system()
    data = {
        "M": s.M,
        "K": s.K,
        "dof_names": np.array(s.dof_names),
        "hinge_pairs": np.array(s.hinge_pairs),
    }
    data.update(fields)
    data = {k: v for k, v in data.items() if v is not None}
    p = tmp_path / "bad.npz"
    np.savez(p, **data)
    return p


@pytest.mark.parametrize(
    "fields, match",
    [
        ({"K": None}, r"missing required field\(s\) \['K'\]"),
        ({"K": np.triu(np.ones((4, 4)))}, r"field 'K' must be symmetric"),
        ({"hinge_pairs": np.array([["rx_out", "rx_nowhere"]])}, r"'rx_nowhere' is not in"),
        ({"M": np.eye(3)}, r"field 'M' must have shape \(4, 4\)"),
        ({"hinge_pairs": np.array(["rx_out", "rx_in"])}, r"'hinge_pairs' must have shape \(h, 2\)"),
        ({"base_influence": np.ones(3)}, r"'base_influence' must have shape \(4,\)"),
        ({"M": -np.eye(4)}, r"'M' must be positive definite"),
        ({"extra": np.ones(2)}, r"unknown field\(s\) \['extra'\]"),
        ({"dof_names": np.array(["a", "a", "rx_in", "rx_out"])}, r"must be unique"),
    ],
)
def test_malformed_files_give_clear_errors(tmp_path, fields, match):
    p = _write(tmp_path, **fields)
    with pytest.raises(SystemFileError, match=match) as info:
        load_system(p)
    assert str(p) in str(info.value)


def test_missing_and_unreadable_file(tmp_path):
    with pytest.raises(SystemFileError, match="not found"):
        load_system(tmp_path / "nope.npz")
    bad = tmp_path / "junk.npz"
    bad.write_text("not a zip")
    with pytest.raises(SystemFileError, match="not a readable"):
        load_system(bad)


def test_save_is_atomic_and_adds_suffix(tmp_path):
    p = save_system(tmp_path / "model", _system())
    assert p.name == "model.npz" and p.exists()
    assert sorted(x.name for x in tmp_path.iterdir()) == ["model.npz"]
    with pytest.raises(TypeError):
        save_system(tmp_path / "x.npz", "not a system")


def test_mac_identity_and_pairing():
    s = _system()
    modes = modal_analysis(s.M, s.K)
    np.testing.assert_allclose(mac(modes.shapes, modes.shapes).diagonal(), 1.0)
    # M-orthogonal modes are not Euclidean-orthogonal in general; the MAC of a set with itself is
    # the identity for an identity mass matrix
    s2 = FreeplaySystem(M=np.eye(4), K=s.K, dof_names=s.dof_names, hinge_pairs=s.hinge_pairs)
    m2 = modal_analysis(s2.M, s2.K)
    np.testing.assert_allclose(mac(m2.shapes, m2.shapes), np.eye(4), atol=1e-12)
    perm = [2, 0, 3, 1]
    idx, val = pair_modes(m2.shapes, -m2.shapes[:, perm] * 3.0)
    np.testing.assert_array_equal(idx, np.argsort(perm))
    np.testing.assert_allclose(val, 1.0)


def test_modal_analysis_matches_two_dof_closed_form():
    s = two_dof_system(m_in=2.0, m_out=1.0, k_in=8.0)
    kn = 3.0
    modes = modal_analysis(s.M, s.closed_stiffness(kn))
    # det(K - w^2 M) = 0 for K = [[11, -3], [-3, 3]], M = diag(2, 1)
    lam = np.roots([2.0, -(11 * 1 + 3 * 2), 11 * 3 - 9])
    np.testing.assert_allclose(np.sort(modes.omega**2), np.sort(lam))
    np.testing.assert_allclose(modes.shapes.T @ s.M @ modes.shapes, np.eye(2), atol=1e-12)


def test_damping_helpers_give_requested_ratios():
    s = two_dof_system()
    K = s.closed_stiffness(2.0e4)
    modes = modal_analysis(s.M, K)
    f1, f2 = modes.frequencies_hz
    C = rayleigh_damping(s.M, K, f1=f1, f2=f2, zeta=0.03)
    zeta = np.diag(modes.shapes.T @ C @ modes.shapes) / (2 * modes.omega)
    np.testing.assert_allclose(zeta, 0.03, rtol=1e-10)
    Cm = modal_damping(s.M, K, [0.01, 0.05])
    zeta_m = modes.shapes.T @ Cm @ modes.shapes / (2 * modes.omega)
    np.testing.assert_allclose(zeta_m, np.diag([0.01, 0.05]), atol=1e-12)
    with pytest.raises(ValueError, match="f1 < f2"):
        rayleigh_damping(s.M, K, f1=10.0, f2=5.0, zeta=0.02)


def test_open_hinge_mechanism_is_allowed_but_indefinite_k_is_not():
    # outboard DOF held only by the freeplay spring: K is singular, which is legal
    s = FreeplaySystem(
        M=np.eye(2), K=[[1.0, 0.0], [0.0, 0.0]], dof_names=("a", "b"), hinge_pairs=(("b", "a"),)
    )
    assert modal_analysis(s.M, s.K).frequencies_hz[0] == pytest.approx(0.0, abs=1e-9)
    assert modal_analysis(s.M, s.closed_stiffness(1.0)).frequencies_hz[0] > 0
    with pytest.raises(ValueError, match="positive semidefinite"):
        FreeplaySystem(M=np.eye(2), K=-np.eye(2), dof_names=("a", "b"), hinge_pairs=())


def test_replace_and_unknown_dof():
    s = _system()
    t = s.replace(C=None)
    assert t.C is None and s.C is not None
    with pytest.raises(TypeError, match="unknown FreeplaySystem fields"):
        s.replace(mass=1)
    with pytest.raises(KeyError, match="unknown DOF 'zz'"):
        s.dof_index("zz")


def test_pairing_breaks_a_tie_of_shapes_by_frequency_and_only_a_tie():
    """Two measured DOFs: a shape is one ratio, so a model mode far off in frequency can match
    a reference mode's shape better than the right one (fin D's sealed mode 2 at 218.5 Hz,
    shape (1, -0.2225): its model mode 2 at 222.6 Hz reads (3.81, -0.855), MAC 0.99999, and a
    mode at 4 kHz the ratio exactly). Given the frequencies, the tie (within 0.01 of the best
    MAC) goes to the nearest; a clear MAC difference is not overridden by frequency."""
    ref = np.array([[1.0, 1.0], [0.161, -0.2225]])  # two reference modes at 53.5, 218.5 Hz
    model = np.array([[2.41, 3.81, -2.0], [0.388, -0.855, 0.445]])  # 53.8, 222.6, 4000 Hz
    f_ref, f = np.array([53.5, 218.5]), np.array([53.8, 222.6, 4000.0])
    assert pair_modes(ref, model)[0].tolist() == [0, 2]  # by MAC alone: the 4 kHz mode
    idx, val = pair_modes(ref, model, frequencies=(f_ref, f))
    assert idx.tolist() == [0, 1] and val[1] > 0.9999
    # a clear MAC difference stands whatever the frequencies: (1, 0) against (1, 0.2) and (0, 1)
    clear = pair_modes(np.array([[1.0], [0.0]]), np.array([[1.0, 0.0], [0.2, 1.0]]),
                       frequencies=([100.0], [300.0, 100.0]))[0]
    assert clear.tolist() == [0]
