"""The default folding fin: plate FE with knuckle hinges, and its reduction to a FreeplaySystem.

Structure (docs/model.md), fin in the x-y plane, hinge axis along x (Rx = theta_x is the hinge
rotation), bending only (w, theta_x, theta_y per node; the base excitation is out-of-plane):

- inboard plate [0, c_root] x [0, s_in], clamped on its root edge y = 0 (the shaker base);
- outboard plate [0, c_out] x [s_in, s_in + s_out], a separate mesh whose bottom edge lies on the
  hinge line y = s_in;
- three hinges at x = x_left, x_mid, x_right on the hinge line. Each side of each hinge is a rigid
  knuckle: the plate's hinge-edge nodes with |x - x_k| <= knuckle_width / 2 follow a master point
  at (x_k, s_in) by small-rotation rigid kinematics (on the line y = s_in)::

      w = w_k - (x - x_k) theta_y,k,   theta_x = theta_x,k(side),   theta_y = theta_y,k

  The two sides share w_k and theta_y,k (tied) and keep their own theta_x (not tied). The left and
  middle theta_x pairs carry the freeplay springs; the right pair is a pure hinge.

Why knuckles: a rotational spring on a single plate node is mesh dependent. A point moment on a
Kirchhoff plate has a log-singular rotation, so the plate's own rotational stiffness at one node
goes to zero under refinement. Spreading each hinge over a rigid knuckle of finite width gives a
mesh-converged hinge stiffness (tests/test_fin.py shows it).

Per-part scaling: K = sum_p D_p K_p(nu_p) and M = sum_p (rho t)_p M_p, with K_p and M_p assembled
once for unit D and unit rho t. So changing E, rho or thickness of a part (model updating) only
rescales; changing nu rebuilds.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..damping import modal_damping, rayleigh_damping
from ..modal import modal_analysis
from ..reduce import Reduction, craig_bampton, guyan
from ..system import FreeplaySystem
from .config import HINGES, PARTS, FinConfig, PartProperties, load_fin_config
from .knuckle import knuckle_map
from .plate import DOFS_PER_NODE, assemble_plate, flexural_rigidity, rectangular_mesh

__all__ = [
    "FinFE",
    "build_fin_fe",
    "fin_reduction",
    "reduce_fin",
    "fin_from_config",
    "default_fin",
    "mode_damping",
    "part_matrices",
    "part_meshes",
    "REDUCED_DOF_NAMES",
    "FIN_HINGE_PAIRS",
]

REDUCED_DOF_NAMES = (
    "uz_top_left",
    "uz_lower_right",
    "rx_left_in",
    "rx_left_out",
    "rx_mid_in",
    "rx_mid_out",
)
FIN_HINGE_PAIRS = (("rx_left_out", "rx_left_in"), ("rx_mid_out", "rx_mid_in"))


@dataclass(frozen=True, eq=False)
class FinFE:
    """Full (unreduced) plate FE model of the fin with the base clamped, relative coordinates.

    Attributes
    ----------
    config : FinConfig
    M, K : scipy.sparse.csr_matrix, shape (n, n) [kg, N/m, ... consistent SI]
        Free-DOF mass and stiffness, K without freeplay springs (open hinges: K singular).
    base_load : ndarray, shape (n,) [kg]
        p = M_ff r_f + M_fb 1_b: the relative-coordinate EOM is M y'' + K y = -p a_g exactly.
    dofs : dict str -> int
        Named free DOFs: ``uz_top_left``, ``uz_lower_right`` and ``rx_{left,mid,right}_{in,out}``.
    hinge_matrix : ndarray, shape (n, 2) [-]
        Columns b_j (+1 outboard, -1 inboard theta_x) of the left and middle freeplay springs.
    rigid : ndarray, shape (n,) [-]
        r_f: the free DOFs of a unit rigid translation of the fin with its base (1 at w DOFs).
    meshes : dict str -> PlateMesh
        "inboard" and "outboard".
    """

    config: FinConfig
    M: sp.csr_matrix
    K: sp.csr_matrix
    base_load: np.ndarray
    dofs: dict
    hinge_matrix: np.ndarray
    rigid: np.ndarray
    meshes: dict
    _unit: dict = field(repr=False)  # part -> (K at D = 1, M at rho t = 1, load at rho t = 1)
    _to_plate: sp.csr_matrix = field(repr=False)  # free DOFs -> nodal DOFs of both plates

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    def closed_stiffness(self, kn: float) -> sp.csr_matrix:
        """K + kn B B^T: both freeplay springs engaged with zero clearance [sparse, (n, n)]."""
        B = sp.csr_matrix(self.hinge_matrix)
        return (self.K + float(kn) * (B @ B.T)).tocsr()

    def with_parts(self, **parts) -> FinFE:
        """A copy with changed per-part properties, e.g. ``fe.with_parts(outboard={"E": 7.2e10})``.

        E, rho and thickness only rescale the stored unit matrices (fast, for model updating); a
        change of nu rebuilds the model.
        """
        cfg = self.config
        for part, props in parts.items():
            if isinstance(props, PartProperties):
                props = dataclasses.asdict(props)
            cfg = cfg.with_part(part, **dict(props))
        if any(cfg.parts[p].nu != self.config.parts[p].nu for p in PARTS):
            return build_fin_fe(cfg)
        M, K, load = _combine(self._unit, cfg)
        return FinFE(
            config=cfg,
            M=M,
            K=K,
            base_load=load,
            dofs=self.dofs,
            hinge_matrix=self.hinge_matrix,
            rigid=self.rigid,
            meshes=self.meshes,
            _unit=self._unit,
            _to_plate=self._to_plate,
        )

    def part_stiffness(self, part: str) -> sp.csr_matrix:
        """The stiffness of one plate (``part`` in PARTS) over the free DOFs; ``K`` is their
        sum."""
        props = self.config.parts[part]
        return flexural_rigidity(props.E, props.thickness, props.nu) * self._unit[part][0]

    def plate_displacement(self, x) -> dict:
        """Nodal (w, theta_x, theta_y) of each plate from free DOFs ``x`` of shape (n,).

        Returns
        -------
        dict str -> ndarray, shape (n_nodes_part, 3) [m, rad, rad]
            Relative to the base (the clamped root nodes are zero).
        """
        u = self._to_plate @ np.asarray(x, float)
        n_in = self.meshes["inboard"].n_nodes * DOFS_PER_NODE
        return {
            "inboard": u[:n_in].reshape(-1, DOFS_PER_NODE),
            "outboard": u[n_in:].reshape(-1, DOFS_PER_NODE),
        }


def _combine(unit: dict, cfg: FinConfig):
    M = K = None
    load = 0.0
    for p in PARTS:
        props = cfg.parts[p]
        D = flexural_rigidity(props.E, props.thickness, props.nu)
        mu = props.rho * props.thickness  # mass per area [kg/m^2]
        Ku, Mu, lu = unit[p]
        K = D * Ku if K is None else K + D * Ku
        M = mu * Mu if M is None else M + mu * Mu
        load = load + mu * lu
    return M.tocsr(), K.tocsr(), np.asarray(load)


def part_meshes(cfg: FinConfig) -> dict:
    """The plate mesh of each part, ``{"inboard": PlateMesh, "outboard": PlateMesh}`` (fin
    coordinates [m]; the outboard mesh starts on the hinge line), ceil(side / element_size)
    elements per side."""
    h = cfg.element_size

    def n(length):
        return max(1, int(np.ceil(length / h - 1e-9)))

    return {
        "inboard": rectangular_mesh(
            width=cfg.root_chord,
            height=cfg.inboard_span,
            nx=n(cfg.root_chord),
            ny=n(cfg.inboard_span),
        ),
        "outboard": rectangular_mesh(
            width=cfg.outboard_chord,
            height=cfg.outboard_span,
            nx=n(cfg.outboard_chord),
            ny=n(cfg.outboard_span),
            origin=(0.0, cfg.inboard_span),
        ),
    }


def build_fin_fe(config) -> FinFE:
    """Assemble the full plate FE model of the fin (base clamped, hinges open).

    Parameters
    ----------
    config : FinConfig or mapping
        A mapping is parsed with :meth:`FinConfig.from_mapping`.

    Returns
    -------
    FinFE
    """
    cfg = config if isinstance(config, FinConfig) else FinConfig.from_mapping(config)
    meshes = part_meshes(cfg)
    offset = {"inboard": 0, "outboard": meshes["inboard"].n_dof}

    # ---- constraint map: plate DOFs = Tc @ independent DOFs (knuckles, ties)
    kmap = knuckle_map(meshes, hinge_x=cfg.hinge_x, knuckle_width=cfg.knuckle_width)
    Tc, hinge_dof, slaved, free_nodes = kmap.T, kmap.hinge_dof, kmap.slaved, kmap.free_nodes
    n_own, n_ind = kmap.n_own, Tc.shape[1]

    # ---- base (clamped root) and free partition of the independent DOFs
    root = meshes["inboard"].edge_nodes("bottom")
    base_rows = (DOFS_PER_NODE * root[:, None] + np.arange(DOFS_PER_NODE)).ravel()
    is_base = np.zeros(n_ind, bool)
    is_base[np.flatnonzero(Tc[base_rows].sum(axis=0).A1 != 0)] = True
    free = np.flatnonzero(~is_base)
    # rigid unit translation of the whole fin with the base: w = 1 everywhere, no rotation
    rigid = np.zeros(n_ind)
    rigid[np.arange(0, n_own, DOFS_PER_NODE)] = 1.0
    for k in range(3):
        rigid[hinge_dof[k, "w"]] = 1.0

    unit = {}
    for part in PARTS:
        mesh = meshes[part]
        nu = cfg.parts[part].nu
        # D = E t^3 / (12 (1 - nu^2)) = 1 and rho t = 1
        Kp, Mp = assemble_plate(mesh, E=12.0 * (1.0 - nu * nu), nu=nu, rho=1.0, thickness=1.0)
        sl = slice(offset[part], offset[part] + mesh.n_dof)
        Tp = Tc[sl]
        K_ind = (Tp.T @ Kp @ Tp).tocsr()
        M_ind = (Tp.T @ Mp @ Tp).tocsr()
        assert np.abs(K_ind @ rigid).max() <= 1e-8 * abs(K_ind.diagonal()).max()
        load = (M_ind @ rigid)[free]  # M_ff r_f + M_fb 1_b
        unit[part] = (K_ind[free][:, free].tocsr(), M_ind[free][:, free].tocsr(), load)
    M, K, load = _combine(unit, cfg)

    pos = np.full(n_ind, -1)
    pos[free] = np.arange(free.size)
    out = meshes["outboard"]
    dofs = {}
    for name in ("top_left", "lower_right"):
        node = out.nearest_node(*getattr(cfg, name))
        g = offset["outboard"] // DOFS_PER_NODE + node
        if g in slaved:
            raise ValueError(
                f"`points.{name}` falls on a hinge knuckle; move it off the hinge line"
            )
        dofs["uz_" + name] = int(pos[np.flatnonzero(free_nodes == g)[0] * DOFS_PER_NODE])
    for k, hname in enumerate(HINGES):
        for side in ("in", "out"):
            dofs[f"rx_{hname}_{side}"] = int(pos[hinge_dof[k, "tx_" + side]])
    B = np.zeros((free.size, 2))
    for j, hname in enumerate(HINGES[:2]):
        B[dofs[f"rx_{hname}_out"], j] = 1.0
        B[dofs[f"rx_{hname}_in"], j] = -1.0
    return FinFE(
        config=cfg,
        M=M,
        K=K,
        base_load=load,
        dofs=dofs,
        hinge_matrix=B,
        rigid=rigid[free],
        meshes=meshes,
        _unit=unit,
        _to_plate=(Tc[:, free]).tocsr(),
    )


def fin_reduction(
    fe: FinFE,
    *,
    method: str | None = None,
    n_modes: int | None = None,
    base_vector: bool = False,
    interior: str | None = None,
) -> Reduction:
    """Craig-Bampton (or Guyan) reduction of the fin to the paper's retained DOFs.

    Boundary DOFs, in this order: ``REDUCED_DOF_NAMES`` (Uz of the two measure points, Rx of the
    four spring hinge nodes); then ``n_modes`` interior coordinates (defaults from the config):

    - ``interior="system"`` (default): the interior residuals of the ``n_modes`` lowest
      zero-clearance modes of the assembled fin at the configured kn (after removing their
      constraint-mode part), diagonalised on the interior. Those modes are then exact in the
      basis; with 6 of them the first 6 frequencies stay within 0.05 % (modes 1-5) and 0.7 %
      (mode 6) of the full model for any kn from 0 to 2.35e6 N m/rad.
    - ``interior="fixed_interface"``: classical Craig-Bampton fixed-interface modes; with 6 of
      them modes 4-6 (> 850 Hz) are 0.9-2.6 % off (8 modes: 0.26 %).

    With ``base_vector=True`` one more interior vector is appended: the part of the rigid
    translation r_f that the boundary columns miss, c = r_f - T_tl - T_lr, M-orthogonalised against
    the fixed-interface modes. Then r_f lies exactly in the basis, with coordinates 1 at the two Uz
    DOFs and 0 at the hinge DOFs, so the reduced base influence is (nearly) the rigid one.
    """
    method = fe.config.reduction if method is None else method
    n_modes = fe.config.n_modes if n_modes is None else n_modes
    boundary = np.array([fe.dofs[s] for s in REDUCED_DOF_NAMES])
    interior = fe.config.interior if interior is None else interior
    if method == "craig_bampton" and interior == "system" and n_modes > 0:
        modes = modal_analysis(fe.M, fe.closed_stiffness(fe.config.kn), n_modes=n_modes)
        red = craig_bampton(fe.M, fe.K, boundary, n_modes=n_modes, interior_vectors=modes.shapes)
    elif method == "craig_bampton" and interior in ("system", "fixed_interface"):
        red = craig_bampton(fe.M, fe.K, boundary, n_modes=n_modes)
    elif method == "guyan":
        red = guyan(fe.M, fe.K, boundary)
    else:
        raise ValueError(
            f"`method` must be 'craig_bampton' or 'guyan' and `interior` 'system' or "
            f"'fixed_interface', got {method!r}, {interior!r}"
        )
    if not base_vector:
        return red
    T = np.array(red.T)
    c = fe.rigid - T[:, 0] - T[:, 1]  # zero at every boundary DOF (rigid: 1 at Uz, 0 at Rx)
    Phi = T[:, red.n_boundary :]
    c = c - Phi @ (Phi.T @ (fe.M @ c))  # Phi is M-orthonormal
    c = c / np.sqrt(c @ (fe.M @ c))
    T = np.column_stack([T, c])
    M_r = T.T @ (fe.M @ T)
    K_r = T.T @ (fe.K @ T)
    return Reduction(
        T=T,
        M_r=0.5 * (M_r + M_r.T),
        K_r=0.5 * (K_r + K_r.T),
        boundary=red.boundary,
        fixed_interface_hz=red.fixed_interface_hz,
    )


def reduce_fin(
    fe: FinFE,
    *,
    method: str | None = None,
    n_modes: int | None = None,
    base_vector: bool = False,
    influence: str = "rigid",
    interior: str | None = None,
) -> FreeplaySystem:
    """Reduced fixed-base fin as a :class:`FreeplaySystem` (12 DOFs by default).

    DOFs: ``uz_top_left``, ``uz_lower_right``, ``rx_left_in``, ``rx_left_out``, ``rx_mid_in``,
    ``rx_mid_out``, ``q1`` .. ``q{n_modes}``; hinge pairs (``rx_left_out``, ``rx_left_in``) and
    (``rx_mid_out``, ``rx_mid_in``). K excludes the freeplay springs (singular: the outboard plate
    is a mechanism about the hinge line).

    Damping is defined once, on the zero-clearance model K_r + kn0 B B^T at the configured default
    kn0, so C is a fixed matrix that neither vanishes nor grows with the kn used later: modal
    damping with ratio zeta in every mode of that model, or Rayleigh C = a M_r + b (K_r + kn0 B B^T)
    with ratio zeta at f1 and f2.

    Base influence (``influence``): the contract uses one vector r for the load (-M r a_g) and
    the kinematics (absolute = y'' + r a_g), which a fixed-base Craig-Bampton basis cannot satisfy
    both exactly, because the rigid translation of the free nodes is not in its span.

    - ``"rigid"`` (default): r is the rigid-body vector of the retained DOFs (1 at the Uz DOFs,
      0 at the hinge rotations and modal coordinates). The kinematics are exact; the load
      -M_r r a_g is the load of the constraint-mode shape instead of the rigid translation, which
      changes the first mode's participation factor by +0.9 % closed and +1.6 % open (a level
      change only: the backbone and the output-only method do not depend on it) and misweights
      modes above 250 Hz (docs/model.md).
    - ``"load"``: r = M_r^{-1} T^T p with p = M_ff r_f + M_fb 1_b, the exact relative-coordinate
      load of the FE model; then ``y'' + r a_g`` is not the absolute acceleration (r = 1.65 and
      0.92 at the two Uz DOFs).

    ``base_vector=True`` appends the rigid-translation residual as one more coordinate ``q_base``
    (see :func:`fin_reduction`), so r_f lies in the basis, and uses its exact coordinates as r
    (1 at the Uz DOFs, 0 at the hinge DOFs): the absolute accelerations are then exact, and the
    load -M_r r a_g = -T^T M_ff r_f a_g leaves out only the consistent-mass coupling of the clamped
    root row, T^T M_fb 1_b (0.6 % of the inertial load of the default fin, < 0.03 % of its modal
    participation factors). Off by default (12-DOF contract).
    """
    red = fin_reduction(
        fe, method=method, n_modes=n_modes, base_vector=base_vector, interior=interior
    )
    names = REDUCED_DOF_NAMES + tuple(f"q{i + 1}" for i in range(red.n_modes))
    if base_vector:
        names = names + ("q_base",)
        # r_f is in the basis: its exact coordinates (1 at the Uz DOFs, 0 at the hinge DOFs)
        r = np.linalg.lstsq(red.T, fe.rigid, rcond=None)[0]
        assert np.abs(red.T @ r - fe.rigid).max() < 1e-8
    elif influence == "rigid":
        r = np.array([1.0 if n.startswith("uz_") else 0.0 for n in names])
    elif influence == "load":
        r = np.linalg.solve(red.M_r, red.reduce_load(fe.base_load))
    else:
        raise ValueError(f"`influence` must be 'rigid' or 'load', got {influence!r}")
    B = np.zeros((len(names), 2))
    for j, (out, inn) in enumerate(FIN_HINGE_PAIRS):
        B[names.index(out), j] = 1.0
        B[names.index(inn), j] = -1.0
    cfg = fe.config
    K_closed = red.K_r + cfg.kn * B @ B.T
    if cfg.damping_model == "modal":
        C = modal_damping(red.M_r, K_closed, mode_damping(fe, red, B)[1] if cfg.part_zeta
                          else cfg.zeta)
    else:
        f1, f2 = cfg.rayleigh_hz
        C = rayleigh_damping(red.M_r, K_closed, f1=f1, f2=f2, zeta=cfg.zeta)
    return FreeplaySystem(
        M=red.M_r,
        K=red.K_r,
        C=C,
        dof_names=names,
        hinge_pairs=FIN_HINGE_PAIRS,
        base_influence=r,
    )


def mode_damping(fe: FinFE, red: Reduction, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies [Hz], damping ratios [-]) of the reduced fin's zero-clearance modes (at the
    configuration's kn) from a ratio per part (``config.part_zeta``; a part without one, and
    the hinge springs, at ``config.zeta``), by the modal strain energy method: mode i's ratio
    is its parts' ratios weighted by the shares of its strain energy,

        zeta_i = sum_p zeta_p phi_i^T K_p phi_i / phi_i^T K phi_i,

    K_p the part's plate stiffness reduced with the model's basis (T^T K_p T) and the hinge
    springs' kn B B^T. Exact to first order in the ratios for damping proportional to each
    part's stiffness (structural damping of each plate); tests/test_model_fin.py checks it
    against the complex eigenvalues of that damping."""
    cfg = fe.config
    T = np.asarray(red.T)
    zeta = dict(cfg.part_zeta)
    energy_of = [T.T @ (fe.part_stiffness(p) @ T) for p in PARTS] + [cfg.kn * B @ B.T]
    ratio = [zeta.get(p, cfg.zeta) for p in PARTS] + [cfg.zeta]
    modes = modal_analysis(red.M_r, red.K_r + cfg.kn * B @ B.T)
    phi = modes.shapes
    energy = np.array([np.einsum("ij,ik,kj->j", phi, Kp, phi) for Kp in energy_of])
    return modes.frequencies_hz, (np.array(ratio) @ energy) / energy.sum(axis=0)


