"""Which parameters of the internal-force prior the fitted data pin down
(:func:`identifiability`, reported in ``InternalForcePrior.info["identifiability"]``;
:func:`add_trial_spread` adds the jackknifes (over trials, over a design's orientations) that
:mod:`psmforce.identification.prior_selection` runs, and that module fixes what is listed).

The Fisher information of the scaled residuals gives the standard errors and correlations; it
treats the wrist efforts as exact, so the shrinkage that their noise causes in the parameters
that multiply them (errors in variables) is estimated separately (``input_reliability``).
docs/identification.md section 2.1.
"""

from __future__ import annotations

import numpy as np

from psmforce.identification.prior_law import KAPPA, NAMES, PARAMETERS, _model, at_bound
from psmforce.identification.prior_law import MIN_SAMPLES as _MIN_SAMPLES

RECOVERY_TOLERANCE = 0.10
"""The relative accuracy :func:`identifiability` asks of a parameter: three standard errors, and
the shrinkage that input noise causes, within 10 % of its value."""
OFFSET_RESOLUTION = {"N": 0.02, "Nm": 2e-4}
"""A sensor offset (``bias_*``) has no scale of its own: its truth may be 0, where a relative
accuracy means nothing. It is pinned down when three standard errors are within one reading's
white noise, and recovered when it is within that of the truth: 0.02 N and 0.2 mNm, the HEX10's
noise as the bench assumes it (docs/simulator.md section 7, assumed)."""


def is_offset(name: str) -> bool:
    """Whether ``name`` is one of the sensor's offsets (judged by :data:`OFFSET_RESOLUTION`)."""
    return name.startswith("bias_")


def precision_needed(name: str, value: float) -> float:
    """The largest three standard errors that still pin ``name`` down at ``value`` (SI):
    :data:`RECOVERY_TOLERANCE` of its value, or for an offset :data:`OFFSET_RESOLUTION`."""
    if is_offset(name):
        return OFFSET_RESOLUTION[PARAMETERS[NAMES.index(name)][1]]
    return RECOVERY_TOLERANCE * abs(value)


def recovered(name: str, fitted: float, truth: float) -> bool:
    """Whether ``fitted`` recovers ``truth``: within :data:`RECOVERY_TOLERANCE` of it, an offset
    within :data:`OFFSET_RESOLUTION` (a constant with a truth of 0 never is)."""
    if is_offset(name):
        return abs(fitted - truth) <= OFFSET_RESOLUTION[PARAMETERS[NAMES.index(name)][1]]
    return truth != 0 and abs(fitted / truth - 1.0) <= RECOVERY_TOLERANCE


MIN_INPUT_RELIABILITY = 1.0 - RECOVERY_TOLERANCE
MIN_CHANNEL_R2 = -0.05
"""A channel whose fitted R^2 is below this (a constant at its mean scores 0, so this is "worse
than a constant", with room for rounding) is not explained by the law on these data; a
parameter whose Fisher information comes mostly from such channels is listed ("lack of fit")."""
CHANNELS = ("fx", "fy", "fz", "tx", "ty", "tz")


def _pair_differentials(params, e):
    """(N, 3) pair differentials D (N) of the model from efforts (N, 3)."""
    tau_b1, tau_b2 = 0.5 * e[:, 1] - e[:, 2], 0.5 * e[:, 1] + e[:, 2]
    u0 = e[:, 0] - KAPPA * (tau_b1 + tau_b2)
    return np.stack([u0 / params[1], tau_b1 / params[2], tau_b2 / params[2]], axis=1)


def _prediction(params, inputs, sl) -> np.ndarray:
    """(n, 6) law's wrench [f; m] on the samples ``sl`` of ``inputs`` (positions, efforts,
    velocities, g_hex, direction[, hex10_force: the cross-talk's (N, 3) readings])."""
    pos, e, v, g, z, *reading = inputs
    force = reading[0][sl].T if reading and reading[0] is not None else None
    out = _model(params, pos[sl].T, e[sl].T, v[sl].T, g[sl].T, z[sl].T, np, force)
    return np.stack(np.broadcast_arrays(*out), axis=1)


