"""The network's calibration and the domain it was trained on.

Three things a user of the network's posterior needs (:class:`Calibration`, stored in the
checkpoint by :func:`calibrate_checkpoint`, applied by :class:`~.inference.InverseModel`):

- **The domain** (:class:`TrainingDomain`): per channel, the range of the training points'
  frequencies and log amplitudes (their 0.1-99.9 percentiles widened by 5 % of the range), the
  highest noise floor of the training points relative to them (a noisier point is outside; a
  cleaner one is not), the
  number of points of a training case and the prior of kn and delta (the training cases' truth,
  widened by 5 % of its log range).
  A case whose points leave that box, or whose estimate leaves the prior, is outside what the
  network has seen: its estimate is an extrapolation (:meth:`TrainingDomain.outside`). With
  the linear model two more: points that the backbone at the network's estimate misses by more
  than 99.5 % of the training cases' (the estimate does not explain them), and points that no
  (kn, delta) of the prior explains as well as 99.5 % of the training cases (a fin outside the
  prior, whatever the network estimates).
- **The posterior's calibration**: the Gaussian head (trained by its negative log-likelihood)
  gives an estimate and a spread per case. Where the validation cases (never the test cases)
  show it miscalibrated (their SBC ranks reject uniformity), their standardised errors
  z = (log truth - log estimate) / spread are kept and the calibrated posterior is
  estimate * exp(spread * Z) with Z distributed as they were: a recalibration of the predictive
  distribution's quantiles (Kuleshov et al. 2018), which corrects the spread's scale, a shift
  and the tails that one scale factor cannot (:class:`Calibration`). Its 68 % half-width is the
  spread reported (:attr:`Calibration.std_scale`).
- **The checks** as sbi and BayesFlow users read them, on held-out cases: the coverage of the
  central intervals at every level (:func:`coverage_curve`, diagonal = calibrated) and the ranks
  of the truth among posterior draws (simulation-based calibration, :func:`sbc_ranks`; uniform
  for a calibrated posterior, tested by :func:`rank_uniformity`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = ["TrainingDomain", "Calibration", "calibration_metrics", "coverage_curve",
           "fit_std_scale", "sbc_ranks", "rank_uniformity", "design_effect", "prior_misfit",
           "backbone_misfit", "LEVELS"]

LEVELS = np.round(np.arange(0.05, 0.951, 0.05), 2)  # credibility levels of the coverage curve
_Q = 0.001  # [-] the points' range: their 0.1 and 99.9 percentiles ...
_MARGIN = 0.05  # [-] ... widened by this share of the range on each side
PARAMETERS = ("kn", "delta")
MIN_CASES = 30  # validation cases below which the Gaussian head is kept as it is
RECALIBRATE_P = 0.01  # a validation SBC p-value below which a parameter is recalibrated
MISFIT_QUANTILE = 0.995  # training cases' backbone misfit quantile that bounds the domain
MISFIT_CASES = 400  # training cases (at most) the misfit quantile is measured on
PRIOR_GRID = (32, 64)  # kn and delta nodes of the prior's best fit, before its refinement


def _z(truth, mean, std) -> np.ndarray:
    """Standardised errors of the log parameters (N,)."""
    return (np.log(np.asarray(truth, float)) - np.log(np.asarray(mean, float))) / \
        np.asarray(std, float)


def _bounds(levels, z_sorted=None) -> tuple[np.ndarray, np.ndarray]:
    """The standardised bounds (lo, hi) of the central interval of each level: of the standard
    normal, or of the empirical distribution ``z_sorted`` (sorted standardised errors)."""
    lo_p, hi_p = 0.5 - np.asarray(levels) / 2, 0.5 + np.asarray(levels) / 2
    if z_sorted is None:
        return stats.norm.ppf(lo_p), stats.norm.ppf(hi_p)
    return _quantile(z_sorted, lo_p), _quantile(z_sorted, hi_p)


def _quantile(z_sorted, p) -> np.ndarray:
    """The empirical quantile function of ``z_sorted`` (Hazen plotting positions, linear)."""
    z = np.asarray(z_sorted, float)
    pos = (np.arange(z.size) + 0.5) / z.size
    return np.interp(p, pos, z)


def coverage_curve(truth, mean, std, levels=LEVELS, z_sorted=None) -> np.ndarray:
    """Share of cases whose truth lies inside the central interval of each credibility level,
    shape (L,): of the log-normal posterior (median ``mean``, log standard deviation ``std``),
    or with ``z_sorted`` of the posterior mean * exp(std * Z), Z distributed as ``z_sorted``."""
    z = _z(truth, mean, std)
    lo, hi = _bounds(levels, z_sorted)
    return np.array([float(np.mean((z >= a) & (z <= b))) for a, b in zip(lo, hi, strict=True)])


def fit_std_scale(truth, mean, std, levels=LEVELS) -> float:
    """The factor on ``std`` that makes the Gaussian coverage curve of these cases closest to
    the diagonal (smallest largest gap; a log grid 0.1-30 refined once)."""
    def gap(s):
        return float(np.max(np.abs(coverage_curve(truth, mean, s * std, levels) - levels)))

    grid = np.geomspace(0.1, 30.0, 121)
    best = min(grid, key=gap)
    fine = best * np.geomspace(0.95, 1.05, 41)
    return float(min(fine, key=gap))


def sbc_ranks(truth, mean, std, *, n_draws: int = 99, seed: int = 0,
              z_sorted=None) -> np.ndarray:
    """Rank of each case's truth among ``n_draws`` draws of its posterior (log-normal, or
    mean * exp(std * Z) with Z drawn from ``z_sorted``), in [0, n_draws]: uniform for a
    calibrated posterior (Talts et al. 2018)."""
    rng = np.random.default_rng(seed)
    truth, mean, std = (np.asarray(a, float) for a in (truth, mean, std))
    shape = (truth.size, n_draws)
    z = rng.standard_normal(shape) if z_sorted is None else \
        _quantile(z_sorted, rng.uniform(size=shape))
    draws = np.log(mean)[:, None] + std[:, None] * z
    return np.sum(draws < np.log(truth)[:, None], axis=1)


def rank_uniformity(ranks, n_draws: int, *, bins: int = 10, clusters=None) -> dict:
    """Pearson's chi-square test of the ranks' uniformity over ``bins`` equal bins: the
    statistic, its p-value and the bin counts (a p-value below 0.01 rejects uniformity).

    With ``clusters`` (a label per rank: the cases' kn, which a study's cases share 16 at a
    time), also the test for clustered samples: the cases of one kn err alike, so they are not
    independent draws and the plain test rejects too often. The statistic is divided by the
    design effect (Rao and Scott 1981, first order): the mean over the bins of the ratio of the
    bin share's cluster-robust variance to its binomial one, at least 1 (``deff``,
    ``p_value_clustered``; without ``clusters`` these equal 1 and ``p_value``).
    """
    r = np.asarray(ranks)
    counts, edges = np.histogram(r, bins=bins, range=(-0.5, n_draws + 0.5))
    chi2, p = stats.chisquare(counts)
    deff = 1.0 if clusters is None else design_effect(r, edges, clusters)
    return {"chi2": float(chi2), "p_value": float(p), "counts": counts.tolist(),
            "deff": deff, "p_value_clustered": float(stats.chi2.sf(chi2 / deff, bins - 1))}


def design_effect(ranks, edges, clusters) -> float:
    """Mean over the bins (``edges``) of the cluster-robust variance of the share of ``ranks``
    in the bin over its binomial variance, at least 1 (1 with fewer than 2 clusters)."""
    r, cl = np.asarray(ranks), np.asarray(clusters)
    if cl.shape != r.shape:
        raise ValueError(f"`clusters` must have one label per rank ({r.shape}), got {cl.shape}")
    _, idx = np.unique(cl, return_inverse=True)
    n_cl, n = int(idx.max()) + 1 if idx.size else 0, r.size
    if n_cl < 2:
        return 1.0
    b = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, edges.size - 2)
    ratios = []
    for k in range(edges.size - 1):
        y = (b == k).astype(float)
        share = y.mean()
        if not 0 < share < 1:
            continue
        per = np.bincount(idx, weights=y - share, minlength=n_cl)  # each cluster's excess
        robust = n_cl / (n_cl - 1) * float(per @ per) / n ** 2
        ratios.append(robust / (share * (1 - share) / n))
    return max(float(np.mean(ratios)), 1.0) if ratios else 1.0


def backbone_misfit(ps, system, kn, delta, *, mode: int = 0) -> np.ndarray:
    """Per case of ``ps``: the RMS relative frequency residual of its points against the
    DFA backbone of ``system`` at (``kn[c]``, ``delta[c]``), shape (N,)."""
    from ..fit import BackboneModel

    model = BackboneModel(system, ps.channels, mode=mode)
    cidx = np.array([model.channels.index(ps.channels[i]) for i in ps.channel], dtype=int)
    out = np.full(ps.n_cases, np.nan)
    for c in range(ps.n_cases):
        sel = ps.case == c
        if sel.any():
            f = model.frequency(ps.amplitude[sel], cidx[sel], float(kn[c]), float(delta[c]))
            out[c] = float(np.sqrt(np.mean((f / ps.frequency[sel] - 1.0) ** 2)))
    return out


def prior_misfit(ps, system, kn_range, delta_range, *, mode: int = 0) -> np.ndarray:
    """Per case of ``ps``: the RMS relative frequency residual of its points against the DFA
    backbone of ``system`` at the (kn, delta) within ``kn_range`` x ``delta_range`` that explains
    them best, shape (N,): the best node of a log grid of :data:`PRIOR_GRID`, then a bounded
    least-squares step from it. Unlike :func:`backbone_misfit` at the network's estimate it does
    not grow with the network's own errors: on the noise study's training cases its 99.5 %
    quantile is 0.9 %, against 2.0 % at a network's estimates (docs/inverse.md)."""
    from scipy.optimize import least_squares

    from ..fit import BackboneModel

    # curve nodes 7 % apart in kn (the fit's are 1.8 %): a misfit judged at the 1 % level, and
    # a fresh process computes a quarter of the prior's curves (about 1 s on the default fin)
    model = BackboneModel(system, ps.channels, mode=mode, kn_nodes=32)
    cidx = np.array([model.channels.index(ps.channels[i]) for i in ps.channel], dtype=int)
    kns = np.geomspace(*kn_range, PRIOR_GRID[0])
    deltas = np.geomspace(*delta_range, PRIOR_GRID[1])
    bounds = (np.log([kn_range[0], delta_range[0]]), np.log([kn_range[1], delta_range[1]]))
    out = np.full(ps.n_cases, np.nan)
    for c in range(ps.n_cases):
        sel = ps.case == c
        if not sel.any():
            continue
        amp, ch, f = ps.amplitude[sel], cidx[sel], ps.frequency[sel]
        scaled = amp[:, None] / deltas[None, :]  # every delta of the grid at once (delta = 1)
        grid = np.array([np.sqrt(np.mean((model.frequency(scaled, ch, k, 1.0) / f[:, None] - 1)
                                         ** 2, axis=0)) for k in kns])
        i, j = np.unravel_index(int(np.argmin(grid)), grid.shape)

        def residual(p, amp=amp, ch=ch, f=f):
            return model.frequency(amp, ch, float(np.exp(p[0])), float(np.exp(p[1]))) / f - 1

        step = least_squares(residual, np.log([kns[i], deltas[j]]), bounds=bounds,
                             diff_step=1e-4, max_nfev=50)
        out[c] = min(float(grid[i, j]), float(np.sqrt(np.mean(step.fun ** 2))))
    return out


