"""Banded operators of ACMP: the second-difference Gram matrix and the two banded solves.

D is the unscaled second difference, shape (N-2, N): (D y)_n = y_n - 2 y_{n+1} + y_{n+2}.
Its Gram matrix P = D^T D is symmetric pentadiagonal with

    diag 0: [1, 5, 6, ..., 6, 5, 1],  diag 1: [-2, -4, ..., -4, -2],  diag 2: [1, ..., 1]

(N >= 4; the short cases are built from the definition). Both ACMP solves are therefore banded
and cost O(N): LAPACK ``pbsv`` (banded Cholesky) through :func:`scipy.linalg.solveh_banded`.
The smoothing's matrix ``P / beta + I`` depends only on (N, beta), which every iteration of an
ACMP call, and every call on a record of the same length, share: its Cholesky factor is kept
(LAPACK ``pbtrf`` once, ``pbtrs`` per solve: the same arithmetic as ``pbsv``, a third of its
time; ``python benchmarks/identify_time.py``).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded, solveh_banded

__all__ = ["second_difference_gram", "demodulate", "smooth_second_difference"]


def second_difference_gram(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Diagonals (0, 1, 2) of P = D^T D, lengths (n, n-1, n-2)."""
    assert n >= 3
    p0 = np.zeros(n)
    p1 = np.zeros(n - 1)
    p2 = np.ones(n - 2)
    # each row (1, -2, 1) at columns (k, k+1, k+2) adds its outer product
    w = (1.0, -2.0, 1.0)
    for a in range(3):
        p0[a : n - 2 + a] += w[a] ** 2
    for a in range(2):
        p1[a : n - 2 + a] += w[a] * w[a + 1]
    return p0, p1, p2


def demodulate(x: np.ndarray, phase: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Regularised quadrature demodulation: the ACMP mode update.

    Minimises ``||D u||^2 + ||D v||^2 + alpha ||x - u cos(phase) - v sin(phase)||^2``, i.e. solves

        (Phi^T Phi / alpha + K^T K) y = K^T x,   K = [diag cos, diag sin],  Phi = blkdiag(D, D).

    With u and v interleaved (y = [u_0, v_0, u_1, v_1, ...]) the matrix is symmetric with 4
    super-diagonals: K^T K couples (u_n, v_n) (offset 1), P couples u_n with u_{n+1}, u_{n+2}
    (offsets 2 and 4). One banded Cholesky solve of 2N unknowns, O(N) time and memory.

    Parameters
    ----------
    x, phase : ndarray, shape (N,) [signal units], [rad]
    alpha : float [-], > 0

    Returns
    -------
    u, v : ndarray, shape (N,) [signal units]
    """
    n = x.shape[0]
    c = np.cos(phase)
    s = np.sin(phase)
    p0, p1, p2 = second_difference_gram(n)
    inv = 1.0 / alpha
    ab = np.zeros((5, 2 * n))  # upper form: ab[4 + i - j, j] = A[i, j]
    ab[4, 0::2] = c * c + inv * p0
    ab[4, 1::2] = s * s + inv * p0
    ab[3, 1::2] = c * s  # A[2k, 2k+1]
    ab[2, 2::2] = inv * p1  # A[2k, 2k+2]
    ab[2, 3::2] = inv * p1
    ab[0, 4::2] = inv * p2  # A[2k, 2k+4]
    ab[0, 5::2] = inv * p2
    rhs = np.empty(2 * n)
    rhs[0::2] = c * x
    rhs[1::2] = s * x
    y = solveh_banded(ab, rhs, overwrite_ab=True, overwrite_b=True, check_finite=False)
    return y[0::2], y[1::2]


def smooth_second_difference(z: np.ndarray, beta: float) -> np.ndarray:
    """Tikhonov low-pass ``(P / beta + I)^{-1} z`` (passes linear trends exactly).

    Parameters
    ----------
    z : ndarray, shape (N,) [any]
    beta : float [-], > 0
    """
    factor = _smoothing_factor(z.shape[0], float(beta))
    return cho_solve_banded((factor, False), z, check_finite=False)


@functools.lru_cache(maxsize=16)
def _smoothing_factor(n: int, beta: float) -> np.ndarray:
    """Upper banded Cholesky factor of ``P / beta + I`` (read-only; 3 x n floats)."""
    p0, p1, p2 = second_difference_gram(n)
    inv = 1.0 / beta
    ab = np.zeros((3, n))
    ab[2] = 1.0 + inv * p0
    ab[1, 1:] = inv * p1
    ab[0, 2:] = inv * p2
    factor = cholesky_banded(ab, overwrite_ab=True, check_finite=False)
    factor.setflags(write=False)
    return factor
