"""Design of experiments for the internal-force prior: what a recording would tell about the
prior's parameters before anyone fits it (docs/ati_free.md): those the efforts reading fits
(:data:`DESIGNED`; an estimator's prior reads the efforts).

The measure is the Fisher information of the law's wrench (:mod:`.prior_law`, through
:func:`~psmforce.identification.prior_identifiability.jacobian_grams`) with respect to the
parameters, at the instrument's design values (:data:`~psmforce.identification.prior_selection.
DESIGN`), on a recording's own inputs (wrist positions, efforts, velocities and gravity in the
HEX10 frame, :func:`~psmforce.identification.prior.arrays_from_frame`) and its sample mask
(:func:`~psmforce.identification.prior.internal_wrench_target`: moments of samples under a known
external force and overloaded samples do not count, as in the fit). Each HEX10 channel is
weighed by an assumed white noise (``channel_noise``, N and Nm), so the information adds over
samples and over recordings, and the standard errors it gives are lower bounds: the wrist
efforts are read as exact (their errors, the fit's errors in variables, are not in it;
:func:`~psmforce.identification.prior_identifiability.identifiability` measures those on data).

Criteria, each from one information matrix F (physical units, :data:`DESIGNED` order):
:func:`log_det` of F scaled by each parameter's bounds' span (D-optimality, unit free);
:func:`condition_number` of F normalised to a unit diagonal (identifiability's measure: 1 for
orthogonal parameters, large where a combination is barely seen); :func:`standard_errors` from
F^-1; :func:`not_identifiable` by the identifiability report's rules that a design can apply (3
standard errors within what
:func:`~psmforce.identification.prior_identifiability.precision_needed` asks, 10 % of the
design value or an offset's resolution, or within :data:`ZERO_VALUE_SPAN` of the bounds' span
for another parameter designed at 0; no correlation beyond :data:`MAX_CORRELATION`).
:func:`segment_shares` says which parameters a part of a recording excites;
:func:`known_weight_gains` what known masses add.
"""

from __future__ import annotations

import numpy as np

from psmforce.identification.prior import (HELD_BY_READING, arrays_from_frame,
                                           internal_wrench_target)
from psmforce.identification.prior_identifiability import (is_offset, jacobian_grams,
                                                            precision_needed)
from psmforce.identification.prior_law import NAMES, PARAMETERS
from psmforce.identification.prior_selection import DESIGN

DESIGNED = tuple(n for n in NAMES if n not in HELD_BY_READING["efforts"])
"""The parameters a design informs, in :data:`NAMES` order: every one the efforts reading fits
(the capstan it holds at 0 is left out). Every matrix and vector here is in this order."""
_INDEX = [NAMES.index(n) for n in DESIGNED]
DESIGN_PARAMS = np.array([DESIGN[n] for n in NAMES])
"""The law's parameters the information is evaluated at (SI, all of :data:`NAMES`)."""
SPAN = np.array([PARAMETERS[i][3] - PARAMETERS[i][2] for i in _INDEX])
MAX_CORRELATION = 0.99
"""The identifiability report's limit on a parameter's correlation with another."""
ZERO_VALUE_SPAN = 0.01
"""A parameter other than an offset whose design value is 0 (the direction tension) cannot be
asked for a relative accuracy: 3 standard errors within this fraction of its bounds' span
instead. (An offset is asked for the sensor's resolution, whatever its value.)"""
EXCITE_RATIO = 2.0
"""A segment "excites" a parameter when its share of the parameter's information is at least
this many times its share of the duration: it tells more about it than an average second does.
A parameter every sample sees alike (a bias) is excited by none in particular."""


def fisher_information(frame, channel_noise, params=DESIGN_PARAMS, psm=None) -> np.ndarray:
    """(F, F) Fisher information (physical units) of a recording ``frame`` (the recording
    layout; a simulated one, or a plan run through the bench) about the prior's parameters at
    ``params`` (all of :data:`NAMES`), about the :data:`DESIGNED` ones (F), each HEX10 channel
    [fx fy fz tx ty tz] with white noise ``channel_noise`` (6,) (N, Nm). Additive: the
    information of two recordings is the sum of theirs."""
    arrays = arrays_from_frame(frame, psm)
    _, mask = internal_wrench_target(frame)
    inputs = (arrays["positions"], arrays["efforts"], arrays["velocities"], arrays["g_hex"],
              arrays["direction"])
    noise = np.asarray(channel_noise, dtype=float)
    return jacobian_grams(np.asarray(params, float), _INDEX, inputs, mask, noise).sum(axis=0)


def _scaled(info: np.ndarray) -> np.ndarray:
    """Information per bounds' span (each parameter measured in its span): unit free."""
    return info * np.outer(SPAN, SPAN)


def log_det(info: np.ndarray) -> float:
    """log det of the span-scaled information; -inf where it is singular."""
    sign, value = np.linalg.slogdet(_scaled(info))
    return float(value) if sign > 0 else float("-inf")


