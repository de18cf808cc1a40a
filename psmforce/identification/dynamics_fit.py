"""The arm dynamics fit: signal conditioning, input checks and the constrained least squares.

* Physical consistency by construction: each body's 10 parameters come from a log-Cholesky
  parametrisation (``inertia.py``); Coulomb, viscous, Stribeck and armature >= 0; optionally the
  instrument bodies' mass inside :data:`BOUNDING_ELLIPSOIDS`.
* Solver: CasADi IPOPT on the weighted least-squares cost (weights 1/RMS of each coordinate's
  torque, so that every joint counts), with a weak pull of the inertial parameters towards the
  URDF prior only to fix directions the data cannot see; warm start from OLS.

Signal conditioning: see ``signals.py``; defaults are the published protocol (5.4 Hz zero-phase
Butterworth on q, dq, tau; accelerations from the filtered velocity; 200-sample trim).
The model itself: :mod:`.dynamics`.
"""

from __future__ import annotations

import time

import numpy as np

from psmforce.robot.conventions import GRAVITY_MPS2, JOINTS
from psmforce.identification.dynamics import ArmDynamicsModel
from psmforce.identification.dynamics_options import N_COORD, DynamicsFitOptions
from psmforce.identification.dynamics_regressor import (BODIES, hysteresis_states,
                                                         identification_model, linear_columns,
                                                         linear_terms, rigid_regressors)
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.inertia import (PARAMETER_NAMES, parameters_to_theta,
                                              theta_to_parameters, theta_to_parameters_casadi)
from psmforce.identification.signals import check_finite_2d, derivative, zero_phase_lowpass

_MIN_EXTENT_M = 1e-3
"""Lower bound on exp(d_i) of the log-Cholesky factor: keeps pseudo-inertias strictly positive definite."""
_MAX_SIZE_M = 2.0
"""Bound on the log-Cholesky extents, shape terms and centre of mass of every body (m)."""

BOUNDING_ELLIPSOIDS = {
    # instrument bodies only: (centre (m), semi-axes (m) along x, y, z of the body's joint frame).
    # Roll body: the 8 mm shaft and the roll disc, so at most 12 mm off the shaft axis; along the
    # shaft it is left free (3 m): an axisymmetric mass moving with insertion acts identically on
    # the roll body and on the insertion body, so only the lateral extent is the roll body's own.
    # Wrist bodies: the clevis and the jaws (< 20 mm). The arm bodies get none: by the lumping
    # argument (``dynamics_regressor`` module docstring) the yaw and pitch bodies are equivalent
    # bodies of the whole parallelogram, not physical links, so only their positive-definiteness
    # is meaningful.
    "roll": ((0.0, 0.0, -0.22), (0.012, 0.012, 3.0)),
    "wrist_pitch": ((0.0, 0.0, 0.0), (0.01, 0.01, 0.01)),
    "wrist_yaw": ((0.0, 0.0, 0.0), (0.02, 0.02, 0.02)),
}


# ------------------------------------------------------------------ conditioning
def condition_signals(c, dc, tau_c, sample_rate_hz: float, opts: DynamicsFitOptions, *,
                      with_states: bool = False):
    """Filter c, dc, tau (zero phase), differentiate dc, trim both ends: (c, dc, ddc, tau), and
    with ``with_states`` the hysteresis states (N,7,4) of the kept rows, integrated along the
    whole filtered recording (so the trimmed start has settled them)."""
    filt = [zero_phase_lowpass(x, sample_rate_hz, opts.cutoff_hz, order=opts.filter_order)
            for x in (c, dc, tau_c)]
    ddc = derivative(filt[1], sample_rate_hz)
    sl = slice(opts.trim, len(c) - opts.trim)
    out = (filt[0][sl], filt[1][sl], ddc[sl], filt[2][sl])
    return out + (hysteresis_states(filt[0])[sl],) if with_states else out


def check_fit_inputs(c, dc, tau, opts, name):
    """c, dc, tau as (N, 7) float arrays if finite, of one shape and long enough for ``opts``;
    else IdentificationInputError naming ``name``."""
    n_rows = np.asarray(c).shape[0] if np.ndim(c) else 0
    c = check_finite_2d(c, f"{name} positions", width=N_COORD)
    dc = check_finite_2d(dc, f"{name} velocities", width=N_COORD)
    tau = check_finite_2d(tau, f"{name} efforts", width=N_COORD)
    if not (c.shape == dc.shape == tau.shape):
        raise IdentificationInputError(
            f"{name}: positions, velocities and efforts must have the same shape; got "
            f"{c.shape}, {dc.shape}, {tau.shape}")
    if n_rows < opts.min_samples + 2 * opts.trim:
        raise IdentificationInputError(
            f"{name}: {n_rows} samples is too short; the fit needs at least "
            f"{opts.min_samples + 2 * opts.trim} ({opts.min_samples} after trimming {opts.trim} "
            "at each end)")
    return c, dc, tau


