"""Paired comparison of two models over bench seeds: the error ratio, its interval and the verdict.

Both models are trained and scored on the same bench seeds, so each seed gives one ratio
``error_a / error_b`` (per axis), and the seed's own difficulty cancels in it. The comparison is
made on the logarithms of those ratios: their mean is the log of the geometric-mean ratio, and
their spread over seeds (ddof 1) gives the interval:

- ``"t"`` (default): Student's t interval on the mean log ratio, ``n - 1`` degrees of freedom,
  mapped back by ``exp``. It assumes the log ratios are roughly normal over seeds; with 3 to 5
  seeds it is wide, as it should be.
- ``"bootstrap"``: the percentile interval of the mean log ratio over seeds resampled with
  replacement (seeded). With few seeds it is too narrow (it cannot be wider than the seeds'
  range); it is offered for many seeds, and the table says which was used.

:func:`verdict` calls ``a`` "ahead" only when the whole interval lies below 1, "behind" only when it
lies above, and "tie" otherwise; one seed gives no interval and always a tie. The spread rule of
:func:`psmforce.estimators.evaluation.tables.compare` stays for the pages that used it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Mapping, Sequence

import numpy as np
from scipy import stats

CONFIDENCE = 0.95
METHODS = ("t", "bootstrap")
BOOTSTRAP_RESAMPLES = 10_000


class PairedError(ValueError):
    """Errors that cannot be paired (unequal lengths, not positive and finite); the message says
    which."""


@dataclass(frozen=True)
class PairedRatio:
    """``a``'s error over ``b``'s on the same seeds: per-seed ratios, their geometric mean and
    its interval (``low``, ``high``; NaN with one seed), the method and confidence, the verdict."""

    ratios: tuple[float, ...]
    mean_ratio: float
    low: float
    high: float
    method: str
    confidence: float
    verdict: str

    @property
    def n(self) -> int:
        return len(self.ratios)

    def to_dict(self) -> dict:
        return asdict(self) | {"n": self.n}

    def text(self) -> str:
        """``0.52x [0.41, 0.66] ahead``; one seed: ``0.52x (one seed) tie``."""
        if self.n < 2:
            return f"{self.mean_ratio:.2f}x (one seed) {self.verdict}"
        return f"{self.mean_ratio:.2f}x [{self.low:.2f}, {self.high:.2f}] {self.verdict}"


def verdict(low: float, high: float) -> str:
    """``"ahead"`` when the interval of ``a``'s error over ``b``'s lies wholly below 1,
    ``"behind"`` when wholly above, ``"tie"`` otherwise (and for a NaN bound: no interval)."""
    if math.isnan(low) or math.isnan(high):
        return "tie"
    if high < 1.0:
        return "ahead"
    return "behind" if low > 1.0 else "tie"


def _positive(name: str, values: Sequence[float]) -> np.ndarray:
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or len(x) == 0:
        raise PairedError(f"{name}: one error per seed expected, got shape {x.shape}")
    if not np.all(np.isfinite(x)) or np.any(x <= 0):
        raise PairedError(f"{name}: every error must be positive and finite, got {x.tolist()}")
    return x


def paired_ratio(errors_a: Sequence[float], errors_b: Sequence[float], *,
                 confidence: float = CONFIDENCE, method: str = "t", seed: int = 0) -> PairedRatio:
    """The paired ratio of ``errors_a`` over ``errors_b`` (one error per seed, the same seeds in
    the same order), with its ``confidence`` interval by ``method`` (see the module docstring);
    ``seed`` seeds the bootstrap."""
    a, b = _positive("errors_a", errors_a), _positive("errors_b", errors_b)
    if len(a) != len(b):
        raise PairedError(f"paired errors need the same seeds: {len(a)} against {len(b)}")
    if method not in METHODS:
        raise PairedError(f"unknown interval method {method!r}; known: {', '.join(METHODS)}")
    if not 0.0 < confidence < 1.0:
        raise PairedError(f"confidence must lie in (0, 1), got {confidence}")
    logs = np.log(a / b)
    mean = float(logs.mean())
    low = high = float("nan")
    if len(logs) >= 2:
        tail = (1.0 - confidence) / 2.0
        if method == "t":
            half = stats.t.ppf(1.0 - tail, len(logs) - 1) * logs.std(ddof=1) / math.sqrt(len(logs))
            low, high = mean - half, mean + half
        else:
            rng = np.random.default_rng(seed)
            means = logs[rng.integers(0, len(logs), (BOOTSTRAP_RESAMPLES, len(logs)))].mean(axis=1)
            low, high = np.quantile(means, [tail, 1.0 - tail])
        low, high = math.exp(low), math.exp(high)
    return PairedRatio(ratios=tuple(float(r) for r in a / b), mean_ratio=math.exp(mean),
                       low=low, high=high, method=method, confidence=confidence,
                       verdict=verdict(low, high))


def mean_sd(values: Sequence[float]) -> dict:
    """``{mean, sd, n}`` of errors over seeds, the sample standard deviation (ddof 1; NaN for one
    value): the spread a page shows beside a paired comparison."""
    x = np.asarray(values, dtype=float)
    return {"mean": float(x.mean()), "sd": float(x.std(ddof=1)) if len(x) > 1 else float("nan"),
            "n": int(len(x))}


def paired_by_axis(per_seed_a: Sequence[Mapping[str, float]],
                   per_seed_b: Sequence[Mapping[str, float]], axes: Sequence[str], **kwargs
                   ) -> dict[str, PairedRatio]:
    """:func:`paired_ratio` per axis of two models' per-seed ``{axis: error}`` lists."""
    return {a: paired_ratio([s[a] for s in per_seed_a], [s[a] for s in per_seed_b], **kwargs)
            for a in axes}


def paired_record(per_seed_a: Sequence[Mapping[str, float]],
                  per_seed_b: Sequence[Mapping[str, float]], axes: Sequence[str], **kwargs
                  ) -> dict[str, dict]:
    """:func:`paired_by_axis` as a JSON record: per axis the ratio's fields and its ``text``
    (the cell a page prints)."""
    return {a: r.to_dict() | {"text": r.text()}
            for a, r in paired_by_axis(per_seed_a, per_seed_b, axes, **kwargs).items()}
