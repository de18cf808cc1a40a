"""Putting every stream on one clock.

Rules, per stream, before resampling:

* messages are sorted by time stamp (stable); an *out-of-order* message is one whose stamp is
  earlier than a stamp already seen in bag order; they are counted;
* *duplicates* (a stamp equal to an earlier one) are dropped, keeping the first in bag order;
* the *nominal period* is the median interval between consecutive distinct stamps;
* *dropped messages* are estimated as ``sum(max(0, round(interval / nominal) - 1))``;
* a *gap* is an interval longer than ``gap_periods`` x max(nominal period, output period): a hole a
  few output periods long is bridged just as the output clock bridges its own samples, longer ones
  are not.

The output clock runs at ``rate_hz`` over the span every stream covers (latest first message to
earliest last message), starting at that span's start (``time`` = 0). Every column is linearly
interpolated between the two messages that bracket an output time (all signals are continuous:
joint positions, velocities, efforts, wrenches, Jacobian entries). An output time strictly inside a
gap of any stream is marked; the caller drops or flags those rows (never silently kept).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psmforce.io.bags.reading import BagError, RawStream


@dataclass(frozen=True)
class CleanStream:
    """One stream sorted and de-duplicated, with what was found on the way."""

    raw: RawStream
    stamps_ns: np.ndarray
    """(M,) int64 strictly increasing."""
    values: np.ndarray
    out_of_order: int
    duplicates: int
    nominal_period_s: float
    dropped_estimate: int


def clean(stream: RawStream, where: str) -> CleanStream:
    """Sort by stamp, drop duplicate stamps and measure the stream's timing."""
    stamps = stream.stamps_ns
    out_of_order = int(np.count_nonzero(stamps[1:] < np.maximum.accumulate(stamps)[:-1]))
    order = np.argsort(stamps, kind="stable")
    stamps, values = stamps[order], stream.values[order]
    first = np.concatenate(([True], np.diff(stamps) > 0))
    stamps, values = stamps[first], values[first]
    if len(stamps) < 2:
        raise BagError(f"{where}: topic '{stream.topic}' has {len(stamps)} distinct time stamp(s); "
                       f"at least 2 are needed to interpolate")
    intervals = np.diff(stamps) / 1e9
    nominal = float(np.median(intervals))
    dropped = int(np.maximum(np.rint(intervals / nominal) - 1, 0).sum())
    return CleanStream(stream, stamps, values, out_of_order, int(np.count_nonzero(~first)),
                       nominal, dropped)


def output_clock(streams: list[CleanStream], rate_hz: float, where: str) -> tuple[int, np.ndarray]:
    """Start (ns, absolute) and sample times (s since start) over the span all streams cover."""
    start = max(int(s.stamps_ns[0]) for s in streams)
    end = min(int(s.stamps_ns[-1]) for s in streams)
    if end <= start:
        spans = {s.raw.name: [s.stamps_ns[0] / 1e9, s.stamps_ns[-1] / 1e9] for s in streams}
        raise BagError(f"{where}: the streams do not overlap in time (spans in s: {spans}); "
                       f"check that they share one clock")
    # 1e-9 s slack: a last message exactly on a sample must keep that sample
    count = int(np.floor((end - start) / 1e9 * rate_hz + 1e-9)) + 1
    if count < 2:
        raise BagError(f"{where}: the streams overlap for {(end - start) / 1e9:.6f} s, less than "
                       f"one output period at {rate_hz:g} Hz")
    return start, np.arange(count) / rate_hz


def gap_threshold_s(stream: CleanStream, rate_hz: float, gap_periods: float) -> float:
    return gap_periods * max(stream.nominal_period_s, 1.0 / rate_hz)


def resample(stream: CleanStream, start_ns: int, times_s: np.ndarray, threshold_s: float
             ) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
    """Interpolate one stream at ``times_s`` (s since ``start_ns``, inside the stream's span).

    Returns the (len(times_s), k) values, a boolean mask of the samples strictly inside one of the
    stream's gaps, and the gaps as (start, end) in s since ``start_ns``.
    """
    t = (stream.stamps_ns - start_ns) / 1e9
    left = np.clip(np.searchsorted(t, times_s, side="right") - 1, 0, len(t) - 2)
    weight = ((times_s - t[left]) / (t[left + 1] - t[left]))[:, None]
    values = stream.values[left] * (1.0 - weight) + stream.values[left + 1] * weight
    is_gap = np.diff(t) > threshold_s
    inside = is_gap[left] & (times_s > t[left]) & (times_s < t[left + 1])
    gaps = [(float(t[i]), float(t[i + 1])) for i in np.flatnonzero(is_gap)]
    return values, inside, gaps