def fin_from_config(mapping) -> FreeplaySystem:
    """Reduced fin from a mapping laid out like the default ``fin.yaml`` (e.g. a Hydra cfg as dict).

    Unknown keys raise ``ValueError`` listing the allowed ones.
    """
    return reduce_fin(build_fin_fe(FinConfig.from_mapping(mapping)))


def default_fin() -> FreeplaySystem:
    """The reduced default fin (12 DOFs, base fixed, damped).

    Its configuration is package data, ``freeplayid/model/fin/fin.yaml``
    (:func:`freeplayid.model.fin_config_path`), so it works in any install, not only in a source
    checkout; the scripts' Hydra option ``model=fin`` is the same file.
    """
    return reduce_fin(build_fin_fe(load_fin_config()))


def part_matrices(config, part: str, *, clamped: bool = False):
    """Stand-alone plate model of one part, for modal tests and per-part model updating.

    The paper tests the inboard and outboard fins free-free, and the inboard fin clamped, before
    assembly. This gives the same plate mesh as in the fin without knuckles, hinges or springs.

    Parameters
    ----------
    config : FinConfig or mapping
    part : {"inboard", "outboard"}
    clamped : bool
        Clamp the root edge y = 0 (inboard only); otherwise free-free (3 rigid-body modes).

    Returns
    -------
    M, K : scipy.sparse.csr_matrix, shape (n, n)
        Nodal DOFs (w, theta_x, theta_y) of ``part_meshes(cfg)[part]``, root DOFs removed if
        clamped.
    """
    cfg = config if isinstance(config, FinConfig) else FinConfig.from_mapping(config)
    if part not in PARTS:
        raise ValueError(f"`part` must be one of {list(PARTS)}, got {part!r}")
    if clamped and part != "inboard":
        raise ValueError("`clamped=True` is only defined for the inboard part (its root edge)")
    mesh = part_meshes(cfg)[part]
    p = cfg.parts[part]
    K, M = assemble_plate(mesh, E=p.E, nu=p.nu, rho=p.rho, thickness=p.thickness)
    if clamped:
        root = mesh.edge_nodes("bottom")
        fixed = (DOFS_PER_NODE * root[:, None] + np.arange(DOFS_PER_NODE)).ravel()
        keep = np.setdiff1d(np.arange(mesh.n_dof), fixed)
        M, K = M[keep][:, keep], K[keep][:, keep]
    return M.tocsr(), K.tocsr()