@dataclass(frozen=True)
class TrainingDomain:
    """What the network was trained on (module docstring).

    Attributes
    ----------
    channels : tuple of str
    frequency : tuple of (lo, hi) per channel [Hz]
    log_amplitude : tuple of (lo, hi) per channel [ln m]
    n_points : (int, int)
        Fewest and most points of a training case.
    kn, delta : (lo, hi) [N m/rad], [rad]
        The training cases' truth.
    noise_db_max : float or None [dB]
        The training points' highest noise floor relative to them (``noise_db``: their 99.9
        percentile plus 5 % of the range); None: not recorded (points without it, or a
        checkpoint from before it was).
    misfit_limit : float or None [-]
        The largest relative frequency misfit (RMS) of a case's points against the model's
        backbone at the network's own estimate that :data:`MISFIT_QUANTILE` of the training
        cases stay below (:func:`backbone_misfit`; None: not measured, no model given). A case
        beyond it is one the network's estimate does not explain: seen on the default fin at
        kn 2000 against a prior of 300-800, estimated at 832-853 with a spread of 2 %, inside
        the prior and wrong by 57 %.
    prior_misfit_limit : float or None [-]
        The same quantile of the training cases' misfit at the (kn, delta) within the prior that
        explains their points best (:func:`prior_misfit`; None: not measured). A case beyond it
        is one that no fin of the training prior explains, whatever the network estimates:
        with a network whose own errors raise :attr:`misfit_limit`, the fin at kn 2000 is
        caught by this one (docs/inverse.md).
    """

    channels: tuple
    frequency: tuple
    log_amplitude: tuple
    n_points: tuple
    kn: tuple
    delta: tuple
    misfit_limit: float | None = None
    noise_db_max: float | None = None
    prior_misfit_limit: float | None = None

    @classmethod
    def from_point_sets(cls, ps, *, misfit_limit: float | None = None,
                        prior_misfit_limit: float | None = None) -> TrainingDomain:
        def box(x):
            if x.size == 0:
                return (float("nan"), float("nan"))
            lo, hi = np.quantile(x, [_Q, 1 - _Q])
            pad = _MARGIN * (hi - lo)
            return (float(lo - pad), float(hi + pad))

        def prior(x):  # the truth's range, widened by the margin in log
            lo, hi = np.log(np.nanmin(x)), np.log(np.nanmax(x))
            pad = _MARGIN * (hi - lo)
            return (float(np.exp(lo - pad)), float(np.exp(hi + pad)))

        per = [ps.channel == i for i in range(len(ps.channels))]
        counts = np.bincount(ps.case, minlength=ps.n_cases)
        noise = None if ps.noise_db is None else ps.noise_db[np.isfinite(ps.noise_db)]
        return cls(channels=tuple(ps.channels),
                   frequency=tuple(box(ps.frequency[m]) for m in per),
                   log_amplitude=tuple(box(np.log(ps.amplitude[m])) for m in per),
                   n_points=(int(counts.min()), int(counts.max())),
                   kn=prior(ps.kn), delta=prior(ps.delta), misfit_limit=misfit_limit,
                   noise_db_max=None if noise is None or not noise.size else box(noise)[1],
                   prior_misfit_limit=prior_misfit_limit)

    def to_dict(self) -> dict:
        return {"channels": list(self.channels), "frequency": [list(r) for r in self.frequency],
                "log_amplitude": [list(r) for r in self.log_amplitude],
                "n_points": list(self.n_points), "kn": list(self.kn), "delta": list(self.delta),
                "misfit_limit": self.misfit_limit, "noise_db_max": self.noise_db_max,
                "prior_misfit_limit": self.prior_misfit_limit}

    @classmethod
    def from_dict(cls, d: dict) -> TrainingDomain:
        return cls(channels=tuple(d["channels"]),
                   frequency=tuple(tuple(r) for r in d["frequency"]),
                   log_amplitude=tuple(tuple(r) for r in d["log_amplitude"]),
                   n_points=tuple(d["n_points"]), kn=tuple(d["kn"]), delta=tuple(d["delta"]),
                   misfit_limit=d.get("misfit_limit"), noise_db_max=d.get("noise_db_max"),
                   prior_misfit_limit=d.get("prior_misfit_limit"))

    def outside(self, ps, estimate=None, system=None) -> list[str]:
        """Per case of ``ps``: why it lies outside the domain ('' inside): its points beyond
        the training points' range, a point noisier than any training point (its noise floor
        relative to it, where both are recorded), more points than any training case, an
        estimate outside
        the training prior by more than twice its spread (``estimate``, optional: a dict of
        "kn", "delta", "log_kn_std", "log_delta_std" arrays), or (with ``system``, the linear
        model) points that the backbone at the estimate misses by more than
        :attr:`misfit_limit`, or that the best backbone within the training prior misses by
        more than :attr:`prior_misfit_limit`."""
        misfit = best = None
        if system is not None and estimate is not None and self.misfit_limit is not None:
            misfit = backbone_misfit(ps, system, estimate["kn"], estimate["delta"])
        if system is not None and self.prior_misfit_limit is not None:
            best = prior_misfit(ps, system, self.kn, self.delta)
        out = []
        for c in range(ps.n_cases):
            sel = ps.case == c
            why = self._points(ps, sel)
            if self.noise_db_max is not None and ps.noise_db is not None:
                nz = ps.noise_db[sel]
                nz = nz[np.isfinite(nz)]
                if nz.size and nz.max() > self.noise_db_max:
                    why.append(f"a point's noise floor {nz.max():.3g} dB re the point, above the "
                               f"training points' {self.noise_db_max:.3g} dB (noisier than any "
                               "training record)")
            if sel.sum() > self.n_points[1]:
                why.append(f"{int(sel.sum())} points, training cases had {self.n_points[1]} "
                           "at most")
            for name, (lo, hi), unit in (("kn", self.kn, "N·m/rad"),
                                         ("delta", self.delta, "rad")):
                if estimate is None:
                    continue
                v, s = estimate[name][c], 2 * estimate[f"log_{name}_std"][c]
                if not lo * np.exp(-s) <= v <= hi * np.exp(s):
                    why.append(f"estimated {name} {v:.4g} {unit} outside the training "
                               f"prior [{lo:.4g}, {hi:.4g}] by more than twice its spread")
            if misfit is not None and misfit[c] > self.misfit_limit:
                why.append(f"the backbone at the network's estimate misses the points by "
                           f"{100 * misfit[c]:.2g} % (RMS; {100 * MISFIT_QUANTILE:g} % of the "
                           f"training cases within {100 * self.misfit_limit:.2g} %)")
            if best is not None and best[c] > self.prior_misfit_limit:
                why.append(f"no (kn, delta) of the training prior explains the points: the best "
                           f"misses them by {100 * best[c]:.2g} % (RMS; "
                           f"{100 * MISFIT_QUANTILE:g} % of the training cases within "
                           f"{100 * self.prior_misfit_limit:.2g} %)")
            out.append("; ".join(why))
        return out

    def _points(self, ps, sel) -> list[str]:
        why = []
        for i, ch in enumerate(ps.channels):
            m = sel & (ps.channel == i)
            if not m.any() or ch not in self.channels:
                continue
            j = self.channels.index(ch)
            for label, x, (lo, hi), unit in (
                    ("frequency", ps.frequency[m], self.frequency[j], "Hz"),
                    ("amplitude", ps.amplitude[m], np.exp(self.log_amplitude[j]), "m")):
                if x.max() > hi or x.min() < lo:
                    far = x.max() if x.max() > hi else x.min()
                    why.append(f"{ch} {label} {far:.4g} {unit} outside the training points' "
                               f"[{lo:.4g}, {hi:.4g}]")
        return why