def jacobian_grams(params, free, inputs, mask, ch_scale, chunk: int = 20000, y=None) -> np.ndarray:
    """(6, F, F) per channel ``J_k^T J_k``: J the derivative of the law's scaled output
    ``prediction / ch_scale`` over the samples ``mask`` keeps (N, 6) with respect to the ``free``
    parameters (indices into :data:`NAMES`, physical units), by central differences of 1e-6 of
    each parameter's bounds' span, at ``params``. The Fisher information is their sum weighted
    by 1 / (each channel's residual variance in those scaled units): :func:`identifiability`
    takes the variances from the fit's residuals, a design (:mod:`psmforce.identification.
    prior_design`) from an assumed sensor noise. ``y`` (N, 6), the readings, only sets the
    rounding of the differences (the residuals' own, as the fit sees them); None: zero."""
    params = np.asarray(params, dtype=float)
    y = np.zeros((len(inputs[0]), 6)) if y is None else y
    span = np.array([p[3] - p[2] for p in PARAMETERS])
    used = np.asarray(mask) > 0
    gram = np.zeros((6, len(free), len(free)))
    for start in range(0, len(inputs[0]), chunk):
        sl = slice(start, start + chunk)
        cols = []
        for i in free:
            dp = np.zeros(len(params))
            dp[i] = 1e-6 * span[i]
            cols.append(((_prediction(params + dp, inputs, sl) - y[sl]) / ch_scale
                         - (_prediction(params - dp, inputs, sl) - y[sl]) / ch_scale) / (2 * dp[i]))
        jac = np.stack(cols, axis=2) * used[sl][:, :, None]  # (n, 6, F), unused samples 0
        gram += np.einsum("nki,nkj->kij", jac, jac)
    return gram


def held_value_shifts(gram, n_free: int, tolerance) -> np.ndarray:
    """(F, H) how far each of the first ``n_free`` parameters of ``gram`` ((6, F + H, F + H)
    per channel Jacobian grams, :func:`jacobian_grams`, the free parameters then the held ones)
    moves, to first order, when each held parameter is off by its ``tolerance`` (H,): the fit's
    normal equations ``G_ff dp_f = -G_fh dp_h`` with G the channels' sum, as the fit weighs
    them. Physical units of the free parameters."""
    total = np.asarray(gram).sum(axis=0)
    return (-np.linalg.pinv(total[:n_free, :n_free]) @ total[:n_free, n_free:]
            * np.asarray(tolerance, dtype=float)[None, :])


