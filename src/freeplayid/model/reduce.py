"""Component-mode reduction of large sparse (M, K): Craig-Bampton and Guyan.

Partition the DOFs into boundary (retained physical) DOFs b and interior DOFs i::

    x = T z,   T = [[I, 0], [Psi, Phi]] (rows b then i, reordered to the original order),
    Psi = -K_ii^{-1} K_ib                     (static constraint modes),
    (K_ii - w_k^2 M_ii) Phi_k = 0, k = 1..m   (fixed-interface normal modes, mass-normalised),
    M_r = T^T M T,   K_r = T^T K T.

Guyan is Craig-Bampton with m = 0. Both reproduce exactly any static response to loads applied at
the boundary DOFs (the constraint modes span it), and Craig-Bampton converges to the full dynamic
model as m grows. The interior factorisation is a sparse LU (``splu``) and the fixed-interface
modes come from shift-invert Lanczos (``eigsh`` with sigma = 0, the interior is fixed so K_ii is
positive definite for a properly supported structure).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["Reduction", "craig_bampton", "guyan"]


@dataclass(frozen=True)
class Reduction:
    """A Craig-Bampton (or Guyan) reduction of (M, K).

    Attributes
    ----------
    T : ndarray, shape (n, nb + nm) [-]
        Full DOFs from the reduced coordinates z = [x_b; q]: x = T z.
    M_r, K_r : ndarray, shape (nb + nm, nb + nm)
        Reduced mass and stiffness, T^T M T and T^T K T (symmetrised).
    boundary : ndarray, shape (nb,) of int
        Indices (into the full DOFs) of the retained boundary DOFs, in the order of z.
    fixed_interface_hz : ndarray, shape (nm,) [Hz]
        Frequencies of the fixed-interface modes (boundary clamped), ascending.
    """

    T: np.ndarray
    M_r: np.ndarray
    K_r: np.ndarray
    boundary: np.ndarray
    fixed_interface_hz: np.ndarray

    @property
    def n_boundary(self) -> int:
        return int(self.boundary.size)

    @property
    def n_modes(self) -> int:
        return int(self.fixed_interface_hz.size)

    def reduce_load(self, f) -> np.ndarray:
        """Generalised load T^T f for a full load ``f`` of shape (n,) or (n, k)."""
        return self.T.T @ np.asarray(f, float)

    def expand(self, z) -> np.ndarray:
        """Full DOFs x = T z from reduced coordinates of shape (nb + nm,) or (nb + nm, k)."""
        return self.T @ np.asarray(z, float)


def _as_csc(name: str, a) -> sp.csc_matrix:
    if sp.issparse(a):
        out = sp.csc_matrix(a, dtype=float)
    else:
        arr = np.asarray(a, dtype=float)
        if arr.ndim != 2:
            raise ValueError(f"`{name}` must be a 2-D matrix, got shape {arr.shape}")
        out = sp.csc_matrix(arr)
    if out.shape[0] != out.shape[1]:
        raise ValueError(f"`{name}` must be square, got shape {out.shape}")
    return out


def _check_boundary(boundary, n: int) -> np.ndarray:
    b = np.asarray(boundary)
    if b.ndim != 1 or b.size == 0 or not np.issubdtype(b.dtype, np.integer):
        raise ValueError(
            f"`boundary` must be a non-empty 1-D array of DOF indices, got {boundary!r}"
        )
    if b.min() < 0 or b.max() >= n:
        raise ValueError(
            f"`boundary` indices must lie in [0, {n}), got min {b.min()}, max {b.max()}"
        )
    if np.unique(b).size != b.size:
        raise ValueError("`boundary` contains duplicate DOF indices")
    if b.size >= n:
        raise ValueError("`boundary` must leave at least one interior DOF")
    return b.astype(int)


def craig_bampton(M, K, boundary, *, n_modes: int, interior_vectors=None) -> Reduction:
    """Craig-Bampton reduction to the ``boundary`` DOFs plus ``n_modes`` fixed-interface modes.

    Parameters
    ----------
    M, K : ndarray or scipy.sparse matrix, shape (n, n)
        Symmetric mass (positive definite) and stiffness; K_ii (interior, boundary fixed) must be
        nonsingular.
    boundary : array_like of int, shape (nb,)
        Retained DOF indices; the reduced coordinates start with them in this order.
    n_modes : int, >= 0
        Number of fixed-interface modes kept (0 gives Guyan).
    interior_vectors : ndarray, shape (n, m), optional
        Use these full-space vectors instead of fixed-interface modes (``n_modes`` is then
        ignored): their interior residuals after the constraint-mode part is removed,
        ``x_i - Psi x_b``, are diagonalised on (K_ii, M_ii) inside their span. With the lowest
        modes of the assembled structure this keeps those modes exactly in the basis (a
        system-mode interior basis); ``fixed_interface_hz`` then holds the interior-subspace
        frequencies.

    Returns
    -------
    Reduction
    """
    Ms = _as_csc("M", M)
    Ks = _as_csc("K", K)
    n = Ms.shape[0]
    if Ks.shape != Ms.shape:
        raise ValueError(f"`M` and `K` must have the same shape, got {Ms.shape} and {Ks.shape}")
    b = _check_boundary(boundary, n)
    if int(n_modes) != n_modes or n_modes < 0:
        raise ValueError(f"`n_modes` must be an integer >= 0, got {n_modes!r}")
    n_modes = int(n_modes)
    interior = np.setdiff1d(np.arange(n), b)
    ni = interior.size
    if n_modes > ni:
        raise ValueError(f"`n_modes` = {n_modes} exceeds the {ni} interior DOFs")

    Kii = Ks[interior][:, interior].tocsc()
    lu, Psi = _constraint_modes(Kii, Ks[interior][:, b].toarray())
    Mii = Ms[interior][:, interior].tocsc()
    if interior_vectors is not None:
        X = np.asarray(interior_vectors, dtype=float)
        if X.ndim != 2 or X.shape[0] != n:
            raise ValueError(f"`interior_vectors` must have shape ({n}, m), got {X.shape}")
        Phi, f_fi = _interior_of_vectors(X[interior] - Psi @ X[b], Kii, Mii)
        n_modes = Phi.shape[1]
    elif n_modes > 0:
        Phi, f_fi = _fixed_interface_modes(Kii, Mii, lu, n_modes)
    else:
        Phi = np.zeros((ni, 0))
        f_fi = np.zeros(0)

    nb = b.size
    T = np.zeros((n, nb + n_modes))
    T[b, np.arange(nb)] = 1.0
    T[interior, :nb] = Psi
    T[interior, nb:] = Phi
    M_r = T.T @ (Ms @ T)
    K_r = T.T @ (Ks @ T)
    M_r = 0.5 * (M_r + M_r.T)
    K_r = 0.5 * (K_r + K_r.T)
    for arr in (T, M_r, K_r, b, f_fi):
        arr.setflags(write=False)
    return Reduction(T=T, M_r=M_r, K_r=K_r, boundary=b, fixed_interface_hz=f_fi)


def _constraint_modes(Kii: sp.csc_matrix, Kib: np.ndarray):
    """The LU factors of K_ii and the static constraint modes Psi = -K_ii^-1 K_ib, shape
    (ni, nb); a ValueError if K_ii is singular (the structure not supported by the boundary)."""
    try:
        lu = spla.splu(Kii)
    except RuntimeError as exc:
        raise ValueError(
            "K_ii (interior with the boundary fixed) is singular: the structure must be supported "
            f"once the boundary DOFs are fixed ({exc})"
        ) from None
    piv = np.abs(lu.U.diagonal())
    if piv.min() <= 1e-11 * piv.max():
        raise ValueError(
            "K_ii (interior with the boundary fixed) is singular to working precision: the "
            "structure must be supported once the boundary DOFs are fixed"
        )
    return lu, -lu.solve(Kib)


def _interior_of_vectors(R: np.ndarray, Kii: sp.csc_matrix, Mii: sp.csc_matrix):
    """Interior vectors ``R`` (ni, m) with zero boundary values, diagonalised on (K_ii, M_ii)
    inside their span: (Phi M_ii-orthonormal and K_ii-diagonal, its frequencies [Hz])."""
    lam, V = scipy.linalg.eigh(R.T @ (Kii @ R), R.T @ (Mii @ R))
    Phi = R @ V  # M_ii-orthonormal, K_ii-diagonal
    big = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[big, np.arange(Phi.shape[1])])
    return Phi, np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)


def _fixed_interface_modes(Kii: sp.csc_matrix, Mii: sp.csc_matrix, lu, n_modes: int):
    """The ``n_modes`` lowest fixed-interface modes, M_ii-normalised with their largest component
    positive, and their frequencies [Hz]: dense for small interiors, else shift-invert Lanczos."""
    ni = Kii.shape[0]
    if ni <= 400 or n_modes >= ni - 1:
        lam, Phi = scipy.linalg.eigh(
            Kii.toarray(), Mii.toarray(), subset_by_index=(0, n_modes - 1)
        )
    else:
        op = spla.LinearOperator((ni, ni), matvec=lu.solve, dtype=float)
        v0 = np.ones(ni)  # deterministic start: same basis on every call
        lam, Phi = spla.eigsh(Kii, k=n_modes, M=Mii, sigma=0.0, which="LM", OPinv=op, v0=v0)
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
    Phi = Phi / np.sqrt(np.einsum("im,im->m", Phi, Mii @ Phi))
    # sign convention: largest-magnitude component positive (reproducible reduced matrices)
    big = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[big, np.arange(n_modes)])
    return Phi, np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)


def guyan(M, K, boundary) -> Reduction:
    """Guyan (static) condensation to the ``boundary`` DOFs: Craig-Bampton with no modes."""
    return craig_bampton(M, K, boundary, n_modes=0)
