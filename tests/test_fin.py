"""The default folding fin: reduced system contract, hinge physics, knuckle convergence, config."""

import copy

import numpy as np
import pytest
import scipy.sparse.linalg as spla
import yaml

from freeplayid.model import (
    FIN_HINGE_PAIRS,
    REDUCED_DOF_NAMES,
    build_fin_fe,
    default_fin,
    default_fin_parameters,
    fin_config_path,
    fin_from_config,
    load_fin_config,
    load_system,
    modal_analysis,
    part_matrices,
    reduce_fin,
    save_system,
)


@pytest.fixture(scope="module")
def cfg():
    return load_fin_config()


@pytest.fixture(scope="module")
def mapping():
    return yaml.safe_load(fin_config_path().read_text(encoding="utf-8"))  # package data


@pytest.fixture(scope="module")
def fin():
    return default_fin()


def test_default_fin_contract(fin, cfg):
    assert fin.dof_names == REDUCED_DOF_NAMES + tuple(f"q{i}" for i in range(1, 7))
    assert fin.hinge_pairs == FIN_HINGE_PAIRS
    assert fin.M.shape == fin.K.shape == fin.C.shape == (12, 12)
    assert fin.base_influence.shape == (12,)
    B = fin.hinge_matrix()
    assert B[fin.dof_index("rx_left_out"), 0] == 1 and B[fin.dof_index("rx_left_in"), 0] == -1
    assert B[fin.dof_index("rx_mid_out"), 1] == 1 and B[fin.dof_index("rx_mid_in"), 1] == -1
    assert np.linalg.eigvalsh(fin.C).min() > -1e-9 * np.abs(fin.C).max()
    assert default_fin_parameters() == {"kn": cfg.kn, "delta": cfg.delta}
    assert cfg.kn > 0 and cfg.delta == pytest.approx(0.003)


def test_open_hinge_is_one_mechanism_and_closed_hinge_is_near_50_hz(fin, cfg):
    f_open = modal_analysis(fin.M, fin.K).frequencies_hz
    assert f_open[0] < 1e-3 * f_open[1]  # the outboard plate folds freely about the hinge line
    assert f_open[1] > 100.0  # ... and that is the only mechanism
    f_closed = modal_analysis(fin.M, fin.closed_stiffness(cfg.kn)).frequencies_hz
    assert f_closed[0] == pytest.approx(50.0, rel=0.03)
    f_rigid = modal_analysis(fin.M, fin.closed_stiffness(1e3 * cfg.kn)).frequencies_hz
    assert f_rigid[0] > 1.3 * f_closed[0]  # the default kn is comparable to the fin's own stiffness
    # modal damping defined on the zero-clearance model at the default kn
    modes = modal_analysis(fin.M, fin.closed_stiffness(cfg.kn))
    c = np.diag(modes.shapes.T @ fin.C @ modes.shapes) / (2 * modes.omega)
    np.testing.assert_allclose(c, cfg.zeta, rtol=1e-6)