def identifiability(params, fixed, inputs, y, mask, ch_scale, chunk: int = 20000, *,
                    efforts_read: bool = True, held_tolerance: dict | None = None) -> dict:
    """Which parameters the fitted data pin down, at the optimum ``params``.

    ``inputs`` = (positions, efforts, velocities, g_hex, direction[, hex10_force]); ``y``, ``mask``,
    ``ch_scale``: the fit's readings (external force removed), sample mask and channel scales,
    so the residuals are the fit's own scaled residuals r. J = dr/dp (central differences, physical units) over
    the free parameters; Fisher information sum_k J_k^T J_k / s_k^2 with s_k^2 the residual
    variance of channel k; its condition number once normalised to a unit diagonal (scale free:
    1 for orthogonal parameters, large where a combination is barely seen). Standard errors and
    correlations from the fit's own estimator (it weighs channels by their scale, not their
    noise: sandwich covariance H^-1 (sum_k s_k^2 J_k^T J_k) H^-1, H = J^T J), white residuals
    assumed: a lower bound where they are correlated in time.

    Input noise (errors in variables) is not in J: the model reads the wrist efforts as exact,
    and where their noise is a sizeable part of a regressor's spread, least squares shrinks the
    parameter that multiplies it towards zero by the reliability ``1 - var(noise) / var(D)``.
    The noise is estimated from the efforts' sample-to-sample steps (median absolute step: the
    white part only, a lower bound where the efforts carry slower disturbances); the regressors
    are the pair differentials D where the pair is taut (asymmetries, force samples) and where
    moments are fitted (cable radius). ``efforts_read`` (the efforts reading, whose D are read
    from the motor efforts): the efforts also carry slow disturbances that tension no cable (the
    discs' friction, the arm's), which the steps do not see, so the shrinkage is also bounded
    from the readings' side (``input_reliability_bound``, :func:`_reverse_regression_bound`).
    The load path reads D from the known tip force, whose errors are that sensor's white noise:
    there a residual beyond white noise is the law's misfit, not the regressor's, and the bound
    is not taken.

    ``not_identifiable`` (name -> reason): a parameter at its bound; one correlated beyond
    0.99 with another; 3 standard errors above :data:`RECOVERY_TOLERANCE` of its value (a value
    within 3 standard errors of zero cannot be pinned down relatively at all); a reliability
    below :data:`MIN_INPUT_RELIABILITY`; more than half its Fisher information from channels
    the law explains worse than a constant (R^2 below :data:`MIN_CHANNEL_R2`: lack of fit, the
    value then carries what the law misses); pulley radii, pretension, twist gain, bias_fz where fewer
    than 200 samples are slack by more than 3 noise standard deviations (only slack separates
    them; the smooth max's curvature would otherwise "identify" them from noise); one that
    rests on held design values: ``held_tolerance`` (name -> how far a held value may be off
    its truth, SI) moves it, to first order (:func:`held_value_shifts`, the held parameters'
    shifts added in quadrature), by more than its needed precision. A standard error sees the
    noise only; a design value held off its truth biases every free parameter correlated with
    it, however small their standard errors (``held_value_shift`` in the report).
    """
    pos, e, v, g = inputs[:4]
    free = [i for i, n in enumerate(NAMES) if n not in fixed]
    span = np.array([p[3] - p[2] for p in PARAMETERS])
    used = mask > 0

    held_tolerance = held_tolerance or {}
    held = [i for i, n in enumerate(NAMES) if n in fixed and held_tolerance.get(n, 0.0) > 0.0]
    gram_all = jacobian_grams(params, free + held, inputs, mask, ch_scale, chunk, y)
    gram = gram_all[:, :len(free), :len(free)]
    shifts = (held_value_shifts(gram_all, len(free), [held_tolerance[NAMES[i]] for i in held])
              if held and free else np.zeros((len(free), 0)))
    sq, n_res = np.zeros(6), np.zeros(6)
    for start in range(0, len(pos), chunk):
        sl = slice(start, start + chunk)
        r = (_prediction(params, inputs, sl) - y[sl]) / ch_scale
        sq += np.sum(np.where(used[sl], r, 0.0) ** 2, axis=0)
        n_res += used[sl].sum(axis=0)
    s2 = np.where(n_res > 0, sq / np.maximum(n_res, 1), 1.0)  # residual variance per channel
    # lack of fit: R^2 of each channel on the fitted samples (a constant scores 0)
    var_y = np.array([np.var(y[used[:, c], c]) if used[:, c].any() else 0.0 for c in range(6)])
    r2 = np.where(var_y > 0, 1.0 - s2 * ch_scale ** 2 / np.where(var_y > 0, var_y, 1.0), 1.0)
    unexplained = r2 < MIN_CHANNEL_R2
    info = np.einsum("kij,k->ij", gram, 1.0 / s2)  # Fisher information
    # the fit weighs channels by ch_scale, not by their residual variance: sandwich covariance
    hess_inv = np.linalg.pinv(gram.sum(axis=0))
    cov = hess_inv @ np.einsum("kij,k->ij", gram, s2) @ hess_inv
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    d = np.sqrt(np.diag(info))
    spread = d * span[free]  # the residuals' sensitivity across each parameter's bounds
    excited = spread > 1e-9 * spread.max()
    norm = info[np.ix_(excited, excited)] / np.outer(d[excited], d[excited])
    corr = np.clip(cov / np.outer(np.where(se > 0, se, 1.0), np.where(se > 0, se, 1.0)), -1, 1)

    # errors in variables: the wrist efforts' white noise against the regressors' spread
    D = _pair_differentials(params, e)
    noise_var = (1.4826 * np.median(np.abs(np.diff(D, axis=0)), axis=0)) ** 2 / 2.0
    two_t0 = params[0] / 3.0 * (1.0 + params[3] * pos[:, 0] ** 2)
    a = np.array([params[5], params[6], params[6]])
    taut = (two_t0[:, None] + a * D > np.abs(D)) & used[:, 2:3]

    def reliability(pairs, sel):
        var = [np.var(D[sel[:, i], i]) for i in pairs if sel[:, i].sum() > 1]
        spread = float(np.mean(var)) if var else 0.0  # 0: nothing moves the pairs (not excited)
        return float(1.0 - np.mean(noise_var[list(pairs)]) / spread) if spread > 0 else 0.0

    # slack samples beyond the effort noise: what separates the pretension from bias_fz (the
    # threshold) and pins the pulley radii (fz = -|D| there)
    clear_slack = (np.abs(D) - (two_t0[:, None] + a * D) > 3 * np.sqrt(noise_var)) & used[:, 2:3]
    n_slack = [int(clear_slack[:, 0].sum()), int(clear_slack[:, 1:].any(axis=1).sum())]
    not_slack = {"pulley_radius_pitch": n_slack[0] < _MIN_SAMPLES,
                 "pulley_radius_blade": n_slack[1] < _MIN_SAMPLES,
                 **dict.fromkeys(("pretension_total", "bias_fz", "twist_gain"),
                                 sum(n_slack) < _MIN_SAMPLES)}
    bound = at_bound(params)  # the rule of info["bounds_hit"]
    moments = np.broadcast_to(used[:, 3:4], D.shape)
    rel = {"asymmetry_pitch": reliability([0], taut), "asymmetry_blade": reliability([1, 2], taut),
           "cable_radius": reliability([0, 1, 2], moments)}
    white = _white_noise(y, used) / ch_scale  # the readings' white noise, scaled units
    rel_bound = {name: _reverse_regression_bound(free.index(NAMES.index(name)), params[
        NAMES.index(name)], gram, n_res * np.maximum(s2 - white ** 2, 0.0))
                 for name in rel if NAMES.index(name) in free} if efforts_read else {}

    # each parameter's Fisher information from the channels the law does not explain
    share = (np.einsum("kii,k->ki", gram, 1.0 / s2)[unexplained].sum(axis=0)
             / np.maximum(np.diag(info), 1e-300))
    reasons = {}
    for k, i in enumerate(free):
        name, unit, value = NAMES[i], PARAMETERS[i][1], params[i]
        if not excited[k]:
            reasons[name] = "not excited: the fitted samples do not depend on it"
            continue
        why = []
        if bound[i]:
            why.append(f"at its bound ({value:.4g} {unit}): set by the bound, not by the data")
        if not_slack.get(name):
            why.append(f"slack samples beyond the effort noise: {n_slack[0]} (pitch pair), "
                       f"{n_slack[1]} (blade pairs), fewer than {_MIN_SAMPLES}: without them the "
                       f"data see the rest level bias_fz - pretension_total, the product "
                       f"pretension_total x twist_gain and the ratios asymmetry / pulley "
                       f"radius, not the parts")
        partner = max((j for j in range(len(free)) if j != k), key=lambda j: abs(corr[k, j]),
                      default=None)
        if partner is not None and abs(corr[k, partner]) > 0.99:
            why.append(f"correlation {corr[k, partner]:+.4f} with {NAMES[free[partner]]}: the "
                       f"data see a combination of the two")
        if 3 * se[k] > precision_needed(name, value):
            why.append(f"{value:.4g} +- {se[k]:.2g} {unit} (1 SE): " + _imprecision(
                name, value, se[k]))
            if partner is not None and 0.9 < abs(corr[k, partner]) <= 0.99:
                why[-1] += f", correlation {corr[k, partner]:+.3f} with {NAMES[free[partner]]}"
        if share[k] > 0.5:
            bad = np.flatnonzero(unexplained)
            why.append(f"lack of fit: {share[k]:.0%} of its information comes from "
                       f"{', '.join(CHANNELS[c] for c in bad)}, which the law explains worse "
                       f"than a constant on the fitted data (R^2 "
                       f"{', '.join(f'{r2[c]:.3g}' for c in bad)}): its value carries what the "
                       f"law misses there")
        moved = float(np.sqrt(np.sum(shifts[k] ** 2)))
        if moved > precision_needed(name, value):
            by = [NAMES[held[j]] for j in np.argsort(-np.abs(shifts[k]))[:3]]
            why.append(f"rests on held design values: were they off by their tolerance, it "
                       f"would move {moved:.2g} {unit} (first order), more than the "
                       f"{precision_needed(name, value):.2g} it is judged by; most by "
                       f"{', '.join(by)}")
        if name in rel and rel[name] < MIN_INPUT_RELIABILITY:
            why.append(f"errors in variables: the wrist efforts' noise leaves a reliability of "
                       f"{rel[name]:.2f} in its regressor (the pair differentials), so the fit "
                       f"shrinks it towards zero")
        elif rel_bound.get(name, 1.0) < MIN_INPUT_RELIABILITY:
            why.append(f"errors in variables: the readings it explains keep a residual beyond "
                       f"their white noise, which a disturbance in its regressor (the pair "
                       f"differentials) would leave; the reverse regression puts it up to "
                       f"{1 / max(rel_bound[name], 1e-9) - 1:.0%} above the fit (reliability "
                       f"bound {rel_bound[name]:.2f})")
        if why:
            reasons[name] = "; ".join(why)
    for name in ("bias_fz", "twist_gain"):  # the data see bias_fz - T_tot and T_tot x twist_gain
        if "pretension_total" in reasons and name not in reasons and NAMES.index(name) in free:
            reasons[name] = ("tied to pretension_total, which is not identifiable: the data see "
                             "bias_fz - pretension_total and pretension_total x twist_gain")
    pairs = [[NAMES[free[i]], NAMES[free[j]], float(corr[i, j])]
             for i in range(len(free)) for j in range(i + 1, len(free)) if abs(corr[i, j]) > 0.9]
    return {
        "method": "Fisher information of the fit's scaled residuals (central differences) at the "
                  "optimum, channel noise from the residuals; sandwich standard errors, white "
                  "residuals assumed; input noise from the efforts' steps"
                  + ("; its shrinkage bounded by the reverse regression" if efforts_read else ""),
        "condition_number": float(np.linalg.cond(norm)) if norm.size else None,
        "standard_errors": {NAMES[i]: float(x) for i, x in zip(free, se)},
        "correlations_above_0.9": pairs,
        "effort_noise_differential_n": [float(x) for x in np.sqrt(noise_var)],
        "channel_r2": {c: float(x) for c, x in zip(CHANNELS, r2)},
        "input_reliability": rel,
        **({"input_reliability_bound": rel_bound,
            "readings_white_noise": {c: float(x) for c, x in zip(CHANNELS, white * ch_scale)}}
           if efforts_read else {}),
        "clear_slack_samples": {"pitch": n_slack[0], "blade": n_slack[1]},
        "held_value_shift": {NAMES[i]: float(np.sqrt(np.sum(shifts[k] ** 2)))
                             for k, i in enumerate(free)} if held else {},
        "not_identifiable": reasons,
        "fixed": sorted(fixed),
    }


