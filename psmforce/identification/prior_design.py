"""Design of experiments for the internal-force prior: what a recording would tell about the
prior's parameters before anyone fits it (docs/ati_free.md), for a fit reading the cables from
the motor efforts (``reading="efforts"``, the default: an estimator's prior; the parameters of
:data:`DESIGNED`) or from the known tip force (``reading="load_path"``: the instrument's
identification with known weights, :mod:`psmforce.identification.load_path`; every parameter of
the law, :func:`designed`).

The measure is the Fisher information of the law's wrench (:mod:`.prior_law`, through
:func:`~psmforce.identification.prior_identifiability.jacobian_grams`) with respect to the
parameters, at the instrument's design values (:data:`~psmforce.identification.prior_selection.
DESIGN`), on a recording's own inputs (wrist positions, efforts, velocities and gravity in the
HEX10 frame, as :func:`~psmforce.identification.prior.fit_arrays` gives them for the reading)
and its sample mask, as in the fit (:func:`~psmforce.identification.prior.internal_wrench_target`:
overloaded samples do not count, nor, read from the efforts, the moments of samples under a
known external force; read from the load path, the tip force's moment is known and every moment
counts, but clenched samples do not). Each HEX10 channel is
weighed by an assumed white noise (``channel_noise``, N and Nm), so the information adds over
samples and over recordings, and the standard errors it gives are lower bounds: the wrist
efforts are read as exact (their errors, the fit's errors in variables, are not in it;
:func:`~psmforce.identification.prior_identifiability.identifiability` measures those on data).

Criteria, each from one information matrix F (physical units, in the order of
:func:`designed` for its reading; every function takes the ``reading`` its matrix was computed
for):
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

from functools import cache

import numpy as np

from psmforce.identification.prior import fit_arrays, held_by_reading
from psmforce.identification.prior_identifiability import (is_offset, jacobian_grams,
                                                            precision_needed)
from psmforce.identification.prior_law import NAMES, PARAMETERS
from psmforce.identification.prior_selection import DESIGN


@cache
def designed(reading: str = "efforts") -> tuple[str, ...]:
    """The parameters a design for a fit reading ``reading`` informs, in :data:`NAMES` order:
    every one that reading fits (:func:`~psmforce.identification.prior.held_by_reading`; the
    efforts reading holds the capstan and the sensor's cross-talk, the load path nothing).
    Every matrix and vector of that reading is in this order."""
    return tuple(n for n in NAMES if n not in held_by_reading(reading))


DESIGNED = designed("efforts")
"""The parameters an efforts design informs (:func:`designed`)."""


def design_params(reading: str = "efforts") -> np.ndarray:
    """The law's parameters the information is evaluated at (SI, all of :data:`NAMES`): the
    design values, with what ``reading`` holds at its held value (the law that reading fits:
    the blade cables' path tension in one form only)."""
    held = held_by_reading(reading)
    return np.array([held.get(n, DESIGN[n]) for n in NAMES])


DESIGN_PARAMS = design_params("efforts")
""":func:`design_params` of the efforts reading."""


def _index(reading: str) -> list[int]:
    return [NAMES.index(n) for n in designed(reading)]


def _span(reading: str) -> np.ndarray:
    return np.array([PARAMETERS[i][3] - PARAMETERS[i][2] for i in _index(reading)])


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


def fisher_information(frame, channel_noise, params=None, psm=None,
                       reading: str = "efforts") -> np.ndarray:
    """(F, F) Fisher information (physical units) of a recording ``frame`` (the recording
    layout; a simulated one, or a plan run through the bench; the load path needs its known tip
    force) about the prior's parameters at ``params`` (all of :data:`NAMES`), about those
    ``reading`` fits (F, :func:`designed`), each HEX10 channel [fx fy fz tx ty tz] with white
    noise ``channel_noise`` (6,) (N, Nm). Additive: the information of two recordings is the
    sum of theirs."""
    params = design_params(reading) if params is None else params
    arrays, _, mask = fit_arrays(frame, reading, psm)
    inputs = (arrays["positions"], arrays["efforts"], arrays["velocities"], arrays["g_hex"],
              arrays["direction"], arrays["hex10_force"])
    noise = np.asarray(channel_noise, dtype=float)
    return jacobian_grams(np.asarray(params, float), _index(reading), inputs, mask,
                          noise).sum(axis=0)


def _scaled(info: np.ndarray, reading: str) -> np.ndarray:
    """Information per bounds' span (each parameter measured in its span): unit free."""
    span = _span(reading)
    if info.shape != (len(span), len(span)):
        raise ValueError(f"an information matrix of shape {info.shape} is not one of the "
                         f"{reading} reading, which informs {len(span)} parameters")
    return info * np.outer(span, span)


def log_det(info: np.ndarray, reading: str = "efforts") -> float:
    """log det of the span-scaled information; -inf where it is singular."""
    sign, value = np.linalg.slogdet(_scaled(info, reading))
    return float(value) if sign > 0 else float("-inf")


def condition_number(info: np.ndarray) -> float:
    """Condition number of the information normalised to a unit diagonal (the identifiability
    report's); infinite where a parameter has no information at all."""
    d = np.sqrt(np.diag(info))
    if not np.all(d > 0):
        return float("inf")
    return float(np.linalg.cond(info / np.outer(d, d)))


def covariance(info: np.ndarray, reading: str = "efforts") -> np.ndarray:
    """F^-1 (physical units), computed in span units (pseudo-inverse: a direction with no
    information gets none, not an overflow)."""
    span = _span(reading)
    return np.linalg.pinv(_scaled(info, reading), rcond=1e-15, hermitian=True) \
        * np.outer(span, span)


def standard_errors(info: np.ndarray, reading: str = "efforts") -> np.ndarray:
    """From :func:`covariance`; infinite for a parameter without any information (the
    pseudo-inverse would give it 0)."""
    se = np.sqrt(np.maximum(np.diag(covariance(info, reading)), 0.0))
    se[~(np.diag(info) > 0)] = np.inf
    return se


def not_identifiable(info: np.ndarray, params=None, reading: str = "efforts"
                     ) -> dict[str, str]:
    """Parameter -> why a fit on data with this information would not pin it down (the rules of
    the module docstring)."""
    names, index, spans = designed(reading), _index(reading), _span(reading)
    cov = covariance(info, reading)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    corr = cov / np.outer(np.where(se > 0, se, 1.0), np.where(se > 0, se, 1.0))
    np.fill_diagonal(corr, 0.0)
    value = np.asarray(design_params(reading) if params is None else params, dtype=float)[index]
    allowed = np.array([precision_needed(n, x) if is_offset(n) or x != 0.0
                        else ZERO_VALUE_SPAN * span for n, x, span in zip(names, value, spans)])
    reasons = {}
    seen = np.diag(info) > 0
    for i, name in enumerate(names):
        why = []
        if not seen[i]:  # the pseudo-inverse gives a parameter nothing sees a standard error of 0
            why.append("no information (nothing in the data depends on it)")
        elif not np.isfinite(se[i]) or 3 * se[i] > allowed[i]:
            why.append(f"3 SE = {3 * se[i]:.3g} {PARAMETERS[index[i]][1]} > {allowed[i]:.3g}")
        j = int(np.argmax(np.abs(corr[i])))
        if abs(corr[i, j]) > MAX_CORRELATION:
            why.append(f"correlation {corr[i, j]:+.4f} with {names[j]}")
        if why:
            reasons[name] = "; ".join(why)
    return reasons


def _finite(x) -> float | None:
    """``x`` as a JSON number; None where it is not finite (no information, a singular matrix)."""
    return float(x) if np.isfinite(x) else None


def summary(info: np.ndarray, params=None, reading: str = "efforts") -> dict:
    """The criteria of one information matrix, JSON ready (an infinite value as None)."""
    se = standard_errors(info, reading)
    return {"log_det": _finite(log_det(info, reading)),
            "condition_number": _finite(condition_number(info)),
            "standard_errors": {n: _finite(x) for n, x in zip(designed(reading), se)},
            "not_identifiable": not_identifiable(info, params, reading)}


def segment_shares(infos: list[np.ndarray], durations_s, reading: str = "efforts"
                   ) -> list[dict]:
    """Per segment (its information ``infos[s]``, its duration): each parameter's share of the
    total information (diagonal) and the parameters it excites (:data:`EXCITE_RATIO`)."""
    names = designed(reading)
    diag = np.array([np.diag(f) for f in infos])
    total = diag.sum(axis=0)
    share = diag / np.where(total > 0, total, 1.0)
    time_share = np.asarray(durations_s, dtype=float) / float(np.sum(durations_s))
    out = []
    for row, t in zip(share, time_share):
        out.append({"information_share": {n: float(x) for n, x in zip(names, row)},
                    "excites": [n for n, x in zip(names, row)
                                if x >= EXCITE_RATIO * t and x > 0]})
    return out


def known_weight_gains(base: np.ndarray, candidates: dict[str, np.ndarray],
                       params=None, reading: str = "efforts") -> dict:
    """What known masses hung at the tip add to the information ``base`` (the excitation's).

    ``candidates``: label (a mass in an orientation) -> the information of holding it. Each
    alone: its log-det gain and the standard errors of the parameters ``base`` does not
    identify, after / before. Then greedily, the candidate with the largest log-det gain
    first: after each step the criteria and what is still not identifiable; ``needed`` is how
    many steps make every parameter identifiable (None: the candidates never do), and
    ``not_identifiable_with_all`` what the last step leaves. The log-dets
    and condition numbers are taken over the parameters that the base or some candidate informs
    at all: one that none informs (the capstan's growth under static holds, read through the
    load path) would make every log-det -inf; it is named not identifiable at every step."""
    names = designed(reading)
    weak = list(not_identifiable(base, params, reading))
    se0 = standard_errors(base, reading)
    informed = np.diag(base + sum(candidates.values(), np.zeros_like(base))) > 0
    span = _span(reading)[informed]

    def ld(info):
        sign, value = np.linalg.slogdet(info[np.ix_(informed, informed)] * np.outer(span, span))
        return float(value) if sign > 0 else float("-inf")

    ld0 = ld(base)

    def gain(info):
        with np.errstate(invalid="ignore"):  # no information before or after: no ratio (None)
            ratio = standard_errors(info, reading)[idx] / se0[idx]
        return {"log_det_gain": _finite(ld(info) - ld0),
                "standard_error_ratio": {names[i]: _finite(x) for i, x in zip(idx, ratio)}}

    idx = [names.index(n) for n in weak]
    alone = {label: gain(base + f) for label, f in candidates.items()}
    steps, info, left = [], base.copy(), dict(candidates)
    needed = 0 if not weak else None
    while left and needed is None:
        label = max(left, key=lambda k: ld(info + left[k]))
        before = ld(info)
        info = info + left.pop(label)
        missing = not_identifiable(info, params, reading)
        steps.append({"added": label, "log_det_gain": _finite(ld(info) - before),
                      "condition_number": _finite(condition_number(
                          info[np.ix_(informed, informed)])),
                      "not_identifiable": sorted(missing)})
        if not missing:
            needed = len(steps)
    return {"not_identifiable_without": weak, "each_alone": alone, "greedy": steps,
            "needed": needed,
            "not_identifiable_with_all": steps[-1]["not_identifiable"] if steps else weak}