def test_save_load_round_trip(fin, tmp_path):
    path = save_system(tmp_path / "fin.npz", fin)
    back = load_system(path)
    assert back.dof_names == fin.dof_names and back.hinge_pairs == fin.hinge_pairs
    for a, b in ((back.M, fin.M), (back.K, fin.K), (back.C, fin.C)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(back.base_influence, fin.base_influence)
    assert back.fingerprint() == fin.fingerprint()


def test_fin_from_config_matches_default(fin, mapping):
    other = fin_from_config(copy.deepcopy(mapping))
    np.testing.assert_allclose(other.K, fin.K, rtol=1e-12, atol=1e-9 * np.abs(fin.K).max())
    np.testing.assert_allclose(other.M, fin.M, rtol=1e-12, atol=1e-12 * np.abs(fin.M).max())


def _f1_closed(cfg, h, width):
    fe = build_fin_fe(cfg.replace(element_size=h, knuckle_width=width))
    K = fe.closed_stiffness(cfg.kn)
    return modal_analysis(fe.M, K, n_modes=1, sparse=True).frequencies_hz[0]


def test_knuckle_hinge_converges_with_the_mesh(cfg):
    f = np.array([_f1_closed(cfg, h, cfg.knuckle_width) for h in (0.02, 0.01, 0.005)])
    d = np.abs(np.diff(f)) / f[1:]
    assert d[1] < 0.5 * d[0] and d[1] < 5e-3
    # a hinge on a single plate node (knuckle narrower than an element) keeps softening: the
    # point-moment rotation of a Kirchhoff plate is log-singular
    g = np.array([_f1_closed(cfg, h, 1e-5) for h in (0.01, 0.005)])
    assert (g[0] - g[1]) / g[1] > 0.01


def test_harmonic_response_matches_full_model(cfg):
    """Base-driven response at 40 Hz (closed hinges, undamped): reduced vs full FE."""
    fe = build_fin_fe(cfg)
    sysr = reduce_fin(fe, influence="load")
    w = 2 * np.pi * 40.0
    y_full = spla.spsolve((fe.closed_stiffness(cfg.kn) - w * w * fe.M).tocsc(), -fe.base_load)
    Kr = sysr.closed_stiffness(cfg.kn)
    y_red = np.linalg.solve(Kr - w * w * sysr.M, -sysr.M @ sysr.base_influence)
    for j, name in enumerate(REDUCED_DOF_NAMES):
        assert y_red[j] == pytest.approx(y_full[fe.dofs[name]], rel=5e-3), name


def test_base_vector_option_makes_influence_rigid(cfg):
    fe = build_fin_fe(cfg)
    s = reduce_fin(fe, base_vector=True)
    assert s.dof_names[-1] == "q_base" and s.n_dof == 13
    np.testing.assert_allclose(s.base_influence[:6], [1, 1, 0, 0, 0, 0], atol=1e-9)
    # modal participation factors of the base load agree with the exact-load 12-DOF model
    s12 = reduce_fin(fe, influence="load")
    gam = []
    for sys_ in (s, s12):
        modes = modal_analysis(sys_.M, sys_.closed_stiffness(cfg.kn))
        gam.append(modes.shapes[:, :3].T @ sys_.M @ sys_.base_influence)
    np.testing.assert_allclose(np.abs(gam[0]), np.abs(gam[1]), rtol=2e-3)


def test_with_parts_rescales_like_a_rebuild(cfg):
    fe = build_fin_fe(cfg)
    changes = {
        "E": 1.05 * cfg.parts["outboard"].E,
        "thickness": 0.9 * cfg.parts["outboard"].thickness,
    }
    fast = fe.with_parts(outboard=changes, inboard={"rho": 2800.0})
    slow = build_fin_fe(cfg.with_part("outboard", **changes).with_part("inboard", rho=2800.0))
    assert abs(fast.K - slow.K).max() <= 1e-10 * abs(slow.K).max()
    assert abs(fast.M - slow.M).max() <= 1e-12 * abs(slow.M).max()
    np.testing.assert_allclose(fast.base_load, slow.base_load, rtol=1e-12, atol=1e-15)


def test_part_matrices_free_free_plate_matches_leissa(cfg):
    """Free-free square outboard plate, nu = 0.3: lambda = omega a^2 sqrt(rho h / D) of the first
    elastic modes, Leissa, J. Sound Vib. 31(3) (1973) (also Code_Aster SDLS01, free plate)."""
    from freeplayid.model.fin.plate import flexural_rigidity

    sq = cfg.replace(outboard_span=0.2, top_left=(0.0, 0.28)).with_part("outboard", nu=0.3)
    M, K = part_matrices(sq, "outboard")
    modes = modal_analysis(M, K, n_modes=6, sparse=True)
    p = sq.parts["outboard"]
    lam = (
        modes.omega
        * 0.2**2
        * np.sqrt(p.rho * p.thickness / flexural_rigidity(p.E, p.thickness, 0.3))
    )
    assert np.all(lam[:3] < 1e-3)  # three rigid-body modes
    np.testing.assert_allclose(lam[3:], [13.49, 19.79, 24.43], rtol=0.02)
    Mc, Kc = part_matrices(cfg, "inboard", clamped=True)
    assert Mc.shape[0] == 3 * 21 * 8  # 21 x 9 nodes, root row removed
    with pytest.raises(ValueError, match="clamped"):
        part_matrices(cfg, "outboard", clamped=True)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda m: m.update(colour="red"), r"unknown key\(s\) \['colour'\].*allowed"),
        (lambda m: m["parts"]["outboard"].update(G=1.0), r"parts.outboard.*unknown.*'G'"),
        (lambda m: m["hinge"].pop("kn"), r"missing key\(s\) \['kn'\]"),
        (lambda m: m["hinge"].update(x=[0.1, 0.05, 0.15]), "hinge.x"),
        (lambda m: m["points"].update(top_left=[0.0, 0.01]), "points.top_left"),
        (lambda m: m.update(kind="npz"), "model.kind"),
        (lambda m: m["parts"]["inboard"].update(thickness=-1), "thickness"),
        (lambda m: m["damping"].update(model="viscous"), "damping.model"),
    ],
)
def test_config_errors(mapping, edit, match):
    bad = copy.deepcopy(mapping)
    edit(bad)
    with pytest.raises(ValueError, match=match):
        fin_from_config(bad)


