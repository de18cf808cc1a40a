"""How much of the internal-force prior held-out recordings support, per output component.

The prior is a law fitted on training recordings. Where the bench (or the robot) has an internal
wrench outside the law's family, the fit soaks it into parameters that mean something else (a
crossing cable's lateral force into the distal mass, docs/identification.md section 2), and
subtracting that prediction makes the hybrid's input worse, not better. Where the law predicts a
component as a constant (the lateral forces on a straight-cable instrument) subtracting it changes
nothing but an offset. Either way the prior should stay out of that component.

:func:`supported_weights` measures it on recordings the fit did not see (the validation trials):
per component k of [fx, fy, fz, tx, ty, tz] (HEX10 frame, N and Nm), the least-squares slope of
the held-out internal wrench ``y_k`` (:func:`~psmforce.identification.prior.internal_wrench_target`:
HEX10 minus the known external force) on the law's prediction ``p_k``, both centred (offsets are
the network's to learn), clipped to [0, 1]:

    w_k = clip(cov(y_k, p_k) / var(p_k), 0, 1)

which is the weight that leaves the least variance in ``y_k - w_k p_k``, the hybrid's residual.
A weight is set to 0 when the weighted prediction removes less than :data:`MIN_EXPLAINED` of
``y_k``'s held-out variance: a component the data cannot show the law to help is left out
rather than subtracted with a noisy slope.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import (InternalForcePrior, _check_arrays, arrays_from_frame,
                                            internal_wrench_target)
from psmforce.io.recording import HEX10

MIN_EXPLAINED = 0.01
"""Share of a component's held-out variance the weighted prior must remove to stay in it."""


def supported_weights(prior: InternalForcePrior, recordings: Sequence, psm=None
                      ) -> tuple[np.ndarray, dict]:
    """((6,) weights in [0, 1], report) of ``prior`` on held-out ``recordings`` (DataFrames of
    :mod:`psmforce.io.recording`); see the module docstring. The report gives, per component, the
    weight, the unclipped slope and the share of held-out variance removed with the law as
    fitted (``explained_as_fitted``, may be negative) and with the weight (``explained``)."""
    if len(recordings) == 0:
        raise IdentificationInputError("no held-out recordings to weigh the prior on")
    ys, masks, preds = [], [], []
    for frame in recordings:
        a = arrays_from_frame(frame, psm, direction=prior.has_friction)
        y, mask = internal_wrench_target(frame)
        ys.append(y)
        masks.append(mask)
        preds.append(prior.law_arrays(*_check_arrays(a["positions"], a["efforts"],
                                                      a["velocities"], a["g_hex"],
                                                      a["direction"]),
                                      a["hex10_force"] if prior.has_crosstalk else None))
    y, mask, p = (np.concatenate(x) for x in (ys, masks, preds))
    weights, report = np.zeros(6), {}
    for k, name in enumerate(HEX10):
        m = mask[:, k] > 0
        if m.sum() < 2:
            report[name] = {"weight": 0.0, "samples": int(m.sum()), "reason": "no samples"}
            continue
        yk, pk = y[m, k] - y[m, k].mean(), p[m, k] - p[m, k].mean()
        var_y, var_p = float(yk @ yk), float(pk @ pk)
        slope = float(yk @ pk) / var_p if var_p > 0 else 0.0
        w = min(max(slope, 0.0), 1.0)
        explained = _explained(yk, w * pk, var_y)
        if explained < MIN_EXPLAINED:
            w = 0.0
        weights[k] = w
        report[name] = {"weight": w, "slope": slope, "samples": int(m.sum()),
                        "explained_as_fitted": _explained(yk, pk, var_y),
                        "explained": _explained(yk, w * pk, var_y)}
    return weights, {"method": "psmforce.identification.prior_support.supported_weights",
                     "min_explained": MIN_EXPLAINED, "recordings": len(recordings),
                     "components": report}


def weigh_prior(prior: InternalForcePrior, recordings: Sequence, psm=None) -> InternalForcePrior:
    """``prior`` with the :func:`supported_weights` of ``recordings`` (a copy)."""
    weights, report = supported_weights(prior, recordings, psm)
    return prior.with_axis_weights(weights, report)


def _explained(y: np.ndarray, removed: np.ndarray, var_y: float) -> float:
    """Share of ``y``'s variance (sum of squares ``var_y``, centred) that subtracting ``removed``
    (centred) takes away."""
    if var_y <= 0:
        return 0.0
    r = y - removed
    return float(1.0 - (r @ r) / var_y)
