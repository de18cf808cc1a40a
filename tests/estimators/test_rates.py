"""Rates: the checkpoint and the export record the training rate, old files read as 100 Hz, a
stream at a whole multiple of it is decimated causally and answered at its own rate, any other
stream refused in one line."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
import torch

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.runtime.export import export
from psmforce.estimators.data.hybrid_inputs import hybrid_columns
from psmforce.core.integrity import seal
from psmforce.estimators.data.rates import (DEFAULT_SAMPLE_RATE_HZ, AntiAlias, RateError,
                                            decimation_factor, recording_rate_hz, trials_rate_hz)
from psmforce.estimators.runtime.streaming import Flags, StreamingError, StreamingEstimator
from tests.estimators.test_streaming import (StandInPrior, model_and_scalers, one_thread, recording)  # noqa: F401

CONFIG = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}


def _checkpoint(path, rate_hz=None):
    features, base = hybrid_columns(use_prior=False)
    model, xs, ys = model_and_scalers(len(features))
    return ck.TrainedModel("hybrid", CONFIG, features, xs, ys, base, model=model,
                           sample_rate_hz=rate_hz).save(path)


def _rewrite(path, version=None, **changes):
    """Rewrite a checkpoint's metadata: ``changes`` (None removes a field), sealed again
    (:mod:`psmforce.core.integrity`), or as a version 2 file (written before the envelope)."""
    payload = torch.load(path, weights_only=True)
    meta = {k: v for k, v in json.loads(payload["meta"]).items() if k != "sha256"}
    meta = {k: v for k, v in {**meta, **changes}.items() if v is not None}
    if version == 2:
        meta["format_version"] = 2
    else:
        meta = seal(meta)
    payload["meta"] = json.dumps(meta)
    torch.save(payload, path)


def test_checkpoint_and_export_record_the_rate_and_old_files_read_as_100_hz(tmp_path):
    path = _checkpoint(tmp_path / "k.pt", 1000.0)
    assert ck.load_checkpoint(path).sample_rate_hz == 1000.0
    export(path, tmp_path / "out")
    assert json.loads((tmp_path / "out" / "hybrid.json").read_text())["sample_rate_hz"] == 1000.0
    assert StreamingEstimator.from_checkpoint(path).rate_hz == 1000.0
    _rewrite(path, version=2, sample_rate_hz=None)  # a file from before the field, upgraded
    ck.upgrade_checkpoint(path, tmp_path / "upgraded.pt")
    assert ck.load_checkpoint(tmp_path / "upgraded.pt").sample_rate_hz == DEFAULT_SAMPLE_RATE_HZ
    assert DEFAULT_SAMPLE_RATE_HZ == 100.0
    unknown = _checkpoint(tmp_path / "u.pt")  # a setup that did not know its rate: null
    assert ck.load_checkpoint(unknown).sample_rate_hz == 100.0


@pytest.mark.parametrize("bad", [-1.0, 0, "fast", True])
def test_a_checkpoint_with_a_rate_that_is_not_a_rate_is_refused(tmp_path, bad):
    path = _checkpoint(tmp_path / "k.pt", 100.0)
    _rewrite(path, sample_rate_hz=bad)
    with pytest.raises(ck.CheckpointError, match="sample_rate_hz"):
        ck.load_checkpoint(path)


def test_a_stream_at_a_rate_the_model_cannot_serve_is_refused_in_one_line(tmp_path):
    path = _checkpoint(tmp_path / "k.pt", 100.0)
    for rate in (150.0, 50.0, 1234.0):
        with pytest.raises(StreamingError) as err:
            StreamingEstimator.from_checkpoint(path, input_rate_hz=rate)
        assert "whole multiple" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(StreamingError, match="trained at 100 Hz"):
        StreamingEstimator.from_checkpoint(path, rate_hz=1000.0)
    assert StreamingEstimator.from_checkpoint(path, input_rate_hz=1000.0).decimation == 10
    assert StreamingEstimator.from_checkpoint(path, input_rate_hz=999.6).decimation == 10
    assert decimation_factor(100.0, 100.0) == 1
    with pytest.raises(RateError, match="input_rate_hz"):
        decimation_factor(float("nan"), 100.0)


def _estimator(input_rate_hz, **options):
    features, base = hybrid_columns(use_prior=True)
    model, xs, ys = model_and_scalers(len(features))
    return StreamingEstimator(model, features, xs, ys, base, StandInPrior(), rate_hz=100.0,
                              input_rate_hz=input_rate_hz, **options)


def _fast(n, factor, seed=0):
    """A recording at ``factor`` x 100 Hz (the 100 Hz generator's signals on a finer clock)."""
    frame = recording(n, seed)
    frame["time"] = np.arange(n) / (100.0 * factor)
    return frame


@pytest.mark.parametrize("post_filter", ["none", "lowpass"])
def test_a_1khz_stream_steps_the_network_every_tenth_sample_and_equals_the_batch_path(
        post_filter):
    est = _estimator(1000.0, post_filter=post_filter, backend="numpy")
    steps = []
    step = est._net.step
    est._net.step = lambda x: (steps.append(1), step(x))[1]
    frame = _fast(600, 10)
    streamed = np.stack([est.step(r).force_hex10 for r in frame.to_dict("records")])
    assert len(steps) == 60  # samples 0, 10, 20, ...: one network step per 10 inputs
    batch = _estimator(1000.0, post_filter=post_filter).predict_recording(frame)
    np.testing.assert_allclose(streamed, batch, atol=2e-5)
    assert np.abs(np.diff(streamed[:, 0])).max() > 0  # answered, not held, between steps


def test_at_1khz_each_network_step_sees_the_anti_aliased_sample_a_100hz_stream_would_carry():
    """Reference built here: the 1 kHz signals low-passed (AntiAlias, checked against scipy
    below), every 10th kept, streamed at 100 Hz: the 1 kHz answers on the network's steps
    equal it, and the warm-up lasts ``window`` network steps."""
    fast = _fast(400, 10, seed=2)
    est = _estimator(1000.0)
    outs = [est.step(r) for r in fast.to_dict("records")]
    columns = list(est.columns)
    slow = fast.copy()
    slow[columns] = AntiAlias(len(columns), 10, 100.0).offline(fast[columns].to_numpy())
    slow = slow.iloc[::10].assign(time=np.arange(40) / 100.0)
    at_100 = [o.force_hex10 for o in map(_estimator(100.0).step, slow.to_dict("records"))]
    np.testing.assert_allclose(np.stack([o.force_hex10 for o in outs[::10]]), at_100, atol=1e-6)
    assert np.abs(np.stack(at_100) - np.stack([o.force_hex10 for o in outs[5::10]])).max() > 1e-3
    window = est.window
    assert outs[10 * (window - 1) - 1].flags & 1 and not outs[10 * (window - 1)].flags & 1


def test_gaps_count_input_samples_and_the_lag_is_stated():
    est = _estimator(1000.0)
    rows = _fast(50, 10).to_dict("records")
    for r in rows[:20]:
        est.step(r)
    assert not est.step(rows[25]).flags & 16   # 4 samples (4 ms) missing: bridged
    assert est.step(rows[40]).flags & 16       # 14 missing: a gap, a new warm-up
    # 2nd-order Butterworth at 40 Hz: sqrt(2) / (2 pi 40) s as an analog filter (the digital
    # one at 1 kHz within 1 %), plus a hold of 4.5 ms on average
    assert est.lag_s() == pytest.approx(np.sqrt(2) / (2 * np.pi * 40) + 0.0045, rel=1e-2)
    assert _estimator(100.0).lag_s() == 0.0


def _stream_with_bases(est, rows, advance=False):
    """Each answer's force and the physics base it carries (N, HEX10 frame), and its flags;
    ``advance``: call :meth:`StreamingEstimator.advance` after every answer, as a node does."""
    forces, bases, flags = [], [], []
    for r in rows:
        out = est.step(r)
        forces.append(out.force_hex10)
        bases.append(est.inputs.base.copy())
        flags.append(out.flags)
        if advance:
            est.advance()
    return np.stack(forces), np.stack(bases), np.array(flags)


def test_the_network_after_the_answer_holds_the_step_before_one_sample_longer():
    """``network_after_answer``: the sample the network is due on is answered with the
    previous step's residual, every other answer is unchanged, the step count is the same,
    the batch path follows it, and one input period of lag is stated."""
    rows = _fast(600, 10).to_dict("records")
    before = _estimator(1000.0, backend="numpy")
    force_b, base_b, flags_b = _stream_with_bases(before, rows)
    after = _estimator(1000.0, backend="numpy", network_after_answer=True)
    steps = []
    step = after._net.step
    after._net.step = lambda x: (steps.append(1), step(x))[1]
    force_a, base_a, flags_a = _stream_with_bases(after, rows, advance=True)
    assert len(steps) == 60  # the same steps, later
    np.testing.assert_allclose(base_a, base_b, atol=1e-12)  # the physics is not deferred
    residual_b, residual_a = force_b - base_b, force_a - base_a
    ticks = np.arange(10, 600, 10)
    others = np.setdiff1d(np.arange(600), ticks)
    np.testing.assert_allclose(residual_a[others], residual_b[others], atol=1e-9)
    np.testing.assert_allclose(residual_a[ticks], residual_b[ticks - 1], atol=1e-9)
    assert np.abs(residual_a[ticks] - residual_b[ticks]).min() > 0  # it is the step before's
    # the first sample steps before its answer: there is no earlier residual to hold
    np.testing.assert_allclose(force_a[0], force_b[0], atol=1e-12)
    batch = _estimator(1000.0, network_after_answer=True).predict_recording(_fast(600, 10))
    np.testing.assert_allclose(force_a, batch, atol=2e-5)
    # whether or when the node calls advance, the estimates are the same
    lazy, _, _ = _stream_with_bases(_estimator(1000.0, backend="numpy",
                                               network_after_answer=True), rows)
    np.testing.assert_array_equal(lazy, force_a)
    assert after.lag_s() == pytest.approx(before.lag_s() + 1e-3, abs=1e-12)
    # warm-up counts the steps the residual has seen: one sample longer here
    last_warm = 10 * (before.window - 1) - 1
    assert flags_b[last_warm] & 1 and not flags_b[last_warm + 1] & 1
    assert flags_a[last_warm + 1] & 1 and not flags_a[last_warm + 2] & 1


def test_the_network_after_the_answer_changes_nothing_without_decimation_or_after_a_gap():
    rows = _fast(300, 1).to_dict("records")
    plain, _, _ = _stream_with_bases(_estimator(100.0, backend="numpy"), rows)
    deferred = _estimator(100.0, backend="numpy", network_after_answer=True)
    same, _, _ = _stream_with_bases(deferred, rows, advance=True)
    np.testing.assert_array_equal(same, plain)  # at D = 1 each answer needs its own step
    assert deferred.lag_s() == 0.0
    rows = _fast(120, 10).to_dict("records")
    rows = rows[:43] + rows[60:]  # 16 samples missing at 1 kHz: a gap, a restart
    before, _, flags = _stream_with_bases(_estimator(1000.0, backend="numpy"), rows)
    after, _, _ = _stream_with_bases(_estimator(1000.0, backend="numpy",
                                                network_after_answer=True), rows)
    restart = int(np.flatnonzero(flags & Flags.GAP)[0])
    assert restart == 43
    np.testing.assert_allclose(after[restart], before[restart], atol=1e-12)  # steps first


def test_anti_alias_step_equals_offline_and_attenuates_above_the_model_nyquist():
    rng = np.random.default_rng(1)
    values = rng.standard_normal((400, 4))
    online = AntiAlias(4, 10, 100.0)
    stepped = np.stack([online.step(v).copy() for v in values])
    np.testing.assert_allclose(stepped, AntiAlias(4, 10, 100.0).offline(values), atol=1e-12)
    t = np.arange(2000) / 1000.0
    tone = np.sin(2 * np.pi * 200 * t)[:, None]  # 200 Hz: would alias onto 0 Hz at 100 Hz
    assert np.abs(AntiAlias(1, 10, 100.0).offline(tone)[500:]).max() < 0.1


def test_training_rate_is_measured_from_the_recordings():
    def trial(rate, n=50, name="a.csv"):
        return SimpleNamespace(path=name, frame=pd.DataFrame({"time": np.arange(n) / rate}))
    assert trials_rate_hz([trial(100.0), trial(100.0, 80)]) == pytest.approx(100.0)
    with pytest.raises(RateError, match="b.csv: sampled at 1000 Hz"):
        trials_rate_hz([trial(100.0), trial(100.0), trial(1000.0, name="b.csv")])
    with pytest.raises(RateError, match="strictly increasing"):
        recording_rate_hz([0.0, 0.0, 0.1])


# Issue 46, class 4: the rate is measured from the data at training, stored, and checked.

def _bench_at(tmp_path, name: str, time_scale: float, only: str | None = None):
    """A tiny bench whose recordings' times are multiplied by ``time_scale`` (0.5: 200 Hz;
    1000: the same data in milliseconds), all of them or the ``only`` one."""
    from psmforce.io.recording import read_recording, write_recording
    from psmforce.sim import simulate
    out = tmp_path / name
    simulate("automated", scale=0.005, seed=0, out=out)
    for path in sorted(out.rglob("*.csv")):
        if only is None or path.match(only):
            frame = read_recording(path)
            frame["time"] = frame["time"] * time_scale
            write_recording(frame, path)
    return out


@pytest.mark.slow
def test_training_records_the_datas_rate_and_finetuning_keeps_it(tmp_path):
    from psmforce.estimators.training.train import finetune, train
    fast = _bench_at(tmp_path, "fast", 0.5)
    train(fast, "fcn", tmp_path / "fast.pt", epochs=1)
    assert ck.load_checkpoint(tmp_path / "fast.pt").sample_rate_hz == pytest.approx(200.0)
    slow = _bench_at(tmp_path, "slow", 1.0)
    with pytest.raises(ValueError, match="sampled at 100 Hz, but .*fast.pt was trained at 200 Hz"):
        finetune(tmp_path / "fast.pt", slow, tmp_path / "tuned.pt", epochs=1)
    assert not (tmp_path / "tuned.pt").exists()


@pytest.mark.parametrize("time_scale, only, match", [
    (1000.0, None, r"outside \[1, 10000\] Hz: .*milliseconds or nanoseconds"),
    (1e9, None, r"outside \[1, 10000\] Hz"),
    (0.5, "*/Free/*", "a model is trained at one rate")])
def test_training_data_at_an_implausible_or_mixed_rate_is_refused(tmp_path, time_scale, only,
                                                                  match):
    from psmforce.estimators.training.train import train
    bench = _bench_at(tmp_path, "bench", time_scale, only)
    with pytest.raises(ValueError, match=match):
        train(bench, "fcn", tmp_path / "m.pt", epochs=1)
    assert not (tmp_path / "m.pt").exists()


def test_a_live_stream_rate_survives_a_repeated_or_backward_stamp_among_the_first():
    """Issue 47, item 4: one repeated or backward stamp among the first messages stopped the
    node (exit 2). It is set aside when the rate is measured, and flagged by the estimator."""
    from psmforce.estimators.data.rates import stream_rate_hz
    stamps = [10**18 + k * 10**6 for k in range(100)]  # 1 kHz
    stamps[40] = stamps[39]            # repeated
    stamps[60] = stamps[50]            # back in time
    stamps[70] = 0                     # unset
    assert stream_rate_hz(stamps) == pytest.approx(1000.0)
    with pytest.raises(RateError, match="distinct header stamps"):
        stream_rate_hz([10**18] * 60 + stamps[:40])
