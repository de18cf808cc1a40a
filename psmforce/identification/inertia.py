"""Physically consistent inertial parameters by construction: log-Cholesky parametrisation.

One rigid body's 10 inertial parameters in Pinocchio's order (``Inertia.toDynamicParameters``)::

    pi = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]

kg, kg m, kg m^2; the inertia tensor I is about the BODY FRAME ORIGIN (the joint frame), not the
centre of mass. The body is physically consistent (a non-negative mass distribution exists) iff
its 4x4 pseudo-inertia ``J = [[Sigma, h], [h^T, m]]`` is positive semi-definite, with
``Sigma = tr(I)/2 * 1 - I`` (second moments) and ``h = m c``. We parametrise J = U U^T with U upper
triangular (Rucker and Wensing 2022)::

    U = exp(alpha) * [[exp(d1), s12, s13, t1],
                      [0,       exp(d2), s23, t2],
                      [0,       0,       exp(d3), t3],
                      [0,       0,       0,       1]]

so every real theta = (alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3) gives a positive-definite J,
m = exp(2 alpha) > 0, and the map is a bijection onto positive-definite pseudo-inertias.
"""

from __future__ import annotations

import numpy as np

THETA_NAMES = ("alpha", "d1", "d2", "d3", "s12", "s23", "s13", "t1", "t2", "t3")
PARAMETER_NAMES = ("m", "mc_x", "mc_y", "mc_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")
PARAMETER_UNITS = ("kg", "kg m", "kg m", "kg m") + ("kg m^2",) * 6


def _upper(theta, exp, zeros):
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = [theta[i] for i in range(10)]
    return a, [[exp(d1), s12, s13, t1], [zeros, exp(d2), s23, t2], [zeros, zeros, exp(d3), t3]]


def pseudo_inertia(pi: np.ndarray) -> np.ndarray:
    """4x4 pseudo-inertia of one body from its 10 parameters."""
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = np.asarray(pi, dtype=float)
    inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    J[:3, 3] = J[3, :3] = (hx, hy, hz)
    J[3, 3] = m
    return J


def parameters_from_pseudo_inertia(J) -> list:
    """10 parameters from a pseudo-inertia (numpy or CasADi 4x4)."""
    sxx, syy, szz = J[0, 0], J[1, 1], J[2, 2]
    tr = sxx + syy + szz
    return [J[3, 3], J[0, 3], J[1, 3], J[2, 3],
            tr - sxx, -J[0, 1], tr - syy, -J[0, 2], -J[1, 2], tr - szz]


def theta_to_parameters_casadi(theta):
    """CasADi: log-Cholesky theta (10,) -> the 10 inertial parameters (list of expressions)."""
    import casadi as ca

    alpha, rows = _upper(theta, ca.exp, 0)
    U = ca.vertcat(ca.horzcat(*rows[0]), ca.horzcat(*rows[1]), ca.horzcat(*rows[2]),
                   ca.horzcat(0, 0, 0, 1)) * ca.exp(alpha)
    return parameters_from_pseudo_inertia(U @ U.T)


def theta_to_parameters(theta) -> np.ndarray:
    """numpy: log-Cholesky theta (10,) -> the 10 inertial parameters."""
    alpha, rows = _upper(np.asarray(theta, dtype=float), np.exp, 0.0)
    U = np.array(rows + [[0.0, 0.0, 0.0, 1.0]]) * np.exp(alpha)
    return np.array(parameters_from_pseudo_inertia(U @ U.T), dtype=float)


def parameters_to_theta(pi) -> np.ndarray:
    """Inverse map for a strictly physically consistent body (pseudo-inertia positive definite)."""
    J = pseudo_inertia(pi)
    P = np.eye(4)[::-1]
    try:
        L = np.linalg.cholesky(P @ J @ P)
    except np.linalg.LinAlgError:
        raise ValueError("body parameters are not strictly physically consistent "
                         "(pseudo-inertia not positive definite)") from None
    U = P @ L @ P  # upper triangular with J = U U^T
    scale = U[3, 3]
    V = U / scale
    return np.array([np.log(scale), np.log(V[0, 0]), np.log(V[1, 1]), np.log(V[2, 2]),
                     V[0, 1], V[1, 2], V[0, 2], V[0, 3], V[1, 3], V[2, 3]])


def consistency_report(pi) -> dict:
    """Mass, centre of mass and the smallest eigenvalue of the pseudo-inertia of one body."""
    pi = np.asarray(pi, dtype=float)
    eig = np.linalg.eigvalsh(pseudo_inertia(pi))
    return {"mass_kg": float(pi[0]),
            "com_m": (pi[1:4] / pi[0]).tolist() if pi[0] > 0 else None,
            "pseudo_inertia_min_eigenvalue": float(eig[0]),
            "physically_consistent": bool(pi[0] > 0 and eig[0] > 0)}
