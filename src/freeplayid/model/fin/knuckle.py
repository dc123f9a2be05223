"""Rigid-knuckle hinges joining the inboard and outboard plate meshes of the fin.

Each of the three hinges k (left, mid, right) at x = x_k on the hinge line has, on each side
(inboard plate's top edge, outboard plate's bottom edge), a rigid knuckle: the edge nodes with
|x - x_k| <= width / 2 follow a master point (x_k, y_hinge) by small-rotation rigid kinematics
along the line y = y_hinge::

    w = w_k - (x - x_k) theta_y,k,   theta_x = theta_x,k(side),   theta_y = theta_y,k

The master DOFs are the independent hinge DOFs, four per hinge: the tied w_k and theta_y,k (shared
by both sides) and the untied hinge rotations theta_x,k(in) and theta_x,k(out). The map is
``u_plates = T @ u_independent`` with the plate DOFs of the inboard mesh first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .plate import DOFS_PER_NODE, PlateMesh

__all__ = ["KnuckleMap", "knuckle_map", "knuckle_nodes"]

HINGE_DOFS = ("w", "ty", "tx_in", "tx_out")


@dataclass(frozen=True)
class KnuckleMap:
    """Plate DOFs from independent DOFs.

    Attributes
    ----------
    T : scipy.sparse.csr_matrix, shape (n_plate_dofs, n_own + 12) [-, m]
    free_nodes : ndarray of int
        Plate nodes (global: inboard then outboard) that keep their own 3 DOFs, in the order of the
        first ``n_own`` independent DOFs.
    n_own : int
        3 * len(free_nodes).
    hinge_dof : dict (k, name) -> int
        Independent DOF of hinge k for name in ("w", "ty", "tx_in", "tx_out").
    slaved : dict int -> (int, str)
        Knuckle node (global) -> (hinge k, side "in"/"out").
    """

    T: sp.csr_matrix
    free_nodes: np.ndarray
    n_own: int
    hinge_dof: dict
    slaved: dict


def knuckle_nodes(mesh: PlateMesh, edge: str, x_k: float, width: float) -> np.ndarray:
    """Nodes of ``edge`` within +-width/2 [m] of x = x_k; the nearest one if none is that close."""
    nodes = mesh.edge_nodes(edge)
    x = mesh.nodes[nodes, 0]
    sel = nodes[np.abs(x - x_k) <= 0.5 * width + 1e-9 * mesh.dx]
    if sel.size == 0:  # knuckle narrower than an element: the nearest node carries the hinge
        sel = nodes[[np.argmin(np.abs(x - x_k))]]
    return sel


def knuckle_map(meshes: dict, *, hinge_x, knuckle_width: float) -> KnuckleMap:
    """Constraint map of the three knuckle hinges between ``meshes["inboard"]`` (top edge) and
    ``meshes["outboard"]`` (bottom edge); ``hinge_x`` [m], ``knuckle_width`` [m]."""
    inboard, outboard = meshes["inboard"], meshes["outboard"]
    node_offset = {"in": 0, "out": inboard.n_nodes}
    slaved = {}
    for k, x_k in enumerate(hinge_x):
        for side, mesh, edge in (("in", inboard, "top"), ("out", outboard, "bottom")):
            for node in knuckle_nodes(mesh, edge, x_k, knuckle_width):
                slaved[node_offset[side] + int(node)] = (k, side)
    n_nodes = inboard.n_nodes + outboard.n_nodes
    is_slave = np.zeros(n_nodes, bool)
    is_slave[list(slaved)] = True
    free_nodes = np.flatnonzero(~is_slave)
    n_own = free_nodes.size * DOFS_PER_NODE
    n_hinges = len(hinge_x)
    hinge_dof = {
        (k, name): n_own + len(HINGE_DOFS) * k + j
        for k in range(n_hinges)
        for j, name in enumerate(HINGE_DOFS)
    }
    rows = [(DOFS_PER_NODE * free_nodes[:, None] + np.arange(DOFS_PER_NODE)).ravel()]
    cols = [np.arange(n_own)]
    vals = [np.ones(n_own)]
    xy = np.vstack([inboard.nodes, outboard.nodes])
    for node, (k, side) in slaved.items():
        dx = xy[node, 0] - hinge_x[k]
        r0 = DOFS_PER_NODE * node
        rows.append(np.array([r0, r0, r0 + 1, r0 + 2]))
        cols.append(
            np.array(
                [
                    hinge_dof[k, "w"],
                    hinge_dof[k, "ty"],
                    hinge_dof[k, "tx_" + side],
                    hinge_dof[k, "ty"],
                ]
            )
        )
        vals.append(np.array([1.0, -dx, 1.0, 1.0]))
    shape = (DOFS_PER_NODE * n_nodes, n_own + len(HINGE_DOFS) * n_hinges)
    T = sp.coo_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape
    ).tocsr()
    return KnuckleMap(T=T, free_nodes=free_nodes, n_own=n_own, hinge_dof=hinge_dof, slaved=slaved)