def check_excitation(dc, coord_names, name):
    """IdentificationInputError naming ``name`` and the coordinates whose velocity dc (N, 7)
    hardly changes."""
    span = dc.max(axis=0) - dc.min(axis=0)
    still = [f"{coord_names[k]} (velocity range {span[k]:.2g})" for k in range(N_COORD)
             if span[k] < 1e-3]
    if still:
        raise IdentificationInputError(
            f"{name}: the trajectory does not excite {', '.join(still)}; a constant or nearly "
            "constant coordinate makes its friction and inertial parameters unidentifiable")



def coupling_and_names(coupling, coordinate_names) -> tuple[np.ndarray, tuple[str, ...]]:
    """T (7,7) with q_dvrk = T c (default identity) and the coordinates' names (default the dVRK
    joints')."""
    T = np.eye(N_COORD) if coupling is None else np.asarray(coupling, dtype=float)
    return T, tuple(coordinate_names or JOINTS)


def relative_error(tau, tau_hat) -> np.ndarray:
    """Per coordinate ||tau - tau_hat|| / ||tau|| over the samples (rows)."""
    return np.linalg.norm(tau - tau_hat, axis=0) / np.linalg.norm(tau, axis=0)


# ------------------------------------------------------------------ fit
def fit_arm_dynamics(c, dc, tau_c, *, sample_rate_hz: float, coupling=None,
                     coordinate_names=None, options: DynamicsFitOptions = DynamicsFitOptions(),
                     provenance: str = "") -> ArmDynamicsModel:
    """Identify the arm model from one trajectory in actuated coordinates c (N,7).

    ``coupling`` T (7,7) with q_dvrk = T c (default identity: c are dVRK joints). Raises
    IdentificationInputError on bad input; returns a model with ``converged`` False (and the
    solver status in ``info``) when IPOPT did not converge.
    """
    t_start = time.perf_counter()
    T, names = coupling_and_names(coupling, coordinate_names)
    if T.shape != (N_COORD, N_COORD) or not np.isfinite(T).all() or abs(np.linalg.det(T)) < 1e-9:
        raise IdentificationInputError("coupling must be a finite invertible 7x7 matrix")
    c, dc, tau_c = check_fit_inputs(c, dc, tau_c, options, "training data")
    check_excitation(dc, names, "training data")
    cf, dcf, ddcf, tauf, zf = condition_signals(c, dc, tau_c, sample_rate_hz, options,
                                                with_states=True)
    return fit_conditioned(cf, dcf, ddcf, tauf, T, names, options, sample_rate_hz, provenance,
                           t_start, states=zf)


