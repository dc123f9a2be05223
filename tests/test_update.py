import numpy as np
import pytest

from freeplayid.model import modal_analysis
from freeplayid.model.from_test.update import mode_table, update_model


def _chain(params):
    """Two-part spring-mass chain: part A (springs 0-3) and part B (springs 4-7).

    ``E_a``/``E_b`` scale the springs of each part, ``rho_b`` the masses of part B.
    """
    n = 8
    k = np.r_[np.full(4, params["E_a"]), np.full(4, params["E_b"])] * 1e4
    m = np.r_[np.full(4, 1.0), np.full(4, params.get("rho_b", 1.0))]
    K = np.zeros((n, n))
    for i in range(n):  # spring i connects node i-1 (ground for i=0) to node i
        K[i, i] += k[i]
        if i > 0:
            K[i - 1, i - 1] += k[i]
            K[i - 1, i] -= k[i]
            K[i, i - 1] -= k[i]
    return np.diag(m), K


def test_update_recovers_young_modulus_perturbation():
    truth = {"E_a": 1.05, "E_b": 0.97}
    M, K = _chain(truth)
    ref = modal_analysis(M, K, n_modes=5)
    res = update_model(_chain, {"E_a": 1.0, "E_b": 1.0}, ref.frequencies_hz)
    assert res.success
    for key, val in truth.items():
        assert res.parameters[key] == pytest.approx(val, rel=5e-3)
    assert np.max(np.abs(res.relative_error)) < 1e-8
    assert "measured [Hz]" in mode_table(res)


def test_update_pairs_by_mac_when_shapes_given():
    truth = {"E_a": 1.0, "E_b": 1.05}
    M, K = _chain(truth)
    ref = modal_analysis(M, K, n_modes=4)
    dofs = [1, 3, 5, 7]
    # give the measured modes out of order: MAC pairing must sort them out
    order = [2, 0, 3, 1]
    res = update_model(
        _chain,
        {"E_a": 1.0, "E_b": 1.0},
        ref.frequencies_hz[order],
        measured_shapes=ref.shapes[dofs][:, order],
        shape_dofs=dofs,
    )
    np.testing.assert_array_equal(res.pairing, order)
    assert np.all(res.mac > 0.999)
    assert res.parameters["E_b"] == pytest.approx(1.05, rel=5e-3)


def test_update_warns_when_parameters_are_not_separable():
    def build(p):  # E and rho of one part enter only as their ratio
        M, K = _chain({"E_a": p["E"], "E_b": p["E"]})
        return M * p["rho"], K

    M, K = build({"E": 1.0, "rho": 1.0})
    f = modal_analysis(M, K, n_modes=4).frequencies_hz
    with pytest.warns(UserWarning, match="not separately identifiable"):
        update_model(build, {"E": 1.1, "rho": 1.0}, f)


def test_update_input_errors():
    with pytest.raises(ValueError, match="initial"):
        update_model(_chain, {"E_a": -1.0}, [1.0])
    with pytest.raises(ValueError, match="measured_hz"):
        update_model(_chain, {"E_a": 1.0}, [])
    with pytest.raises(ValueError, match="shape_dofs"):
        update_model(_chain, {"E_a": 1.0}, [1.0], measured_shapes=np.ones((2, 1)))


def test_update_recovers_fin_young_modulus_from_full_fe():
    """Paper step 1 on the default fin: a 5 % stiffer outboard plate is found from 5 frequencies."""
    from freeplayid.model import build_fin_fe, default_fin_parameters, load_fin_config

    fe = build_fin_fe(load_fin_config())
    kn = default_fin_parameters()["kn"]
    E0 = {p: fe.config.parts[p].E for p in ("inboard", "outboard")}

    def build(params):
        f = fe.with_parts(
            inboard={"E": E0["inboard"] * params["E_in"]},
            outboard={"E": E0["outboard"] * params["E_out"]},
        )
        return f.M, f.closed_stiffness(kn)

    M, K = build({"E_in": 1.0, "E_out": 1.05})
    measured = modal_analysis(M, K, n_modes=5).frequencies_hz
    res = update_model(build, {"E_in": 1.0, "E_out": 1.0}, measured, n_modes=5)
    assert res.success
    assert res.parameters["E_out"] == pytest.approx(1.05, rel=5e-3)
    assert res.parameters["E_in"] == pytest.approx(1.0, rel=5e-3)


def test_a_refit_to_the_updated_model_that_runs_off_is_refused_with_its_cause(monkeypatch):
    """The plain estimate refitted against the model updated to the sealed modes is held to the
    plain fit's rule (:func:`freeplayid.estimate.check_determined`): a refit that ran off to a
    rigid hinge is an IdentificationError naming the update, not a model the frequency scale
    then divides by zero on."""
    import math
    from types import SimpleNamespace

    import freeplayid.identification.model_error as me
    from freeplayid.errors import IdentificationError
    from freeplayid.fit import FitOptions
    from freeplayid.model import ModelOptions, two_dof_system

    system = two_dof_system()
    est = SimpleNamespace(kn=2.0e4, delta=1e-3, points=None)
    monkeypatch.setattr(me, "update_to_sealed_modes",
                        lambda *a, **k: SimpleNamespace(system=system))
    monkeypatch.setattr(me, "refit", lambda e, *a, **k: SimpleNamespace(
        kn=math.inf, delta=e.delta, points=None))
    ds = SimpleNamespace(path="here", name="x", reference_modes={
        "frequencies_hz": [1.0], "shapes": [[1.0]], "dofs": ["uz_out"]})
    with pytest.raises(IdentificationError, match=r"here \(the model updated to its sealed "
                       r"modes\): the fit ran off to kn = inf"):
        me.update_model(ds, system, est, FitOptions(), ModelOptions())
    # a refit that lands is passed on as it is
    monkeypatch.setattr(me, "refit", lambda e, *a, **k: SimpleNamespace(
        kn=2.1e4, delta=e.delta, points=None))
    got = me.update_model(ds, system, est, FitOptions(), ModelOptions())
    assert got[1].kn == 2.1e4
