"""Bad input against the streaming estimator: malformed samples, timestamps that overflow its arithmetic."""

from __future__ import annotations

import numpy as np
import pandas as pd

from tests.robustness.harness import (Attempt, Case, RECOVERED_N, TIMESTAMPS, registrar,
                                      trial, warmed_up)


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- the streaming estimator -------------------------------------------------------------
    def warmed(estimates):
        """Index of the first estimate after the warm-up (held NaN until then)."""
        return next(k for k, e in enumerate(estimates) if np.isfinite(e.force_hex10).all())

    def streaming(name, corrupt, flag="INVALID_INPUT", expect="HANDLED"):
        """One corrupted sample in a clean stream: flagged, every estimate after the warm-up
        finite, every estimate farther than psmforce.experiments.stream_fuzzer.FAR_N from the clean
        stream's flagged, and the last ones back on the clean stream's."""
        def prepare(s, d):
            from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
            frame = pd.read_csv(trial(s.bench, "test", "Palpation"))
            rows = frame.to_dict("records")
            bad_at = 300

            def run():
                def stream(bad):
                    est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                    return [est.step(corrupt(dict(r)) if bad and k == bad_at else r)
                            for k, r in enumerate(rows)]
                return stream(False), stream(True)

            def check(result):
                from psmforce.experiments.stream_fuzzer import FAR_N
                clean, dirty = result
                flagged = dirty[bad_at].flags & Flags[flag]
                start = warmed(dirty)
                finite = all(np.isfinite(e.force_hex10).all() for e in dirty[start:])
                far_unflagged = sum(
                    1 for a, b in zip(clean[start:], dirty[start:])
                    if np.abs(a.force_hex10 - b.force_hex10).max() > FAR_N and not b.flags)
                after = max(np.abs(a.force_hex10 - b.force_hex10).max() for a, b in
                            zip(clean[-50:], dirty[-50:]))
                return (bool(flagged) and finite and not far_unflagged and after < RECOVERED_N,
                        f"flags {Flags(dirty[bad_at].flags)!r}, estimates finite {finite}, "
                        f"{far_unflagged} unflagged estimates over {FAR_N} N off, last 50 "
                        f"within {after:.2g} N of the clean stream's")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step", name, expect, prepare))

    streaming("roll_position 1e30", lambda r: {**r, "roll_position": 1e30})
    streaming("fz 1e39", lambda r: {**r, "fz": 1e39})
    streaming("jaw_velocity 1e39", lambda r: {**r, "jaw_velocity": 1e39})
    streaming("insertion_effort 1e20", lambda r: {**r, "insertion_effort": 1e20})
    streaming("insertion_effort 1e4 spike", lambda r: {**r, "insertion_effort": 1e4})
    streaming("NaN yaw_position", lambda r: {**r, "yaw_position": float("nan")})
    streaming("time None", lambda r: {**r, "time": None})
    streaming("text value", lambda r: {**r, "fx": "abc"})
    streaming("a column missing", lambda r: {k: v for k, v in r.items() if k != "fy"})
    streaming("time 1 s backwards", lambda r: {**r, "time": r["time"] - 1.0}, "TIME_BACKWARDS")
    streaming("time inf", lambda r: {**r, "time": float("inf")})
    streaming("a list, not a mapping", lambda r: list(r.values()))
    streaming("hex10_overload 'yes'", lambda r: {**r, "hex10_overload": "yes"})

    @case("api StreamingEstimator.step", "a 5 s gap: flagged, the stream restarts", "HANDLED")
    def _(s, d):
        from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
        rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")

        def run():
            est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
            return [est.step({**r, "time": r["time"] + (5.0 if k >= 300 else 0.0)})
                    for k, r in enumerate(rows)]

        def check(estimates):
            after = estimates[300]
            finite = all(np.isfinite(e.force_hex10).all() for e in estimates[warmed(estimates):])
            return (bool(after.flags & Flags.GAP) and finite,
                    f"flags after the gap {Flags(after.flags)!r}, estimates finite {finite}")
        return Attempt(call=run, check=check)

    @case("api StreamingEstimator", "rate_hz nan")
    def _(s, d):
        from psmforce.estimators.runtime.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.hybrid,
                                                                       rate_hz=float("nan")),
                       names=("rate_hz",))

    @case("api StreamingEstimator", "max_gap_samples -1")
    def _(s, d):
        from psmforce.estimators.runtime.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.hybrid,
                                                                       max_gap_samples=-1),
                       names=("max_gap_samples",))

    @case("api StreamingEstimator", "an LSTM checkpoint (a model that does not stream)")
    def _(s, d):
        from psmforce.estimators.runtime.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.lstm),
                       names=(str(s.lstm),))

    # --- the stream: timestamps that overflow its arithmetic are flagged, never raised --------
    for name, (value, flag) in TIMESTAMPS.items():
        def timestamp(s, d, value=value, flag=flag):
            from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
            rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")

            def run():
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                return [est.step({**r, "time": value} if k == 300 else r)
                        for k, r in enumerate(rows)]

            def check(estimates):
                odd = estimates[300]
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                last = estimates[-1]
                ok = (bool(odd.flags & Flags[flag]) and finite
                      and not last.flags & Flags.INVALID_INPUT)
                return ok, (f"flags at the odd sample {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: timestamp", name, "HANDLED", timestamp))

    # --- the stream's timestamps: flagged, never raised -----------------------------------
    def stream_case(name, times, flag, at=300, input_rate_hz=None, expect_finite=True):
        def prepare(s, d):
            from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
            rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")
            period = 1.0 / (input_rate_hz or 100.0)
            clean = [r["time"] if input_rate_hz is None else k * period
                     for k, r in enumerate(rows)]
            stamps = times(clean)

            def run():
                options = {} if input_rate_hz is None else {"input_rate_hz": input_rate_hz}
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass",
                                                         **options)
                return [est.step(r, time=t) for r, t in zip(rows, stamps)]

            def check(estimates):
                odd = estimates[at]
                flagged = bool(odd.flags & Flags[flag])
                if not expect_finite:  # every later sample flagged, none raised
                    rest = all(e.flags & (Flags.TIME_BACKWARDS | Flags.GAP)
                               for e in estimates[at:])
                    return flagged and rest, (f"flags at sample {at} {Flags(odd.flags)!r}, "
                                              f"every later one flagged {rest}")
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                last = estimates[-1]
                ok = flagged and finite and not last.flags & Flags.INVALID_INPUT
                return ok, (f"flags at sample {at} {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: timestamp", name, "HANDLED", prepare))

    def one(value):
        def times(clean):
            return [value if k == 300 else t for k, t in enumerate(clean)]
        return times

    stream_case("time NaN", one(float("nan")), "INVALID_INPUT")
    stream_case("time -inf", one(float("-inf")), "INVALID_INPUT")
    stream_case("time numpy 1e307", one(np.float64(1e307)), "GAP")
    stream_case("time a numpy array of one value", one(np.array([1e307])), "GAP")
    stream_case("time 'abc' (text)", one("abc"), "INVALID_INPUT")
    stream_case("time 1e307 at 1 kHz in (decimated x10)", one(1e307), "GAP",
                input_rate_hz=1000.0)
    stream_case("time NaN at 1 kHz in (decimated x10)", one(float("nan")), "INVALID_INPUT",
                input_rate_hz=1000.0)
    stream_case("clock past float resolution from sample 300 (1e300 + k dt)",
                lambda clean: [t if k < 300 else 1e300 + t for k, t in enumerate(clean)],
                "GAP", expect_finite=False)

    def array_case(name, corrupt):
        def prepare(s, d):
            from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
            frame = pd.read_csv(trial(s.bench, "test", "Palpation"))

            def run():
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                values = frame[list(est.columns)].to_numpy(np.float64)
                return [est.step(corrupt(x) if k == 300 else x, time=t)
                        for k, (x, t) in enumerate(zip(values, frame["time"]))]

            def check(estimates):
                odd, last = estimates[300], estimates[-1]
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                ok = (bool(odd.flags & Flags.INVALID_INPUT) and finite
                      and not last.flags & Flags.INVALID_INPUT)
                return ok, (f"flags at sample 300 {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: array sample", name, "HANDLED",
                          prepare))

    array_case("complex dtype (numpy would drop the imaginary part)", lambda x: x + 0j)
    array_case("text dtype", lambda x: x.astype(str))
    array_case("bool dtype", lambda x: x > 0)
    array_case("one value short", lambda x: x[:-1])
    array_case("two-dimensional", lambda x: x[None, :])
    return found