@dataclass(frozen=True)
class Calibration:
    """The checkpoint's calibration record (module docstring).

    Attributes
    ----------
    z : dict of str -> tuple of float or None
        Per parameter ("kn", "delta"): the validation cases' standardised errors of the log
        parameter, (log truth - log estimate) / predicted std, sorted, when they show the
        Gaussian head miscalibrated; the calibrated posterior is then estimate * exp(std * Z)
        with Z distributed as these (a shift and a shape the head missed included). None: the
        head as it is (log-normal).
    domain : TrainingDomain
    n_val : int
        Validation cases.
    val_p_value : dict of str -> float
        Per parameter, the chi-square p-value of the validation cases' SBC ranks under the
        head as it is, for samples clustered by kn where the cases record their kn
        (:func:`rank_uniformity`): below :data:`RECALIBRATE_P` the parameter is recalibrated.
    """

    z: dict
    domain: TrainingDomain
    n_val: int = 0
    val_p_value: dict | None = None

    @property
    def std_scale(self) -> tuple[float, float]:
        """Per parameter, the factor on the predicted std that gives the calibrated posterior's
        68 % half-width (its 16-84 % quantiles' half distance; 1 for the head as it is)."""
        return tuple(1.0 if self.z[p] is None else
                     float(np.diff(_quantile(self.z[p], [0.158655, 0.841345]))[0] / 2)
                     for p in PARAMETERS)

    def shift(self, p: str) -> float:
        """The calibrated posterior's median of Z for parameter ``p`` (0 for the head)."""
        return 0.0 if self.z[p] is None else float(np.median(self.z[p]))

    def describe(self) -> str:
        """One line: what was recalibrated, on how many validation cases, and why."""
        if self.n_val < MIN_CASES:
            return f"not recalibrated: {self.n_val} validation cases are too few"
        pv = self.val_p_value or {}
        return "; ".join(
            f"{p} {'recalibrated' if self.z[p] is not None else 'as the network gives it'} "
            f"(validation SBC p {pv.get(p, float('nan')):.2g} clustered by kn, "
            f"{self.n_val} cases)"
            for p in PARAMETERS)

    def metrics(self, test, raw, *, n_draws: int = 99, seed: int = 0) -> dict:
        """:func:`calibration_metrics` of the calibrated posterior, from the uncalibrated
        predictions ``raw`` (``predict(..., calibrated=False)``) of ``test``."""
        return calibration_metrics(test, raw, n_draws=n_draws, seed=seed, z=self.z)

    def to_dict(self) -> dict:
        return {"z": {p: None if v is None else list(v) for p, v in self.z.items()},
                "domain": self.domain.to_dict(), "n_val": self.n_val,
                "val_p_value": self.val_p_value}

    @classmethod
    def from_dict(cls, d: dict) -> Calibration:
        return cls(z={p: None if d["z"][p] is None else tuple(float(v) for v in d["z"][p])
                      for p in PARAMETERS},
                   domain=TrainingDomain.from_dict(d["domain"]), n_val=int(d.get("n_val", 0)),
                   val_p_value=d.get("val_p_value"))

    @classmethod
    def fit(cls, train, val, raw_val, *, system=None, raw_train=None) -> Calibration:
        """From the training cases (the domain) and the uncalibrated predictions ``raw_val`` of
        the validation cases: a parameter is recalibrated (its standardised errors kept) only
        when its SBC ranks on them reject uniformity (p < :data:`RECALIBRATE_P`) and there are
        :data:`MIN_CASES` of them or more. The validation cases share few kn values (the split
        is by kn), so a recalibration of a head that is calibrated already adds their noise:
        on the noise study's network it widened the test's largest coverage gap from 5.0 / 3.6
        to 6.8 / 6.2 points (kn / delta), and, with the plain chi-square p (the cases of one kn
        taken as independent), from 2.6 to 5.5 points on a network with the noise input. So
        the p-value is the one for samples clustered by kn (``p_value_clustered``)."""
        domain = TrainingDomain.from_point_sets(train)
        if system is not None and train.n_cases:
            pick = np.sort(np.random.default_rng(0).permutation(train.n_cases)[:MISFIT_CASES])
            some = train.subset(pick)
            best = prior_misfit(some, system, domain.kn, domain.delta)
            limits = {"prior_misfit_limit": float(np.nanquantile(best, MISFIT_QUANTILE))}
            if raw_train is not None:
                m = backbone_misfit(some, system, raw_train.kn[pick], raw_train.delta[pick])
                limits["misfit_limit"] = float(np.nanquantile(m, MISFIT_QUANTILE))
            domain = dataclasses.replace(domain, **limits)
        checks = calibration_metrics(val, raw_val) if val.n_cases else None
        z, pv = {}, {}
        for p in PARAMETERS:
            pv[p] = checks[p]["sbc"]["p_value_clustered"] if checks else float("nan")
            bad = val.n_cases >= MIN_CASES and pv[p] < RECALIBRATE_P
            e = _z(getattr(val, p), getattr(raw_val, p), getattr(raw_val, f"log_{p}_std"))
            z[p] = tuple(np.sort(e).tolist()) if bad else None
        return cls(z=z, domain=domain, n_val=int(val.n_cases), val_p_value=pv)