def fit_conditioned(cf, dcf, ddcf, tauf, T, names, options, sample_rate_hz, provenance,
                    t_start, states=None) -> ArmDynamicsModel:
    """The fit proper on already conditioned samples (rows need not be contiguous in time when
    their hysteresis ``states`` are given)."""
    import casadi as ca

    model, _ = identification_model()
    nb = len(BODIES)
    q, dq, ddq = cf @ T.T, dcf @ T.T, ddcf @ T.T
    Y0, Yg, mass_cols = rigid_regressors(model, q[:, :6], dq[:, :6], ddq[:, :6])
    # rigid part in coordinate space: tau_c = T^T [tau_q6; 0] = T[:6]^T tau_q6
    T6 = T[:6]
    A0 = np.einsum("njp,jk->nkp", Y0, T6)
    Ag = np.einsum("xnjp,jk->xnkp", Yg, T6)
    L = linear_columns(options, T, cf, dcf, ddcf, states, Y0)
    terms = linear_terms(options, names)
    term_names = [t.name for t in terms]
    lower = np.array([t.lower for t in terms])
    n_phi = L.shape[2]

    w = 1.0 / np.sqrt(np.mean(tauf ** 2, axis=0))       # 1 / RMS per coordinate
    A = np.concatenate([A0, Ag[0], Ag[1], Ag[2], L], axis=2) * w[None, :, None]
    A = A.reshape(-1, A.shape[2])
    b = (tauf * w).ravel()
    scale = np.sqrt(np.mean(A ** 2, axis=0))
    scale[scale == 0] = 1.0
    As = A / scale
    H = As.T @ As / len(b)
    g_vec = As.T @ b / len(b)
    c0 = float(b @ b) / len(b)

    # OLS warm start on the over-parametrised linear problem (z = [pi, g_x w, g_y w, g_z w, phi]).
    z_ols = np.linalg.lstsq(As, b, rcond=None)[0] / scale
    n_pi, n_w = 10 * nb, 4 * nb
    mu = z_ols[n_pi:n_pi + 3 * n_w].reshape(3, n_w)
    U_, S_, Vt_ = np.linalg.svd(mu)
    g0 = U_[:, 0] * GRAVITY_MPS2
    body_joints = [model.getJointId(b) for b in BODIES]
    pi_prior = np.concatenate([model.inertias[j].toDynamicParameters() for j in body_joints])
    if np.dot(S_[0] * Vt_[0] / GRAVITY_MPS2, pi_prior[mass_cols]) < 0:
        g0 = -g0

    theta = ca.MX.sym("theta", 10 * nb)
    gsym = ca.MX.sym("g", 3)
    phi = ca.MX.sym("phi", n_phi)
    pis = []
    for k in range(nb):
        pis += theta_to_parameters_casadi(theta[10 * k:10 * k + 10])
    pi_x = ca.vertcat(*pis)
    pi_w = ca.vertcat(*[pis[int(i)] for i in mass_cols])
    z = ca.vertcat(pi_x, gsym[0] * pi_w, gsym[1] * pi_w, gsym[2] * pi_w, phi)
    zs = z * ca.DM(scale)
    cost = 0.5 * ca.dot(zs, ca.mtimes(ca.DM(H), zs)) - ca.dot(ca.DM(g_vec), zs) + 0.5 * c0
    # weak pull to the URDF prior (scaled by each parameter's data scale) for invisible directions
    prior_scale = scale[:n_pi]
    reg = options.prior_weight * float(np.mean(np.diag(H))) * 0.5 * ca.sumsqr(
        (pi_x - ca.DM(pi_prior)) * ca.DM(prior_scale))
    x = ca.vertcat(theta, gsym, phi)
    if options.gravity is not None:
        g0 = np.asarray(options.gravity, dtype=float)
        if g0.shape != (3,) or not np.isfinite(g0).all():
            raise IdentificationInputError("options.gravity must be 3 finite numbers (m/s^2)")
    # inequality constraints >= 0 (ellipsoids, Coulomb levels)
    inequality_g = _ellipsoid_constraints(pis) if options.bounding_ellipsoids else []
    # direction-dependent Coulomb levels Fc + a and Fc - a stay >= 0
    for k in options.asymmetric_coulomb:
        i_c = term_names.index(f"{names[k]}.friction.coulomb")
        i_a = term_names.index(f"{names[k]}.friction.coulomb_asymmetry")
        inequality_g += [phi[i_c] + phi[i_a], phi[i_c] - phi[i_a]]
    # the counterweight is a point mass: m * (m z^2) >= (m z)^2 (with m, m z^2 >= 0 as bounds)
    if options.insertion_counterweight:
        i_m = term_names.index("insertion_counterweight.mass")
        inequality_g.append(phi[i_m] * phi[i_m + 2] - phi[i_m + 1] ** 2)
    nlp = {"x": x, "f": cost + reg, "g": ca.vertcat(ca.sumsqr(gsym), *inequality_g)}
    solver = ca.nlpsol("arm", "ipopt", nlp, {
        "ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": options.max_iter,
        "ipopt.tol": 1e-10, "ipopt.sb": "yes"})
    # generous physical box on each body (theta: log sqrt mass, log extents, shape terms in m,
    # centre of mass in m): mass 1e-6..100 kg, principal extents 1 mm..2 m, |shape|, |COM| <= 2 m.
    # It keeps directions the data cannot see (and the prior pull barely holds) from diverging.
    lbx_theta = np.tile([0.5 * np.log(1e-6)] + [np.log(_MIN_EXTENT_M)] * 3 + [-_MAX_SIZE_M] * 6, nb)
    ubx_theta = np.tile([0.5 * np.log(100.0)] + [np.log(_MAX_SIZE_M)] * 3 + [_MAX_SIZE_M] * 6, nb)
    theta0 = np.concatenate([parameters_to_theta(pi_prior[10 * k:10 * k + 10])
                             for k in range(nb)])
    phi0 = np.clip(z_ols[-n_phi:], lower, None)
    lbx = np.concatenate([lbx_theta, -np.inf * np.ones(3), lower])
    ubx = np.concatenate([ubx_theta, np.full(len(lbx) - 10 * nb, np.inf)])
    g_norm2 = GRAVITY_MPS2 ** 2
    if options.gravity is not None:  # known gravity: pin the three components
        lbx[10 * nb:10 * nb + 3] = ubx[10 * nb:10 * nb + 3] = g0
        g_norm2 = float(g0 @ g0)
    n_ell = len(inequality_g)
    sol = solver(x0=np.concatenate([theta0, g0, phi0]), lbx=lbx, ubx=ubx,
                 lbg=np.concatenate([[g_norm2], np.zeros(n_ell)]),
                 ubg=np.concatenate([[g_norm2], np.full(n_ell, np.inf)]))
    stats = solver.stats()
    xs = np.array(sol["x"]).ravel()
    body = np.stack([theta_to_parameters(xs[10 * k:10 * k + 10]) for k in range(nb)])
    g_fit = xs[10 * nb:10 * nb + 3]
    phi_fit = xs[10 * nb + 3:]

    n_parameters, base_columns = _base_parameters(A0, Ag, L, w, g_fit, mass_cols)
    all_names = [f"{b_}.{p}" for b_ in BODIES for p in PARAMETER_NAMES] + term_names

    fitted = ArmDynamicsModel(body, g_fit, phi_fit, T, names, options,
                              converged=bool(stats["success"]))
    tau_hat = fitted.predict_coordinates(cf, dcf, ddcf, states)
    bounds_hit = [n for n, v, lo in zip(term_names, phi_fit, lower)
                  if np.isfinite(lo) and v <= lo + 1e-9]
    fitted.info = {
        "solver": "CasADi IPOPT", "solver_status": stats["return_status"],
        "iterations": int(stats["iter_count"]), "fit_time_s": time.perf_counter() - t_start,
        "n_samples": int(len(cf)), "sample_rate_hz": float(sample_rate_hz),
        "n_parameters": n_parameters, "n_base_parameters": len(base_columns),
        "base_parameter_columns": [all_names[i] for i in base_columns],
        "gravity_direction_from_ols": (g0 / GRAVITY_MPS2).tolist(),
        "bounds_hit": bounds_hit,
        "train_relative_error": relative_error(tauf, tau_hat).tolist(),
        "provenance": provenance,
    }
    return fitted