def _white_noise(y, used) -> np.ndarray:
    """(6,) each reading's white noise (its units): the median absolute second difference over
    samples used three in a row, scaled to a standard deviation (a smooth signal's second
    difference is about 0; white noise's has 6 times its variance). A lower bound of the
    readings' noise: what is slower than a sample is left in the residual."""
    out = np.zeros(y.shape[1])
    for c in range(y.shape[1]):
        ok = used[2:, c] & used[1:-1, c] & used[:-2, c]
        d2 = (y[2:, c] - 2 * y[1:-1, c] + y[:-2, c])[ok]
        out[c] = 1.4826 * np.median(np.abs(d2)) / np.sqrt(6.0) if len(d2) else 0.0
    return out


def _reverse_regression_bound(j: int, value: float, gram, excess) -> float:
    """A lower bound of the reliability of free parameter ``j`` (index into the gram's free
    parameters) whose regressor is measured: Frisch's bounds for a slope under errors in
    variables, on the readings that carry it.

    Least squares gives the slope ``b`` = cov(y, x) / var(x); the reverse regression, with the
    readings' own white noise removed from var(y), gives (var(y) - noise) / cov(y, x), which is
    at or above the true slope whatever noise the regressor carries. Their ratio is
    ``1 + excess / explained``: ``explained`` the readings' variance the parameter carries once
    the other free parameters are partialled out (``value^2`` times the partial column's
    squared norm, Frisch-Waugh on the per-channel Jacobian grams ``gram``, (6, F, F)), ``excess``
    (6,) each channel's residual sum of squares beyond its white noise (scaled units). Channels
    that carry less than 5 % of the partial column's norm are left out (their misfit is not the
    parameter's). 1 where nothing is left over; the returned bound is explained / (explained +
    excess). A misfit from outside the law counts as regressor noise: the data cannot tell
    them apart, which is the point."""
    total = gram.sum(axis=0)
    others = [i for i in range(total.shape[0]) if i != j]
    beta = (np.linalg.lstsq(total[np.ix_(others, others)], total[others, j], rcond=None)[0]
            if others else np.zeros(0))
    part = np.array([g[j, j] - 2 * beta @ g[others, j] + beta @ g[np.ix_(others, others)] @ beta
                     for g in gram])
    part = np.maximum(part, 0.0)
    carried = part >= 0.05 * part.sum() if part.sum() > 0 else np.zeros(len(part), bool)
    explained = value ** 2 * part[carried].sum()
    left = float(np.sum(excess[carried]))
    return float(explained / (explained + left)) if explained + left > 0 else 1.0