def calibration_metrics(test, pred, *, n_draws: int = 99, seed: int = 0, z=None) -> dict:
    """The coverage curve and the SBC ranks' uniformity of ``pred`` on the held-out ``test``
    cases, per parameter: ``levels``, ``coverage``, ``max_gap`` (the largest coverage gap),
    ``sbc`` (``n_draws``, ranks, chi2, p_value, counts, and with the cases' kn recorded
    (``meta["kn_index"]``) the test for samples clustered by kn: ``deff``,
    ``p_value_clustered``; :func:`rank_uniformity`). ``pred``'s log-normal posterior, or
    with ``z`` (:attr:`Calibration.z`) the calibrated one of the uncalibrated ``pred``."""
    out = {"levels": LEVELS.tolist(), "n_cases": int(test.n_cases)}
    clusters = test.meta.get("kn_index")
    for p in PARAMETERS:
        truth, mean, std = getattr(test, p), getattr(pred, p), getattr(pred, f"log_{p}_std")
        zs = None if z is None else z[p]
        cov = coverage_curve(truth, mean, std, z_sorted=zs)
        ranks = sbc_ranks(truth, mean, std, n_draws=n_draws, seed=seed, z_sorted=zs)
        out[p] = {"coverage": cov.tolist(), "max_gap": float(np.max(np.abs(cov - LEVELS))),
                  "sbc": {"n_draws": n_draws, "ranks": ranks.tolist(),
                          **rank_uniformity(ranks, n_draws, clusters=clusters)}}
    return out
