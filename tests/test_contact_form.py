"""Damping only in contact as a form of the replay's damping without a base channel
(``freeplayid.replay`` FORM_ALTERNATIVES' qc, its share searched along the measured curves).

A file of its own: one identification of a few minutes, run beside test_replay.py's."""

from __future__ import annotations

import dataclasses
import math

import torch

from freeplayid import identify
from freeplayid.model import default_fin, modal_damping
from freeplayid.replay.damping_estimate import hinge_damper
from freeplayid.simulate import simulate_sweeps, sweep_dataset
from freeplayid.sweep import Sweep


def test_damping_in_contact_is_a_form_the_curves_take_without_a_base_channel():
    """The default fin with 2 % modal damping and a damper across each hinge acting only in
    contact (+1.5 % in closed mode 1: a share 0.43 of its 3.5 %), simulated with
    ``contact_damping``, no base channel. One ratio answers delta +0.8 %; qc = 0.5's replay
    meets the measured curves several times nearer, so the share is searched along them and
    the nearest share taken: within 0.3 % of the truth, at a share within 0.1 of the truth's,
    the report saying what was replayed; the other shares tried are forms between."""
    fin = default_fin()
    truth = fin.replace(C=modal_damping(fin.M, fin.closed_stiffness(480.0), 0.02))
    c = hinge_damper(fin, 0.015, 480.0, 1.0)
    res = simulate_sweeps(truth, kn=480.0, delta=3e-3, level_g=[0.6, 0.9, 1.2, 1.5, 1.8],
                          sweep=Sweep(30.0, 50.0, 0.5),
                          channels=["uz_top_left", "uz_lower_right"], sample_rate=256.0,
                          dtype=torch.float64, progress=False, contact_damping=[c, c])
    ds = sweep_dataset(res, units="g")
    bare = dataclasses.replace(ds, base_channel=None, runs=tuple(
        dataclasses.replace(r, base=None) for r in ds.runs))
    res = identify(bare, system=fin.replace(C=None), progress=False,
                   replay={"precision_copies": 0})
    formed = res.replay.form_sensitivity
    qc = formed.chosen
    assert qc.form == "contact" and qc.converged and not qc.probe
    assert abs(qc.value - 0.43) < 0.1
    assert res.replay.damping.contact == qc.value and res.replay.damping.hinge == 0.0
    one = formed.alternatives[0]
    assert one.form == "ratio" and formed.curve_ratio(one) > 3
    shares = [a for a in formed.alternatives if a.form == "contact"]
    assert len(shares) >= 2 and all(a.probe for a in shares)  # the others tried: between
    for name, move in (("kn", one.kn_move), ("delta", one.delta_move)):
        err = res.truth_error[name]
        assert abs(err) < 3e-3, name
        assert abs(err) < 0.5 * abs(math.expm1(move) + err), name  # one ratio's is farther
    assert res.verdict.status == "ok"
    assert f"a damper across each hinge in contact only (qc = {qc.value:g})" in res.report()
    assert "acting only in contact" in res.replay.damping.describe()
    assert res.to_dict()["replay"]["damping"]["contact"] == qc.value
