"""Step 1 of the method: the linear fin model from modal tests (the paper's Tables 7 and 8).

:func:`model_from_modal_test` builds the plate FE of a fin configuration, updates chosen per-part
parameters against the measured modes of the three part tests (outboard free-free, inboard
free-free, inboard clamped), reduces the updated fin (:func:`reduce_fin`) and returns one
:class:`ModelBuild`.

Each test is a stand-alone plate of one part, on the same mesh as in the fin
(:func:`part_matrices`). Updating uses log scale factors x_i = ln(p_i / p0_i) and the residual
of every measured mode of every test, stacked::

    r = (f_model,pair(i)(x) - f_meas,i) / f_meas,i

E, rho and thickness only rescale unit matrices: K = D K_1 (+ k_theta S), M = (rho t) M_1 with
D = E t^3 / (12 (1 - nu^2)). Free-free plates have three rigid-body modes (w, two rotations),
which are left out before the pairing. With shapes, modes pair by MAC (recomputed at every
evaluation); without, by order.

Identifiability: a homogeneous plate's frequencies depend on E t^2 / rho only, so E, rho and t of
one part are not separable from frequencies; the Jacobian's condition number says so.

The clamp: ``clamp_stiffness`` k_theta [N m/rad per m of root edge] replaces the rigid clamp of
the ``inboard_clamped`` test by a rotational spring on theta_x (w and theta_y stay fixed), so a
compliant fixture does not bias the inboard plate's parameters; ``clamp.k_theta`` can be updated.
It models the test fixture only: the assembled fin keeps its rigid root.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
import scipy.sparse as sp

from ..fin.config import PARTS, FinConfig
from ..fin.fe import build_fin_fe, part_meshes, reduce_fin
from ..fin.plate import DOFS_PER_NODE, assemble_plate, flexural_rigidity
from ..modal import closed_mode_damping, modal_analysis, pair_modes
from ..system import FreeplaySystem
from .measured import CONFIG_POINTS, MeasuredModes, ModalTest, ModalTestError
from .update import condition_number

__all__ = ["ModelBuild", "TestComparison", "model_from_modal_test", "part_modes",
           "UPDATE_PARAMETERS", "CONDITION_LIMIT", "TEST_TITLES"]

UPDATE_PARAMETERS = tuple(f"{p}.{q}" for p in PARTS for q in ("E", "rho", "thickness")) + (
    "clamp.k_theta",)
# each modal test's name in the report and the figure
TEST_TITLES = {"outboard_free": "Outboard fin, free-free", "inboard_free": "Inboard fin, free-free",
               "inboard_clamped": "Inboard fin, clamped root"}
# the unit of each kind of updated parameter (the report's table)
PARAMETER_UNITS = {"E": "Pa", "rho": "kg/m³", "thickness": "m", "k_theta": "N·m/rad per m"}
TEST_PART = {"outboard_free": ("outboard", False), "inboard_free": ("inboard", False),
             "inboard_clamped": ("inboard", True)}
CONDITION_LIMIT = 1e4  # Jacobian condition number above which parameters are not separable
N_RIGID = 3  # rigid-body modes of a free-free bending plate


@dataclass(frozen=True)
class TestComparison:
    """Measured vs model modes of one test (a Table 7/8 analogue).

    Attributes
    ----------
    test : str
    points : tuple of str
    measured_hz, before_hz, after_hz : ndarray, shape (m,) [Hz]
        Measured, initial model and updated model frequencies of the paired modes.
    mac_before, mac_after : ndarray, shape (m,) or None
    measured_shapes, model_shapes : ndarray, shape (n_points, m) or None
        Measured and updated model w at ``points`` (model scaled to the measured by least squares).
    """

    test: str
    points: tuple
    measured_hz: np.ndarray
    before_hz: np.ndarray
    after_hz: np.ndarray
    mac_before: np.ndarray | None = None
    mac_after: np.ndarray | None = None
    measured_shapes: np.ndarray | None = None
    model_shapes: np.ndarray | None = None

    @property
    def error(self) -> np.ndarray:
        """(after - measured) / measured, shape (m,)."""
        return (self.after_hz - self.measured_hz) / self.measured_hz

    def table(self) -> str:
        """Markdown table: measured, before and after updating, error, MAC."""
        mac = self.mac_after is not None
        rows = ["| mode | measured [Hz] | before [Hz] | error before [%] | after [Hz] | "
                "error after [%] |" + (" MAC before | MAC after |" if mac else ""),
                "|---|---|---|---|---|---|" + ("---|---|" if mac else "")]
        for i, fm in enumerate(self.measured_hz):
            b, a = self.before_hz[i], self.after_hz[i]
            row = (f"| {i + 1} | {fm:.2f} | {b:.2f} | {100 * (b / fm - 1):+.2f} | {a:.2f} | "
                   f"{100 * (a / fm - 1):+.3f} |")
            if mac:
                row += f" {self.mac_before[i]:.4f} | {self.mac_after[i]:.4f} |"
            rows.append(row)
        return "\n".join(rows)


@dataclass(frozen=True)
class ModelBuild:
    """Result of :func:`model_from_modal_test`.

    Attributes
    ----------
    system : FreeplaySystem
        The reduced updated fin (the ``.npz`` contract).
    config, initial_config : FinConfig
        Updated and initial fin configuration.
    parameters : dict str -> (float, float, float)
        Updated parameter -> (initial, updated, updated / initial).
    comparisons : dict str -> TestComparison
        One per measured test.
    condition : float
        Condition number of the scaled Jacobian at the optimum (nan without updating).
    separable : bool
        ``condition`` below :data:`CONDITION_LIMIT`.
    zeta : float
        Modal damping ratio of the reduced model (measured mean, or the configuration's).
    zeta_source : str
        "modal test" or "configuration".
    mode_zeta : tuple of (float, float)
        With measured ratios: (frequency [Hz], damping ratio [-]) of each zero-clearance mode of
        the reduced fin, each part's measured mean ratio weighted by the mode's strain energy in
        that part (:func:`freeplayid.model.fin.fe.mode_damping`; ``config.part_zeta``).
    clamp_stiffness : float or None [N m/rad per m]
    n_evaluations : int
    success : bool
    message : str
    """

    system: FreeplaySystem
    config: FinConfig
    initial_config: FinConfig
    parameters: dict = field(default_factory=dict)
    comparisons: dict = field(default_factory=dict)
    condition: float = float("nan")
    separable: bool = True
    zeta: float = 0.0
    zeta_source: str = "configuration"
    mode_zeta: tuple = ()
    clamp_stiffness: float | None = None
    n_evaluations: int = 0
    success: bool = True
    message: str = "no modal test: no updating"

    @property
    def updated(self) -> bool:
        return bool(self.parameters)

    def warnings(self) -> list[str]:
        """What a user must read: non-separable parameters, a failed or poor update."""
        out = []
        if self.updated and not self.separable:
            out.append(f"the Jacobian's condition number is {self.condition:.3g} (> "
                       f"{CONDITION_LIMIT:.0e}): the parameters {list(self.parameters)} are not "
                       "separately identifiable from these modes (E, rho and thickness of one "
                       "part enter the frequencies only as E t^2 / rho); update fewer of them")
        if self.updated and not self.success:
            out.append(f"the update did not converge: {self.message}")
        worst = max((float(np.max(np.abs(c.error))) for c in self.comparisons.values()),
                    default=0.0)
        if self.updated and worst > 0.02:
            out.append(f"an updated frequency is still {100 * worst:.2f} % off the measured one: "
                       "the parameters updated cannot explain the tests")
        return out

    def metrics(self) -> dict:
        """JSON-ready summary (``metrics.json``)."""
        out = {
            "updated": self.updated, "condition": self.condition, "separable": self.separable,
            "zeta": self.zeta, "zeta_source": self.zeta_source,
            "part_zeta": dict(self.config.part_zeta),
            "mode_zeta": [{"frequency_hz": f, "zeta": z} for f, z in self.mode_zeta],
            "n_evaluations":
            self.n_evaluations, "success": self.success,
            "parameters": {k: {"initial": a, "updated": b, "scale": s}
                           for k, (a, b, s) in self.parameters.items()},
            "n_dof": len(self.system.dof_names), "warnings": self.warnings(),
        }
        for name, c in self.comparisons.items():
            out[name] = {"measured_hz": c.measured_hz.tolist(), "before_hz": c.before_hz.tolist(),
                         "after_hz": c.after_hz.tolist(), "max_abs_error": float(
                             np.max(np.abs(c.error)))}
            if c.mac_after is not None:
                out[name]["mac"] = c.mac_after.tolist()
        return out

    def report(self, figures=()) -> str:
        """``report.md``: the tests (Tables 7/8 analogues), the parameters, the reduced model."""
        lines = ["# Linear fin model from modal tests", ""]
        if not self.updated:
            lines += ["No modal test: the model is the configuration's, not updated.", ""]
        for w in self.warnings():
            lines += [f"**Warning:** {w}", ""]
        notes = {"outboard_free": " (Table 7 analogue)", "inboard_free": " (Table 7 analogue)",
                 "inboard_clamped": " (Table 8 analogue: the fixed-boundary check)"}
        for name, c in self.comparisons.items():
            lines += [f"## {TEST_TITLES[name]}{notes[name]}", "", c.table(), ""]
        if self.updated:
            lines += ["## Updated parameters", "",
                      "| parameter | unit | initial | updated | scale |", "|---|---|---|---|---|"]
            lines += [f"| {k} | {PARAMETER_UNITS.get(k.rsplit('.', 1)[-1], '')} | {a:.6g} | "
                      f"{b:.6g} | {s:.5f} |" for k, (a, b, s) in self.parameters.items()]
            lines += ["", f"Jacobian condition number: {self.condition:.3g} ("
                      + ("separable" if self.separable else "NOT separable") + f"); "
                      f"{self.n_evaluations} model evaluations; {self.message}", ""]
        if self.clamp_stiffness is not None:
            lines += [f"Clamp of the fixed test: rotational spring {self.clamp_stiffness:.4g} "
                      "N·m/rad per m of root edge (test fixture only; the fin's root stays "
                      "rigid).", ""]
        s = self.system
        lines += ["## Reduced model (model.npz)", "",
                  f"- DOFs ({len(s.dof_names)}): {', '.join(s.dof_names)}",
                  f"- hinge pairs: {s.hinge_pairs}",
                  f"- damping: {_damping_line(self)}", ""]
        if figures:
            lines += ["## Figures", ""] + [f"![{f}]({f})" for f in figures]
        return "\n".join(lines) + "\n"


def _mode_zeta(system: FreeplaySystem, kn: float) -> tuple:
    """(frequency [Hz], damping ratio) of each zero-clearance mode at ``kn`` of a system whose
    C is modal in those modes: phi^T C phi / (2 w)."""
    f, z = closed_mode_damping(system, kn)
    return tuple(zip(f.tolist(), z.tolist(), strict=True))


def _damping_line(build: ModelBuild) -> str:
    """The report's damping line: one ratio, or each part's and the modes' they give."""
    where = f"on the zero-clearance model at kn = {build.config.kn:g} N·m/rad"
    if not build.mode_zeta:
        return f"modal, zeta = {build.zeta:.4g} ({build.zeta_source}), {where}"
    parts = ", ".join(f"{p} {z:.4g}" for p, z in build.config.part_zeta)
    modes = ", ".join(f"{f:.1f} Hz {z:.4g}" for f, z in build.mode_zeta[:4])
    return (f"modal, {where}: each mode's ratio is the parts' measured mean ratios ({parts}; "
            f"the hinge springs {build.zeta:.4g}, the mean of all) weighted by its strain "
            f"energy in each: {modes}, …")


# ---------------------------------------------------------------------------- part test models
@dataclass
class _PartTest:
    name: str
    part: str
    K1: sp.csr_matrix  # stiffness at D = 1
    M1: sp.csr_matrix  # mass at rho t = 1
    S: sp.csr_matrix | None  # clamp spring at k_theta = 1 (clamped test with a spring)
    rows: np.ndarray | None  # model DOF index of each measured point's w
    n_rigid: int
    n_modes: int


def _part_test(cfg: FinConfig, name: str, modes, points: dict, source: str, *,
               spring: bool) -> _PartTest:
    part, clamped = TEST_PART[name]
    mesh = part_meshes(cfg)[part]
    nu = cfg.parts[part].nu
    K1, M1 = assemble_plate(mesh, E=12.0 * (1.0 - nu * nu), nu=nu, rho=1.0, thickness=1.0)
    keep = np.arange(mesh.n_dof)
    S = None
    if clamped:
        root = mesh.edge_nodes("bottom")
        fixed = [0, 2] if spring else [0, 1, 2]  # w, theta_y (and theta_x unless a spring)
        keep = np.setdiff1d(keep, (DOFS_PER_NODE * root[:, None] + np.array(fixed)).ravel())
        if spring:  # k_theta per unit length, lumped on the root nodes by tributary length
            xs = np.sort(mesh.nodes[root, 0])
            trib = np.diff(np.r_[xs[0], 0.5 * (xs[1:] + xs[:-1]), xs[-1]])
            order = root[np.argsort(mesh.nodes[root, 0])]
            d = np.zeros(mesh.n_dof)
            d[DOFS_PER_NODE * order + 1] = trib
            S = sp.diags(d).tocsr()[keep][:, keep]
        K1, M1 = K1[keep][:, keep], M1[keep][:, keep]
    pos = np.full(mesh.n_dof, -1)
    pos[keep] = np.arange(keep.size)
    rows = None
    if modes.shapes is not None:
        rows = []
        x0, y0 = mesh.nodes.min(axis=0)
        x1, y1 = mesh.nodes.max(axis=0)
        tol = 0.5 * max(mesh.dx, mesh.dy)
        for p in modes.points:
            if p in points:
                x, y = points[p]
            elif p in CONFIG_POINTS:
                x, y = getattr(cfg, p)
            else:
                raise ModalTestError(f"{source}: `{name}` shape point {p!r} is unknown; known: "
                                     f"{sorted(set(points) | set(CONFIG_POINTS))}")
            if not (x0 - tol <= x <= x1 + tol and y0 - tol <= y <= y1 + tol):
                raise ModalTestError(
                    f"{source}: `{name}` point {p!r} at ({x:g}, {y:g}) m is not on the {part} "
                    f"plate [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}] m (fin coordinates)")
            r = pos[DOFS_PER_NODE * mesh.nearest_node(x, y)]
            if r < 0:
                raise ModalTestError(f"{source}: `{name}` point {p!r} at ({x:g}, {y:g}) m lies "
                                     "on the clamped root edge (w = 0 there)")
            rows.append(r)
        rows = np.asarray(rows)
    n_rigid = 0 if clamped else N_RIGID
    m = modes.n_modes
    n_modes = n_rigid + (2 * m + 4 if rows is not None else m)
    return _PartTest(name, part, K1.tocsr(), M1.tocsr(), S, rows, n_rigid,
                     min(n_modes, K1.shape[0] - 1))


def _solve(t: _PartTest, cfg: FinConfig, k_theta: float | None):
    p = cfg.parts[t.part]
    K = flexural_rigidity(p.E, p.thickness, p.nu) * t.K1
    if t.S is not None:
        K = K + k_theta * t.S
    modes = modal_analysis(p.rho * p.thickness * t.M1, K, n_modes=t.n_modes)
    return modes.frequencies_hz[t.n_rigid:], modes.shapes[:, t.n_rigid:]


def _pair(t: _PartTest, measured, f, phi, source: str, min_mac: float):
    m = measured.n_modes
    if t.rows is None:
        if f.size < m:
            raise ModalTestError(f"{source}: `{t.name}` has {m} modes, the model only {f.size}")
        return np.arange(m), None
    idx, macs = pair_modes(measured.shapes, phi[t.rows, :])
    bad = np.flatnonzero((idx < 0) | (macs < min_mac))
    if bad.size:
        i = int(bad[0])
        raise ModalTestError(
            f"{source}: `{t.name}.modes[{i}]` ({measured.frequencies_hz[i]:g} Hz) pairs with no "
            f"model mode (best MAC {macs[i]:.3f} < {min_mac}); check its shape values and points")
    return idx, macs


def _apply(cfg: FinConfig, names, values, k_theta):
    for n, v in zip(names, values, strict=True):
        part, q = n.split(".")
        if part == "clamp":
            k_theta = float(v)
        else:
            cfg = cfg.with_part(part, **{q: float(v)})
    return cfg, k_theta


def model_from_modal_test(
    config,
    modal_test: ModalTest | None = None,
    *,
    parameters=(),
    clamp_stiffness: float | None = None,
    min_mac: float = 0.8,
    bounds: tuple[float, float] = (0.2, 5.0),
    max_evaluations: int = 200,
) -> ModelBuild:
    """The reduced linear fin, updated against the modal tests when given (the method's step 1).

    Parameters
    ----------
    config : FinConfig or mapping
        The fin (layout of ``freeplayid/model/fin/fin.yaml``).
    modal_test : ModalTest, optional
        Measured modes (:func:`freeplayid.io.read_modal_test`); None: no updating, the model is
        the configuration's (``reduce_fin(build_fin_fe(config))``).
    parameters : sequence of str
        Parameters to update, among :data:`UPDATE_PARAMETERS` (``inboard.E``,
        ``outboard.thickness``, ``clamp.k_theta``, ...).
    clamp_stiffness : float, optional [N m/rad per m of root edge]
        Rotational spring of the clamped test's root (None: rigid clamp); the start of
        ``clamp.k_theta``.
    min_mac : float
        A measured mode whose best MAC is below this is unpaired (an error).
    bounds : (float, float)
        Allowed range of each scale factor p / p0.
    max_evaluations : int
        Limit of model evaluations of the least squares.

    Returns
    -------
    ModelBuild

    Raises
    ------
    ModalTestError
        Unknown parameter, fewer measured modes than parameters, a parameter no test informs,
        an unknown point or one off its part, an unpaired mode.
    """
    cfg0 = config if isinstance(config, FinConfig) else FinConfig.from_mapping(config)
    names = list(parameters)
    _check_parameters(names, clamp_stiffness)
    if modal_test is None:
        if names:
            raise ModalTestError(f"parameters {names} to update need a modal test")
        zeta = cfg0.zeta
        return ModelBuild(system=reduce_fin(build_fin_fe(cfg0)), config=cfg0, initial_config=cfg0,
                          zeta=zeta, clamp_stiffness=clamp_stiffness)
    _check_informed(modal_test, names)
    residual = _TestResidual(cfg0, modal_test, names, clamp_stiffness, min_mac)
    before: dict = {}
    residual(np.zeros(len(names)), before)
    x = np.zeros(0)
    condition, success, message = float("nan"), True, "no parameters to update"
    if names:
        x, success, message, condition = _update(residual, len(names), bounds, max_evaluations)
    after: dict = {}
    residual(x, after)
    cfg, k_theta = _apply(cfg0, names, residual.p0 * np.exp(x), clamp_stiffness)
    zeta_meas = modal_test.mean_damping()
    if zeta_meas is not None:
        # each part's measured mean reaches each mode by its strain energy (reduce_fin); the
        # hinge springs, which no test isolates, at the mean of all
        part_zeta = modal_test.part_damping({t: p for t, (p, _) in TEST_PART.items()})
        cfg = cfg.replace(zeta=zeta_meas, damping_model="modal", part_zeta=part_zeta)
    system = reduce_fin(build_fin_fe(cfg))
    mode_zeta = _mode_zeta(system, cfg.kn) if cfg.part_zeta else ()
    p0 = residual.p0
    updated = {n: (float(a), float(b), float(b / a))
               for n, a, b in zip(names, p0, p0 * np.exp(x), strict=True)}
    return ModelBuild(
        system=system, config=cfg, initial_config=cfg0, parameters=updated,
        comparisons=_comparisons(modal_test, before, after), condition=condition,
        separable=bool(not names or condition < CONDITION_LIMIT),
        zeta=cfg.zeta, zeta_source="modal test" if zeta_meas is not None else "configuration",
        mode_zeta=mode_zeta, clamp_stiffness=k_theta, n_evaluations=residual.n_evaluations,
        success=success, message=message)


def _check_parameters(names: list[str], clamp_stiffness: float | None) -> None:
    """Known parameters, each once; a positive clamp spring, needed to update ``clamp.k_theta``."""
    unknown = [n for n in names if n not in UPDATE_PARAMETERS]
    if unknown or len(set(names)) != len(names):
        raise ModalTestError(f"parameters: {unknown or names} not valid (each once); allowed: "
                             f"{list(UPDATE_PARAMETERS)}")
    if clamp_stiffness is not None and not (np.isfinite(clamp_stiffness) and clamp_stiffness > 0):
        raise ModalTestError(f"clamp_stiffness must be > 0 [N m/rad per m] or None, got "
                             f"{clamp_stiffness!r}")
    if "clamp.k_theta" in names and clamp_stiffness is None:
        raise ModalTestError("parameters: `clamp.k_theta` needs a starting `clamp_stiffness` "
                             "[N m/rad per m of root edge]")


def _check_informed(modal_test: ModalTest, names: list[str]) -> None:
    """At least as many measured modes as parameters, and a test informing each parameter."""
    source = modal_test.source
    if modal_test.n_modes < len(names):
        raise ModalTestError(f"{source}: {modal_test.n_modes} measured mode(s) for {len(names)} "
                             f"parameters to update {names}: need at least as many modes")
    for n in names:
        part = n.split(".")[0]
        informed = [t for t in modal_test.tests if TEST_PART[t][0] == part or (
            part == "clamp" and t == "inboard_clamped")]
        if not informed:
            raise ModalTestError(f"{source}: no test informs parameter `{n}` (tests: "
                                 f"{list(modal_test.tests)})")


class _TestResidual:
    """The relative frequency errors of every measured mode of every test, stacked, at log
    scale factors ``x`` of the parameters; counts its evaluations."""

    def __init__(self, cfg0: FinConfig, modal_test: ModalTest, names: list[str],
                 clamp_stiffness: float | None, min_mac: float):
        self.cfg0, self.modal_test, self.names = cfg0, modal_test, names
        self.clamp_stiffness, self.min_mac = clamp_stiffness, min_mac
        spring = clamp_stiffness is not None
        self.tests = {k: _part_test(cfg0, k, v, modal_test.points, modal_test.source,
                                    spring=spring)
                      for k, v in modal_test.tests.items()}
        self.p0 = np.array([clamp_stiffness if n == "clamp.k_theta" else
                            getattr(cfg0.parts[n.split(".")[0]], n.split(".")[1]) for n in names])
        self.n_evaluations = 0

    def __call__(self, x, keep: dict | None = None) -> np.ndarray:
        """The residual at ``x``; with ``keep``, each test's paired model frequencies, MACs and
        shapes at the measured points go there."""
        cfg, kt = _apply(self.cfg0, self.names, self.p0 * np.exp(x), self.clamp_stiffness)
        self.n_evaluations += 1
        res = []
        for k, t in self.tests.items():
            meas = self.modal_test.tests[k]
            f, phi = _solve(t, cfg, kt)
            idx, macs = _pair(t, meas, f, phi, self.modal_test.source, self.min_mac)
            res.append((f[idx] - meas.frequencies_hz) / meas.frequencies_hz)
            if keep is not None:
                keep[k] = (f[idx], macs, None if t.rows is None else phi[t.rows][:, idx])
        return np.concatenate(res)


def _update(residual: _TestResidual, n: int, bounds: tuple[float, float],
            max_evaluations: int) -> tuple[np.ndarray, bool, str, float]:
    """The least squares over the ``n`` log scale factors: the optimum, success, message and the
    condition number of the scaled Jacobian there."""
    lo, hi = np.log(bounds[0]), np.log(bounds[1])
    sol = scipy.optimize.least_squares(
        residual, np.zeros(n), bounds=(np.full(n, lo), np.full(n, hi)),
        xtol=1e-12, ftol=1e-14, gtol=1e-14, max_nfev=max_evaluations, diff_step=1e-6)
    x = sol.x
    # central differences with a step well above the eigensolver's noise (least_squares'
    # own 1e-6 forward step leaves ~1e-3 noise in a Jacobian column: cond ~1e3 at most)
    h = 1e-3
    jac = np.column_stack([(residual(x + h * e) - residual(x - h * e)) / (2 * h)
                           for e in np.eye(n)])
    return x, bool(sol.success), str(sol.message), condition_number(jac)


def _comparisons(modal_test: ModalTest, before: dict, after: dict) -> dict:
    """One :class:`TestComparison` per test from the kept evaluations at the start and the
    optimum (model shapes scaled onto the measured ones by least squares)."""
    comparisons = {}
    for k, meas in modal_test.tests.items():
        fb, mb, _ = before[k]
        fa, ma, phi = after[k]
        if phi is not None:  # least-squares scale of each model shape onto the measured one
            phi = phi * (np.sum(phi * meas.shapes, 0) / np.sum(phi * phi, 0))
        comparisons[k] = TestComparison(k, meas.points, meas.frequencies_hz, fb, fa, mb, ma,
                                        meas.shapes, phi)
    return comparisons


def part_modes(config, test: str, *, n_modes: int, points=(), coordinates=None,
               clamp_stiffness: float | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Elastic modes of one part test of the fin (what :func:`model_from_modal_test` compares).

    Parameters
    ----------
    config : FinConfig or mapping
    test : str
        One of ``outboard_free``, ``inboard_free``, ``inboard_clamped``.
    n_modes : int
        Elastic modes returned (free-free rigid-body modes left out).
    points : sequence of str
        Points at which the shapes are returned: the configuration's (``top_left``, ...) or keys
        of ``coordinates``.
    coordinates : mapping str -> (float, float) [m], optional
        Fin coordinates of further named points.
    clamp_stiffness : float, optional [N m/rad per m]
        Rotational spring of the clamped test's root (None: rigid).

    Returns
    -------
    frequencies_hz : ndarray, shape (n_modes,) [Hz]
    shapes : ndarray, shape (len(points), n_modes) or None
        Mass-normalised w at ``points`` (None without points).
    """
    if test not in TEST_PART:
        raise ValueError(f"`test` must be one of {list(TEST_PART)}, got {test!r}")
    cfg = config if isinstance(config, FinConfig) else FinConfig.from_mapping(config)
    pts = tuple(points)
    dummy = MeasuredModes(np.ones(n_modes), np.nan, np.ones((len(pts), n_modes)) if pts else None,
                          pts, where=test)
    t = _part_test(cfg, test, dummy, dict(coordinates or {}), "part_modes",
                   spring=clamp_stiffness is not None)
    f, phi = _solve(t, cfg, clamp_stiffness)
    return f[:n_modes], None if t.rows is None else phi[t.rows, :n_modes]
