"""Modal analysis and the modal assurance criterion (MAC)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["Modes", "modal_analysis", "mac", "pair_modes", "closed_mode_damping"]


@dataclass(frozen=True)
class Modes:
    """Undamped normal modes.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (m,) [Hz]
        Natural frequencies in ascending order (0 for rigid-body/mechanism modes).
    shapes : ndarray, shape (n, m) [-]
        Mass-normalised mode shapes as columns (phi^T M phi = I).
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        """Angular frequencies [rad/s], shape (m,)."""
        return 2 * np.pi * self.frequencies_hz


def modal_analysis(M, K, *, n_modes: int | None = None, sparse: bool | None = None) -> Modes:
    """Natural frequencies and mass-normalised mode shapes of (K, M).

    Parameters
    ----------
    M, K : ndarray or scipy.sparse matrix, shape (n, n)
    n_modes : int, optional
        Number of lowest modes (all if None).
    sparse : bool, optional
        Use the shift-invert Lanczos solver (default: when M, K are sparse and n_modes is small).
    """
    n = M.shape[0]
    if n_modes is not None and not (1 <= n_modes <= n):
        raise ValueError(f"`n_modes` must be in [1, {n}], got {n_modes!r}")
    if sparse is None:
        sparse = sp.issparse(K) and n_modes is not None and n_modes < n // 4
    if sparse:
        # shift slightly below zero so a mechanism (singular K) does not break the factorisation
        Ks, Ms = sp.csc_matrix(K), sp.csc_matrix(M)
        scale = abs(Ks.diagonal()).max() / abs(Ms.diagonal()).max()
        # a fixed start vector makes repeated calls bit-identical (reproducible reduced models)
        v0 = np.ones(n)
        lam, phi = spla.eigsh(Ks, k=n_modes, M=Ms, sigma=-1e-6 * scale, which="LM", v0=v0)
        order = np.argsort(lam)
        lam, phi = lam[order], phi[:, order]
        # mass-normalise (eigsh returns M-orthonormal vectors, but be explicit)
        phi = phi / np.sqrt(np.einsum("im,im->m", phi, Ms @ phi))
    else:
        Md = M.toarray() if sp.issparse(M) else np.asarray(M, float)
        Kd = K.toarray() if sp.issparse(K) else np.asarray(K, float)
        sub = None if n_modes is None else (0, n_modes - 1)
        lam, phi = scipy.linalg.eigh(Kd, Md, subset_by_index=sub)
    # sign convention: largest-magnitude component positive, so shapes compare across models
    idx = np.argmax(np.abs(phi), axis=0)
    phi = phi * np.sign(phi[idx, np.arange(phi.shape[1])])
    f = np.sqrt(np.clip(lam, 0.0, None)) / (2 * np.pi)
    return Modes(frequencies_hz=f, shapes=phi)


def mac(phi_a, phi_b) -> np.ndarray:
    """Modal assurance criterion between two mode sets.

    MAC_ij = |phi_a,i^H phi_b,j|^2 / ((phi_a,i^H phi_a,i)(phi_b,j^H phi_b,j))

    Parameters
    ----------
    phi_a : ndarray, shape (n, ma)
    phi_b : ndarray, shape (n, mb)
        Same DOFs (rows) in the same order.

    Returns
    -------
    ndarray, shape (ma, mb), values in [0, 1]
    """
    a = np.asarray(phi_a)
    b = np.asarray(phi_b)
    if a.ndim == 1:
        a = a[:, None]
    if b.ndim == 1:
        b = b[:, None]
    if a.shape[0] != b.shape[0]:
        raise ValueError(
            f"mode sets must share their DOFs (rows), got {a.shape[0]} and {b.shape[0]} rows"
        )
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    return num / den


# MACs this close to a reference mode's best are a tie that the shapes cannot break: with two
# measured DOFs a shape is one ratio, and modes far apart in frequency match it to 1e-6
MAC_TIE = 0.01


def pair_modes(phi_ref, phi, *, min_mac: float = 0.0,
               frequencies: tuple | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Pair each reference mode with the model mode of highest MAC (one-to-one, greedy).

    With ``frequencies`` (reference and model frequencies [Hz]), a reference mode whose MACs tie
    (within :data:`MAC_TIE` of its best) is paired with the nearest in frequency of the tied
    modes: the shapes at a few DOFs cannot tell them apart (the sealed fin's mode 2 at 218 Hz,
    read at two accelerometers, matched the model's mode 9 at 4.0 kHz to MAC 0.99999995 and its
    mode 2 at 223 Hz to 0.9999973).

    Returns
    -------
    index : ndarray, shape (m_ref,) of int
        Model mode paired with each reference mode (-1 if none reaches ``min_mac``).
    mac_value : ndarray, shape (m_ref,)
    """
    m = mac(phi_ref, phi)
    index = np.full(m.shape[0], -1)
    value = np.zeros(m.shape[0])
    work = m.copy()
    if frequencies is not None:
        f_ref, f = (np.asarray(v, float).reshape(-1) for v in frequencies)
        # the greedy order by MAC, each reference mode's ties by frequency distance
        distance = np.abs(np.log(np.maximum(f[None, :], 1e-12) / np.maximum(f_ref[:, None],
                                                                         1e-12)))
    for _ in range(min(m.shape)):
        i, j = np.unravel_index(np.argmax(work), work.shape)
        if work[i, j] < min_mac or work[i, j] < 0:
            break
        if frequencies is not None:
            tied = np.flatnonzero(work[i] >= work[i, j] - MAC_TIE)
            j = int(tied[np.argmin(distance[i, tied])])
        index[i], value[i] = j, m[i, j]
        work[i, :] = -1
        work[:, j] = -1
    return index, value


def closed_mode_damping(system, kn: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequency [Hz], damping ratio) of each zero-clearance mode of ``system`` at ``kn``:
    ``phi^T C phi / (2 w)`` with mass-normalised shapes (exact where C is modal in those modes,
    their diagonal part otherwise)."""
    modes = modal_analysis(system.M, system.closed_stiffness(kn))
    w = 2 * np.pi * modes.frequencies_hz
    zeta = np.einsum("ij,ik,kj->j", modes.shapes, np.asarray(system.C), modes.shapes) / (2 * w)
    return modes.frequencies_hz, zeta
