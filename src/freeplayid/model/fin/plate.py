"""Kirchhoff plate bending: the 12-DOF ACM rectangle, structured meshes and sparse assembly.

Bending only: each node carries the out-of-plane DOFs (w, theta_x, theta_y) with
``theta_x = dw/dy`` and ``theta_y = -dw/dx`` (right-handed rotations about x and y). In-plane
(membrane) DOFs are left out on purpose: the base excitation of the fin is out-of-plane and a flat
plate's bending and membrane problems decouple, so they would only add DOFs.

Element (Adini-Clough-Melosh rectangle, sides a along x and b along y)
----------------------------------------------------------------------
w(x, y) = c^T p(xi, eta) with the 12 monomials::

    p = [1, xi, eta, xi^2, xi eta, eta^2, xi^3, xi^2 eta, xi eta^2, eta^3, xi^3 eta, xi eta^3]

in the local coordinates xi = 2 (x - x_c) / a, eta = 2 (y - y_c) / b in [-1, 1]. The coefficients
follow from the 12 nodal values (nodes counter-clockwise from (-1, -1)): ``u_e = C c``, so the shape
functions are ``N = p^T C^{-1}``. The element is non-conforming (the normal slope jumps across
edges) but passes the patch test and converges; its frequencies converge from above or below
depending on the boundary conditions, so tests check convergence, not bounds.

Energies (D = E t^3 / (12 (1 - nu^2)), curvature kappa = [w_xx, w_yy, 2 w_xy])::

    U = 1/2 int kappa^T D_b kappa dA,   D_b = D [[1, nu, 0], [nu, 1, 0], [0, 0, (1 - nu)/2]]
    T = 1/2 int rho t w_dot^2 dA        (consistent mass; rotary inertia neglected, Kirchhoff)

integrated by 4 x 4 Gauss quadrature, exact for these polynomials (degree <= 6 per direction in
N^T N). Every element of a structured mesh has the same matrices, so they are computed once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = [
    "DOFS_PER_NODE",
    "PlateMesh",
    "rectangular_mesh",
    "acm_element",
    "assemble_plate",
    "flexural_rigidity",
]

DOFS_PER_NODE = 3  # w [m], theta_x = dw/dy [rad], theta_y = -dw/dx [rad]

# monomial exponents (i, j) of xi^i eta^j
_EXP = np.array(
    [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3), (3, 1), (1, 3)]
)
_CORNERS = np.array([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)])


def _mono(xi, eta, dx: int = 0, dy: int = 0) -> np.ndarray:
    """d^dx/dxi^dx d^dy/deta^dy of the 12 monomials at points (xi, eta); shape (npts, 12)."""
    xi = np.atleast_1d(np.asarray(xi, float))[:, None]
    eta = np.atleast_1d(np.asarray(eta, float))[:, None]
    i, j = _EXP[:, 0], _EXP[:, 1]

    def fall(k, d):  # falling factorial k (k-1) ... (k-d+1)
        out = np.ones_like(k, dtype=float)
        for m in range(d):
            out = out * (k - m)
        return out

    ci = fall(i, dx)
    cj = fall(j, dy)
    pi = np.clip(i - dx, 0, None)
    pj = np.clip(j - dy, 0, None)
    return ci * cj * xi**pi * eta**pj


def flexural_rigidity(E: float, thickness: float, nu: float) -> float:
    """Plate flexural rigidity D = E t^3 / (12 (1 - nu^2)) [N m]."""
    return E * thickness**3 / (12.0 * (1.0 - nu * nu))


def _check_positive(**kw) -> None:
    for name, v in kw.items():
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"`{name}` must be a finite number > 0, got {v!r}")


def acm_element(
    a: float, b: float, *, E: float, nu: float, rho: float, thickness: float
) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and consistent mass of one ACM rectangle.

    Parameters
    ----------
    a, b : float [m]
        Side lengths along x and y.
    E : float [Pa]
    nu : float [-], in (-1, 0.5)
    rho : float [kg/m^3]
    thickness : float [m]

    Returns
    -------
    Ke, Me : ndarray, shape (12, 12) [N m/rad-consistent units, kg-consistent units]
        DOF order: node 0 (w, theta_x, theta_y), node 1, node 2, node 3 with the nodes at
        (-a/2, -b/2), (a/2, -b/2), (a/2, b/2), (-a/2, b/2) relative to the element centre.
    """
    _check_positive(a=a, b=b, E=E, rho=rho, thickness=thickness)
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"`nu` must lie in (-1, 0.5), got {nu!r}")
    sx, sy = 2.0 / a, 2.0 / b  # d xi/dx, d eta/dy
    xc, yc = _CORNERS[:, 0], _CORNERS[:, 1]
    C = np.empty((12, 12))
    C[0::3] = _mono(xc, yc)
    C[1::3] = sy * _mono(xc, yc, 0, 1)  # theta_x = dw/dy
    C[2::3] = -sx * _mono(xc, yc, 1, 0)  # theta_y = -dw/dx
    Cinv = np.linalg.inv(C)

    g, wg = np.polynomial.legendre.leggauss(4)
    XI, ETA = np.meshgrid(g, g, indexing="ij")
    W = np.outer(wg, wg).ravel() * (a * b / 4.0)
    xi, eta = XI.ravel(), ETA.ravel()
    N = _mono(xi, eta) @ Cinv  # (16, 12)
    Nxx = sx * sx * _mono(xi, eta, 2, 0) @ Cinv
    Nyy = sy * sy * _mono(xi, eta, 0, 2) @ Cinv
    Nxy = sx * sy * _mono(xi, eta, 1, 1) @ Cinv
    D = flexural_rigidity(E, thickness, nu)
    # kappa^T D_b kappa with kappa = [w_xx, w_yy, 2 w_xy]
    Ke = D * (
        np.einsum("g,gi,gj->ij", W, Nxx, Nxx)
        + np.einsum("g,gi,gj->ij", W, Nyy, Nyy)
        + nu * (np.einsum("g,gi,gj->ij", W, Nxx, Nyy) + np.einsum("g,gi,gj->ij", W, Nyy, Nxx))
        + 2.0 * (1.0 - nu) * np.einsum("g,gi,gj->ij", W, Nxy, Nxy)
    )
    Me = rho * thickness * np.einsum("g,gi,gj->ij", W, N, N)
    return 0.5 * (Ke + Ke.T), 0.5 * (Me + Me.T)