def _imprecision(name: str, value: float, se: float) -> str:
    """Why 3 ``se`` do not pin ``name`` down (:func:`precision_needed`)."""
    if is_offset(name):
        unit = PARAMETERS[NAMES.index(name)][1]
        return (f"3 SE = {3 * se:.3g} {unit} exceed the offset's resolution of "
                f"{OFFSET_RESOLUTION[unit]:g} {unit}")
    return ("indistinguishable from zero" if abs(value) <= 3 * se else
            f"3 SE are {3 * se / abs(value):.0%} of the value")


def add_trial_spread(report: dict, params, jackknife_se: dict[str, float], groups: int,
                     over: str = "trials") -> dict:
    """Add a jackknife to an :func:`identifiability` report, in place, and return it.

    ``jackknife_se``: per free parameter, the delete-a-group jackknife standard error over
    ``groups`` groups (:func:`psmforce.identification.prior_selection.trial_jackknife`);
    ``over``: what a group holds, :data:`JACKKNIFE_OVER` (whole trials, or the known loads'
    orientations, alone or in sign pairs). Unlike the sandwich standard errors it needs no
    noise model: whatever varies between trials (coloured effort disturbance, the discs' stuck
    state, sensor drift, effects outside the law that each trial excites differently), or
    between the poses a design holds, moves the refits. A parameter whose 3 jackknife standard
    errors exceed :func:`precision_needed` joins ``not_identifiable`` with that reason (or has
    it appended); the standard errors are kept under ``jackknife_standard_errors`` (trials) or
    ``<over>_jackknife_standard_errors``."""
    if over not in JACKKNIFE_OVER:
        raise ValueError(f"over must be one of {sorted(JACKKNIFE_OVER)}, got {over!r}")
    reasons = report["not_identifiable"]
    prefix = "" if over == "trials" else f"{over}_"
    report[f"{prefix}jackknife_standard_errors"] = {n: float(x) for n, x in jackknife_se.items()}
    report[f"{prefix}jackknife_groups"] = int(groups)
    for name, se in jackknife_se.items():
        value = float(params[NAMES.index(name)])
        if 3 * se > precision_needed(name, value):
            unit = PARAMETERS[NAMES.index(name)][1]
            why = (f"{JACKKNIFE_OVER[over][0]}: {value:.4g} +- {se:.2g} {unit} (1 SE, "
                   f"jackknife over {groups} {JACKKNIFE_OVER[over][1]}), "
                   + _imprecision(name, value, se))
            reasons[name] = f"{reasons[name]}; {why}" if name in reasons else why
    return report


JACKKNIFE_OVER = {
    "trials": ("varies between groups of trials", "groups of trials"),
    "orientation": ("rests on the orientations the loads hang in",
                    "orientations, each left out with every mass hung in it"),
    "sign_pair": ("rests on the sign pairs of orientations the loads hang in",
                  "sign pairs of orientations, each pair left out with every mass hung in it")}
"""What a jackknife's group holds -> (the reason's words, the groups' words)
(:func:`add_trial_spread`)."""