def condition_number(info: np.ndarray) -> float:
    """Condition number of the information normalised to a unit diagonal (the identifiability
    report's); infinite where a parameter has no information at all."""
    d = np.sqrt(np.diag(info))
    if not np.all(d > 0):
        return float("inf")
    return float(np.linalg.cond(info / np.outer(d, d)))


def covariance(info: np.ndarray) -> np.ndarray:
    """F^-1 (physical units), computed in span units (pseudo-inverse: a direction with no
    information gets none, not an overflow)."""
    return np.linalg.pinv(_scaled(info), rcond=1e-15, hermitian=True) * np.outer(SPAN, SPAN)


def standard_errors(info: np.ndarray) -> np.ndarray:
    return np.sqrt(np.maximum(np.diag(covariance(info)), 0.0))


def not_identifiable(info: np.ndarray, params=DESIGN_PARAMS) -> dict[str, str]:
    """Parameter -> why a fit on data with this information would not pin it down (the rules of
    the module docstring)."""
    cov = covariance(info)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    corr = cov / np.outer(np.where(se > 0, se, 1.0), np.where(se > 0, se, 1.0))
    np.fill_diagonal(corr, 0.0)
    value = np.asarray(params, dtype=float)[_INDEX]
    allowed = np.array([precision_needed(n, x) if is_offset(n) or x != 0.0
                        else ZERO_VALUE_SPAN * span for n, x, span in zip(DESIGNED, value, SPAN)])
    reasons = {}
    for i, name in enumerate(DESIGNED):
        why = []
        if not np.isfinite(se[i]) or 3 * se[i] > allowed[i]:
            why.append(f"3 SE = {3 * se[i]:.3g} {PARAMETERS[_INDEX[i]][1]} > {allowed[i]:.3g}")
        j = int(np.argmax(np.abs(corr[i])))
        if abs(corr[i, j]) > MAX_CORRELATION:
            why.append(f"correlation {corr[i, j]:+.4f} with {DESIGNED[j]}")
        if why:
            reasons[name] = "; ".join(why)
    return reasons


def summary(info: np.ndarray, params=DESIGN_PARAMS) -> dict:
    """The criteria of one information matrix, JSON ready (an infinite value as None)."""
    se = standard_errors(info)
    finite = lambda x: float(x) if np.isfinite(x) else None  # noqa: E731
    return {"log_det": finite(log_det(info)), "condition_number": finite(condition_number(info)),
            "standard_errors": {n: finite(x) for n, x in zip(DESIGNED, se)},
            "not_identifiable": not_identifiable(info, params)}


def segment_shares(infos: list[np.ndarray], durations_s) -> list[dict]:
    """Per segment (its information ``infos[s]``, its duration): each parameter's share of the
    total information (diagonal) and the parameters it excites (:data:`EXCITE_RATIO`)."""
    diag = np.array([np.diag(f) for f in infos])
    total = diag.sum(axis=0)
    share = diag / np.where(total > 0, total, 1.0)
    time_share = np.asarray(durations_s, dtype=float) / float(np.sum(durations_s))
    out = []
    for row, t in zip(share, time_share):
        out.append({"information_share": {n: float(x) for n, x in zip(DESIGNED, row)},
                    "excites": [n for n, x in zip(DESIGNED, row)
                                if x >= EXCITE_RATIO * t and x > 0]})
    return out


def known_weight_gains(base: np.ndarray, candidates: dict[str, np.ndarray],
                       params=DESIGN_PARAMS) -> dict:
    """What known masses hung at the tip add to the information ``base`` (the excitation's).

    ``candidates``: label (a mass in an orientation) -> the information of holding it. Each
    alone: its log-det gain and the standard errors of the parameters ``base`` does not
    identify, after / before. Then greedily, the candidate with the largest log-det gain
    first: after each step the criteria and what is still not identifiable; ``needed`` is how
    many steps make every parameter identifiable (None: the candidates never do)."""
    weak = list(not_identifiable(base, params))
    se0 = standard_errors(base)
    ld0 = log_det(base)
    idx = [DESIGNED.index(n) for n in weak]

    def gain(info):
        return {"log_det_gain": log_det(info) - ld0,
                "standard_error_ratio": {DESIGNED[i]: float(x) for i, x in
                                         zip(idx, standard_errors(info)[idx] / se0[idx])}}

    alone = {label: gain(base + f) for label, f in candidates.items()}
    steps, info, left = [], base.copy(), dict(candidates)
    needed = 0 if not weak else None
    while left and needed is None:
        label = max(left, key=lambda k: log_det(info + left[k]))
        before = log_det(info)
        info = info + left.pop(label)
        missing = not_identifiable(info, params)
        steps.append({"added": label, "log_det_gain": log_det(info) - before,
                      "condition_number": condition_number(info),
                      "not_identifiable": sorted(missing)})
        if not missing:
            needed = len(steps)
    return {"not_identifiable_without": weak, "each_alone": alone, "greedy": steps,
            "needed": needed}
