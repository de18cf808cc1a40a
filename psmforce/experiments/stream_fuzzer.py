"""Adversarial streams for :class:`psmforce.estimators.runtime.streaming.StreamingEstimator`: the property behind
"a streaming loop cannot be poisoned".

:func:`fuzz_stream` feeds one estimator a clean recording (tiled to any length, with time gaps)
in which a fraction of the samples is corrupted (:data:`KINDS`: random finite extremes, NaN / inf,
physical spikes beyond the training range, wrong types, missing fields, bad or future
timestamps, malformed arrays, overload flags), and a second, reference estimator of the same
configuration only the clean samples. It reports, and the property asks for:

* no exception, whatever the sample;
* every estimate finite once there has been one (before it, the held estimate is NaN);
* every malformed, non-finite or out-of-bounds sample flagged ``INVALID_INPUT``, every bad
  timestamp flagged and held;
* every estimate farther than ``far_n`` from the reference's (the recent valid trend) carries a
  flag that says why (:data:`SUSPECT`).

``tests/estimators/test_streaming.py`` runs 2 x 10^4 samples,
``tests/robustness/adversarial_stream.py`` 10^6.
"""

from __future__ import annotations

from collections import Counter
from typing import Callable

import numpy as np
import pandas as pd

from psmforce.estimators.data.bounds import physical_bounds
from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
from psmforce.io.recording import OVERLOAD

KINDS = ("clean", "extreme", "nonfinite", "spike", "type", "missing", "sample_type", "time",
         "future", "array", "overload")
"""What a corrupted sample can be; ``clean`` is the recording's own sample."""
REFUSED = {"extreme", "nonfinite", "type", "missing", "sample_type", "array"}
"""Kinds that must come back ``INVALID_INPUT`` and ``HELD``."""
SUSPECT = (Flags.WARMING_UP | Flags.INVALID_INPUT | Flags.TIME_BACKWARDS | Flags.GAP
           | Flags.EXTRAPOLATION | Flags.HELD | Flags.RESET | Flags.IMPLAUSIBLE)
"""Flags that tell a consumer not to trust an estimate as it is."""
FAR_N = 1.0
"""An unflagged estimate must stay within this of the clean stream's (N): 1 N is several times
the hybrid's test RMSE and above what one in-range sample moves an estimate by."""
_BAD_VALUES = ("abc", None, [1.0, 2.0], {}, object(), 1j, b"\xff", "")


def _corrupt(kind: str, values: np.ndarray, t: float, last_t: float, columns: list[str],
             bounds: np.ndarray, rng: np.random.Generator):
    """(sample, time argument) for one corrupted copy of the clean ``values`` at time ``t``."""
    sample = dict(zip(columns, values.tolist()), time=t)
    col = columns[rng.integers(len(columns))]
    if kind == "extreme":
        sample[col] = float(rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(3, 308))
    elif kind == "nonfinite":
        sample[col] = float(rng.choice([np.nan, np.inf, -np.inf]))
    elif kind == "spike":  # physically possible, mostly far outside any training range
        lo, hi = bounds[columns.index(col)]
        sample[col] = float(rng.uniform(lo, hi))
    elif kind == "type":
        sample[col] = _BAD_VALUES[rng.integers(len(_BAD_VALUES))]
    elif kind == "missing":
        del sample[col]
    elif kind == "sample_type":
        return [None, "sample", 42, values.tolist(), {"time": t}][rng.integers(5)], None
    elif kind == "time":
        bad_times = (np.nan, None, "t", t - rng.uniform(0.001, 1.0), last_t, np.inf)
        sample["time"] = bad_times[rng.integers(len(bad_times))]
    elif kind == "future":
        sample["time"] = t + 10.0 ** rng.uniform(1, 6)
    elif kind == "array":
        shapes = (values[:-1], np.r_[values, 0.0], values[None], np.full(values.shape, "x"),
                  values.astype(object).reshape(-1, 1))
        return shapes[rng.integers(len(shapes))], t
    elif kind == "overload":
        sample[OVERLOAD] = 1
    return sample, None


def fuzz_stream(make_estimator: Callable[[], StreamingEstimator], frame: pd.DataFrame,
                n_samples: int = 20_000, *, seed: int = 0, bad_fraction: float = 0.1,
                gap_fraction: float = 0.002, far_n: float = FAR_N) -> dict:
    """Run the property on ``n_samples`` samples built from ``frame`` (a valid recording); see
    the module docstring. Returns counts and the violations (lists of (index, kind, detail),
    first 20 of each): ``exceptions``, ``non_finite``, ``not_refused``, ``unflagged_far``."""
    est, ref = make_estimator(), make_estimator()
    columns = list(est.columns)
    clean = frame[columns].to_numpy(np.float64)
    limits = physical_bounds()
    bounds = np.array([limits.get(c, (-1e3, 1e3)) for c in columns])
    rng = np.random.default_rng(seed)
    # timestamps: consecutive samples with a gap now and then, beyond what is bridged or not
    jump = rng.integers(2, 3 * est.max_gap_samples + 3, n_samples)
    steps = np.where(rng.random(n_samples) < gap_fraction, jump, 1)
    times = np.cumsum(steps) / est.rate_hz
    kinds = np.where(rng.random(n_samples) < bad_fraction,
                     rng.integers(1, len(KINDS), n_samples), 0)
    violations = {"exceptions": [], "non_finite": [], "not_refused": [], "unflagged_far": []}
    counts, flagged = Counter(), Counter()
    worst_unflagged = 0.0
    seen_estimate = False
    ref_out = None
    for i in range(n_samples):
        kind, t = KINDS[kinds[i]], float(times[i])
        values = clean[i % len(clean)]
        counts[kind] += 1
        if kind == "clean":
            sample, when = dict(zip(columns, values.tolist()), time=t), None
        else:
            sample, when = _corrupt(kind, values, t, float(times[i - 1]) if i else t - 1.0,
                                    columns, bounds, rng)
        try:
            out = est.step(sample, when)
        except Exception as err:  # noqa: BLE001 - the property: nothing may escape
            violations["exceptions"].append((i, kind, f"{type(err).__name__}: {err}"))
            continue
        if kind in ("clean", "overload"):
            ref_out = ref.step(values, t)
        flags = out.flags
        for flag in Flags:
            if flag and flags & flag:
                flagged[flag.name] += 1
        finite = bool(np.isfinite(out.force_hex10).all())
        seen_estimate |= not flags & Flags.HELD
        if seen_estimate and not finite:
            violations["non_finite"].append((i, kind, out.force_hex10.tolist()))
        if kind in REFUSED and flags & (Flags.INVALID_INPUT | Flags.HELD) != (
                Flags.INVALID_INPUT | Flags.HELD):
            violations["not_refused"].append((i, kind, Flags(flags).name))
        if (finite and not flags & SUSPECT and ref_out is not None
                and not ref_out.flags & SUSPECT):
            deviation = float(np.abs(out.force_hex10 - ref_out.force_hex10).max())
            worst_unflagged = max(worst_unflagged, deviation)
            if deviation > far_n:
                violations["unflagged_far"].append((i, kind, deviation))
    return {"samples": n_samples, "seed": seed, "far_n": far_n, "kinds": dict(counts),
            "flags": dict(flagged), "max_unflagged_deviation_n": worst_unflagged,
            **{k: len(v) for k, v in violations.items()},
            "examples": {k: v[:20] for k, v in violations.items()}}
