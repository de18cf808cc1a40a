"""A heteroscedastic output: the network's mean and log-variance per axis, trained and scored.

A network with ``predicts_variance = True``
(:class:`psmforce.estimators.networks.causal.CausalTransformer` built with ``uncertainty=True``)
outputs 6 channels per sample: the mean (3) and the log-variance (3) of the standard-scaled target,
i.e. the residual ``(ATI - base - target_scaler.mean) / target_scaler.std`` for the hybrid. Every
other network outputs the 3 means only (:func:`output_width`).

The log-variance passes through :func:`soft_clamp_logvar`, a tanh that keeps it inside
[:data:`LOGVAR_MIN`, :data:`LOGVAR_MAX`] smoothly (the gradient never vanishes abruptly as it
would at a hard clamp), so no sample, however far from the training data, gives a zero or
infinite variance.

Training: the beta-NLL of Seitzer et al., "On the Pitfalls of Heteroscedastic Uncertainty
Estimation with Probabilistic Neural Networks" (ICLR 2022), :func:`beta_nll`, beta =
:data:`BETA`. The plain Gaussian NLL weighs each sample's squared error by 1 / variance, so
samples the network calls noisy barely move the mean: it can "explain" a hard region by a large
variance instead of fitting it, and the mean under-fits there. Multiplying each sample's NLL by
its (gradient-stopped) variance ** beta undoes part of that down-weighting (beta = 1 gives the
mean the MSE's gradient; beta = 0.5 is the paper's recommended compromise).

The standard deviation in N of an axis is ``exp(logvar / 2) * target_scaler.std``
(:func:`std_newton`); the base and the mean of the scaler shift the mean, not its spread.
:func:`uncertainty_metrics` scores it against the truth.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from psmforce.io.recording import AXES

LOGVAR_MIN, LOGVAR_MAX = -12.0, 6.0
"""Range of the log-variance of the scaled target: std from 0.0025 to 20 target stds."""
LOGVAR_MID, LOGVAR_HALF = 0.5 * (LOGVAR_MIN + LOGVAR_MAX), 0.5 * (LOGVAR_MAX - LOGVAR_MIN)
"""Centre and half-width of that range: :func:`soft_clamp_logvar`'s tanh parameters."""
BETA = 0.5
"""The beta of :func:`beta_nll` (Seitzer et al. 2022's recommended value)."""


def predicts_variance(model) -> bool:
    """Whether ``model`` outputs a log-variance after its 3 means (the attribute
    ``predicts_variance``; absent means no)."""
    return bool(getattr(model, "predicts_variance", False))


def output_width(model) -> int:
    """Channels per sample of ``model``'s output: 6 (mean, log-variance) or 3 (mean)."""
    return 6 if predicts_variance(model) else 3


def soft_clamp_logvar(raw: torch.Tensor) -> torch.Tensor:
    """The raw log-variance squashed into (LOGVAR_MIN, LOGVAR_MAX) by a tanh centred on the
    range: slope 1 at its middle, smooth everywhere.
    :class:`psmforce.estimators.runtime.steppers.NumpyStepper` computes the same in numpy."""
    return LOGVAR_MID + LOGVAR_HALF * torch.tanh((raw - LOGVAR_MID) / LOGVAR_HALF)


def beta_nll(mean: torch.Tensor, logvar: torch.Tensor, target: torch.Tensor,
             beta: float = BETA) -> torch.Tensor:
    """Mean over every element of ``var.detach() ** beta * 0.5 * (logvar + (target - mean) ** 2
    / var)`` (the constant 0.5 log 2 pi left out); see the module docstring."""
    var = torch.exp(logvar)
    return torch.mean(var.detach() ** beta * 0.5 * (logvar + (target - mean) ** 2 / var))


def std_newton(logvar: np.ndarray, target_std: np.ndarray,
               out: np.ndarray | None = None) -> np.ndarray:
    """Per-axis standard deviation in N from the log-variance of the scaled target:
    ``exp(logvar / 2) * target_std`` (``out``: an array to write it into, for the streaming
    loop that allocates nothing)."""
    out = np.multiply(logvar, 0.5, out=out)
    np.exp(out, out=out)
    return np.multiply(out, target_std, out=out)


def uncertainty_metrics(pred: np.ndarray, std: np.ndarray,
                        truth: np.ndarray) -> dict[str, dict[str, float]]:
    """{axis: {mean_std_n, rmse_n, within_1std, within_2std, nll}} of (N, 3) predictions with
    their (N, 3) standard deviations against the truth, all in N. ``within_ks``: fraction of
    samples whose |error| <= k std (a calibrated Gaussian gives 0.683 and 0.954); ``nll``: the
    mean Gaussian negative log-likelihood of the truth per sample, nats (of the force in N, so
    it depends on the unit; lower is better)."""
    err = np.asarray(truth, float) - np.asarray(pred, float)
    std = np.asarray(std, float)
    nll = 0.5 * math.log(2 * math.pi) + np.log(std) + 0.5 * (err / std) ** 2
    return {a: {"mean_std_n": float(std[:, i].mean()),
                "rmse_n": float(np.sqrt(np.mean(err[:, i] ** 2))),
                "within_1std": float(np.mean(np.abs(err[:, i]) <= std[:, i])),
                "within_2std": float(np.mean(np.abs(err[:, i]) <= 2 * std[:, i])),
                "nll": float(nll[:, i].mean())} for i, a in enumerate(AXES)}