def test_default_influence_is_rigid_and_close_to_the_exact_load_in_mode_1(cfg):
    fe = build_fin_fe(cfg)
    rigid = reduce_fin(fe)
    exact = reduce_fin(fe, influence="load")
    np.testing.assert_array_equal(rigid.base_influence, [1, 1] + [0] * 10)
    for K in (rigid.closed_stiffness(cfg.kn), rigid.K):
        phi = modal_analysis(rigid.M, K).shapes[:, 0]
        ratio = (phi @ rigid.M @ rigid.base_influence) / (phi @ exact.M @ exact.base_influence)
        assert abs(ratio - 1) < 0.02
    with pytest.raises(ValueError, match="influence"):
        reduce_fin(fe, influence="modal")


def test_part_ratios_reach_each_mode_as_the_complex_eigenvalues_of_part_damping_say(cfg):
    """A ratio per plate (inboard 1 %, outboard 4 %, hinge springs 2 %): each zero-clearance
    mode's ratio by its strain energy (the modal strain energy method) against the reference it
    approximates, the complex eigenvalues of structural damping in each part,
    (K_in (1 + 2i z_in) + K_out (1 + 2i z_out) + kn B B^T (1 + 2i z_h)) phi = lam M phi, whose
    ratios Im(lam) / (2 Re(lam)) agree to first order; the system's C carries those ratios."""
    import scipy.linalg

    from freeplayid.model.fin.fe import fin_reduction, mode_damping

    two = cfg.replace(zeta=0.02, part_zeta={"inboard": 0.01, "outboard": 0.04})
    fe = build_fin_fe(two)
    red = fin_reduction(fe)
    system = reduce_fin(fe)
    B = system.hinge_matrix()
    f, zeta = mode_damping(fe, red, B)
    T = np.asarray(red.T)
    K_in, K_out = (T.T @ (fe.part_stiffness(p) @ T) for p in ("inboard", "outboard"))
    np.testing.assert_allclose(K_in + K_out, red.K_r, rtol=0, atol=1e-9 * abs(red.K_r).max())
    K_h = two.kn * B @ B.T
    lam = scipy.linalg.eigvals(K_in * (1 + 0.02j) + K_out * (1 + 0.08j) + K_h * (1 + 0.04j),
                               red.M_r)
    lam = lam[np.argsort(lam.real)]
    ref = lam.imag / (2 * lam.real)
    np.testing.assert_allclose(np.sqrt(lam.real) / (2 * np.pi), f, rtol=1e-3)
    np.testing.assert_allclose(zeta, ref, rtol=3e-3)  # second order in the ratios: 0.18 %
    assert np.all((zeta > 0.01) & (zeta < 0.04)) and np.ptp(zeta[:4]) > 5e-3  # modes differ
    modes = modal_analysis(system.M, system.closed_stiffness(two.kn))
    w = 2 * np.pi * modes.frequencies_hz
    np.testing.assert_allclose(np.einsum("ij,ik,kj->j", modes.shapes, system.C, modes.shapes)
                               / (2 * w), zeta, rtol=1e-6)
    # the same ratio in every part and the springs: the one-ratio model, exactly
    same = reduce_fin(build_fin_fe(cfg.replace(zeta=0.02, part_zeta={"inboard": 0.02,
                                                                     "outboard": 0.02})))
    one = reduce_fin(build_fin_fe(cfg.replace(zeta=0.02)))
    np.testing.assert_allclose(same.C, one.C, rtol=0, atol=1e-9 * abs(one.C).max())


def test_part_ratios_in_the_config(mapping):
    m = copy.deepcopy(mapping)
    m["damping"]["parts"] = {"outboard": 0.05}
    assert load_fin_config().replace(part_zeta={"outboard": 0.05}).part_zeta == \
        (("outboard", 0.05),)
    fin_from_config(m)  # a part left out gets damping.zeta
    for bad in ({"wing": 0.01}, {"inboard": 1.5}, [0.01]):
        m["damping"]["parts"] = bad
        with pytest.raises(ValueError, match="damping.parts"):
            fin_from_config(m)
    m["damping"].update(parts={"inboard": 0.01}, model="rayleigh")
    with pytest.raises(ValueError, match="needs `damping.model` 'modal'"):
        fin_from_config(m)