def _ellipsoid_constraints(pis) -> list:
    """Bounding ellipsoids, as CasADi expressions >= 0 of the bodies' parameters ``pis`` (10 per
    body, :data:`BODIES` order): each body's mass lies inside an ellipsoid E = {x: |L (x - c)| <=
    1}, L = diag(1/semi-axes): int (1 - |L(x - c)|^2) dm >= 0, i.e. (scalar form of the LMI of
    Wensing et al. 2017) m (1 - c'L^2 c) + 2 (L^2 c).h - tr(L^2 Sigma) >= 0, Sigma = int x x' dm."""
    constraints = []
    for k, name in enumerate(BODIES):
        if name not in BOUNDING_ELLIPSOIDS:
            continue
        centre, axes = BOUNDING_ELLIPSOIDS[name]
        pk = pis[10 * k:10 * k + 10]
        L2 = 1.0 / np.asarray(axes, dtype=float) ** 2
        cen = np.asarray(centre, dtype=float)
        tr_i = pk[4] + pk[6] + pk[9]
        sigma_diag = (0.5 * tr_i - pk[4], 0.5 * tr_i - pk[6], 0.5 * tr_i - pk[9])
        constraints.append(pk[0] * (1.0 - float(cen @ (L2 * cen)))
                           + 2 * sum(L2[i] * cen[i] * pk[1 + i] for i in range(3))
                           - sum(L2[i] * sigma_diag[i] for i in range(3)))
    return constraints


def _base_parameters(A0, Ag, L, w, g_fit, mass_cols) -> tuple[int, np.ndarray]:
    """The number of parameters and the sorted columns of the base parameters: the rank of the
    weighted regressor at the identified gravity (QR with column pivoting)."""
    from scipy.linalg import qr

    Ag_fit = np.einsum("x,xnkp->nkp", g_fit, Ag)
    A_full = A0.copy()
    A_full[:, :, mass_cols] += Ag_fit
    A_base = np.concatenate([A_full, L], axis=2) * w[None, :, None]
    A_base = A_base.reshape(-1, A_base.shape[2])
    col_scale = np.linalg.norm(A_base, axis=0)
    col_scale[col_scale == 0] = 1.0
    R = qr(A_base / col_scale, mode="r", pivoting=True)
    diag = np.abs(np.diag(R[0]))
    rank = int(np.sum(diag > diag[0] * 1e-6))
    return int(A_base.shape[1]), np.sort(R[1][:rank])