@dataclass(frozen=True)
class PlateMesh:
    """Structured mesh of one rectangle [x0, x0 + width] x [y0, y0 + height].

    Attributes
    ----------
    nodes : ndarray, shape (n_nodes, 2) [m]
        Node coordinates; node ``j * (nx + 1) + i`` sits at (x0 + i dx, y0 + j dy).
    elements : ndarray, shape (n_elements, 4) of int
        Node indices of each element, counter-clockwise from its lower-left corner.
    nx, ny : int
        Elements along x and y.
    dx, dy : float [m]
        Element sides.
    """

    nodes: np.ndarray
    elements: np.ndarray
    nx: int
    ny: int
    dx: float
    dy: float

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_dof(self) -> int:
        return DOFS_PER_NODE * self.n_nodes

    def node_at(self, i: int, j: int) -> int:
        """Index of the node in column i (along x) and row j (along y)."""
        if not (0 <= i <= self.nx and 0 <= j <= self.ny):
            raise ValueError(f"node (i, j) = ({i}, {j}) outside the {self.nx} x {self.ny} mesh")
        return j * (self.nx + 1) + i

    def nearest_node(self, x: float, y: float) -> int:
        """Index of the node closest to the point (x, y) [m]."""
        d2 = (self.nodes[:, 0] - x) ** 2 + (self.nodes[:, 1] - y) ** 2
        return int(np.argmin(d2))

    def edge_nodes(self, edge: str) -> np.ndarray:
        """Node indices on an edge: 'bottom' (y = y0), 'top', 'left' (x = x0) or 'right'."""
        ids = np.arange(self.n_nodes).reshape(self.ny + 1, self.nx + 1)
        edges = {"bottom": ids[0], "top": ids[-1], "left": ids[:, 0], "right": ids[:, -1]}
        if edge not in edges:
            raise ValueError(f"`edge` must be one of {list(edges)}, got {edge!r}")
        return edges[edge].copy()


def rectangular_mesh(
    *, width: float, height: float, nx: int, ny: int, origin: tuple[float, float] = (0.0, 0.0)
) -> PlateMesh:
    """Structured nx x ny mesh of the rectangle of the given size [m] with lower-left ``origin``."""
    _check_positive(width=width, height=height)
    for name, v in (("nx", nx), ("ny", ny)):
        if int(v) != v or v < 1:
            raise ValueError(f"`{name}` must be an integer >= 1, got {v!r}")
    nx, ny = int(nx), int(ny)
    x = origin[0] + np.linspace(0.0, width, nx + 1)
    y = origin[1] + np.linspace(0.0, height, ny + 1)
    X, Y = np.meshgrid(x, y)  # rows = y
    nodes = np.column_stack([X.ravel(), Y.ravel()])
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    n00 = (j * (nx + 1) + i).ravel()
    elements = np.column_stack([n00, n00 + 1, n00 + nx + 2, n00 + nx + 1])
    return PlateMesh(nodes=nodes, elements=elements, nx=nx, ny=ny, dx=width / nx, dy=height / ny)


def assemble_plate(
    mesh: PlateMesh, *, E: float, nu: float, rho: float, thickness: float
) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """Global sparse stiffness and mass of a uniform plate on a structured mesh.

    Parameters
    ----------
    mesh : PlateMesh
    E : float [Pa]
    nu : float [-]
    rho : float [kg/m^3]
    thickness : float [m]

    Returns
    -------
    K, M : scipy.sparse.csr_matrix, shape (3 n_nodes, 3 n_nodes)
        Global DOF ``3 * node + k`` with k = 0 (w [m]), 1 (theta_x [rad]), 2 (theta_y [rad]).
        No boundary conditions applied (K is singular with 3 rigid-body modes).
    """
    if not isinstance(mesh, PlateMesh):
        raise TypeError(f"`mesh` must be a PlateMesh, got {type(mesh).__name__}")
    Ke, Me = acm_element(mesh.dx, mesh.dy, E=E, nu=nu, rho=rho, thickness=thickness)
    edofs = (DOFS_PER_NODE * mesh.elements[:, :, None] + np.arange(DOFS_PER_NODE)).reshape(-1, 12)
    rows = np.repeat(edofs, 12, axis=1).ravel()
    cols = np.tile(edofs, (1, 12)).ravel()
    n_el = edofs.shape[0]
    shape = (mesh.n_dof, mesh.n_dof)
    K = sp.coo_matrix((np.tile(Ke.ravel(), n_el), (rows, cols)), shape=shape).tocsr()
    M = sp.coo_matrix((np.tile(Me.ravel(), n_el), (rows, cols)), shape=shape).tocsr()
    return K, M
