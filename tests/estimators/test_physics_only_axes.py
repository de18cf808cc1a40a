"""Physics-only axes: on the axes a checkpoint names, every path (the evaluation's predict_trial,
the streaming estimator online and in batch, the export run back) answers the base alone, the
network's residual not added; the field round-trips through the checkpoint and the export, and
what cannot honour it is refused."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from psmforce.core.integrity import seal
from psmforce.estimators.data.dataset import NO_BASE, Dataset, Trial
from psmforce.estimators.data.hybrid_inputs import (BASE_COLUMNS, HYBRID_FEATURES,
                                                    add_prior_columns, hybrid_columns)
from psmforce.estimators.evaluation.evaluate import predict_trial
from psmforce.estimators.runtime.export import ExportError, export, run_export
from psmforce.estimators.runtime.steppers import StreamingError
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.training.checkpoint import physics_only_problem, residual_gain
from tests.estimators.test_export import _checkpoint
from tests.estimators.test_streaming import (StandInPrior, model_and_scalers, one_thread,  # noqa: F401
                                             recording)

CONFIG = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}


def test_residual_gain_zeroes_exactly_the_named_axes():
    np.testing.assert_array_equal(residual_gain(), [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(residual_gain(("Fx", "Fy")), [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(residual_gain(("Fz",)), [1.0, 1.0, 0.0])


@pytest.mark.parametrize("axes, base, variance, problem", [
    (["Fq"], BASE_COLUMNS, False, "distinct axis names"),
    (["Fx", "Fx"], BASE_COLUMNS, False, "distinct axis names"),
    ("Fx", BASE_COLUMNS, False, "must be a list"),
    (["Fx"], (), False, "needs a residual model"),
    (["Fz"], (BASE_COLUMNS[0], BASE_COLUMNS[1], NO_BASE), False, "no base column"),
    (["Fy"], BASE_COLUMNS, True, "predicts its variance")])
def test_what_cannot_honour_physics_only_axes_is_named(axes, base, variance, problem):
    assert problem in physics_only_problem(axes, base, variance)
    assert physics_only_problem([], base, variance) is None


def _trial(frame, prior) -> Trial:
    """One recording as a test trial, the prior's columns added."""
    trial = Trial("t.csv", "Free", "test", frame.copy())
    add_prior_columns(Dataset(Path("."), [trial], {}), prior)
    return trial


def test_every_path_answers_the_base_alone_on_the_named_axes():
    """Streamed, batch and evaluated estimates agree; on Fx and Fy they are the compensated
    HEX10 (the base) exactly, on Fz the full hybrid's."""
    frame, prior = recording(300), StandInPrior(seed=4)
    frame[["ati_fx", "ati_fy", "ati_fz"]] = 0.0
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES))
    full = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, prior)
    off = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, prior,
                             physics_only_axes=("Fx", "Fy"))
    full_online = np.stack([full.step(r).force_hex10 for r in frame.to_dict("records")])
    off_online = np.stack([off.step(r).force_hex10 for r in frame.to_dict("records")])
    trial = _trial(frame, prior)
    base = trial.frame[list(BASE_COLUMNS)].to_numpy()
    np.testing.assert_allclose(off_online[:, :2], base[:, :2], atol=1e-9)
    np.testing.assert_allclose(off_online[:, 2], full_online[:, 2], atol=1e-12)
    assert np.abs(full_online[:, :2] - base[:, :2]).min() > 1e-3  # the residual was there
    np.testing.assert_allclose(off.predict_recording(frame), off_online, atol=1e-4)
    evaluated = predict_trial(ck.TrainedModel("hybrid", CONFIG, HYBRID_FEATURES, xs, ys,
                                              BASE_COLUMNS, model=model,
                                              physics_only_axes=("Fx", "Fy")), trial)
    warm = model.window
    np.testing.assert_allclose(evaluated[warm:], off_online[warm:], atol=1e-4)
    np.testing.assert_allclose(evaluated[:, :2], base[:, :2], atol=1e-9)


def test_the_field_round_trips_through_checkpoint_stream_and_export(tmp_path):
    path = _checkpoint(tmp_path, use_prior=True)
    record = ck.load_checkpoint(path)
    assert record.physics_only_axes == ()
    record.physics_only_axes = ("Fy",)
    record.save(tmp_path / "off.pt")
    loaded = ck.load_checkpoint(tmp_path / "off.pt")
    assert loaded.physics_only_axes == ("Fy",)
    stream = StreamingEstimator.from_checkpoint(tmp_path / "off.pt")
    assert stream.physics_only_axes == ("Fy",)
    frame = recording(150)
    python = np.stack([stream.step(r).force_hex10 for r in frame.to_dict("records")])
    full = StreamingEstimator.from_checkpoint(path)
    python_full = np.stack([full.step(r).force_hex10 for r in frame.to_dict("records")])
    export(tmp_path / "off.pt", tmp_path / "out")
    spec = json.loads((tmp_path / "out" / "hybrid.json").read_text())
    assert spec["physics_only_axes"] == ["Fy"]
    assert any("physics_only_axes" in step for step in spec["pipeline"])
    exported = run_export(tmp_path / "out", frame)
    assert np.abs(exported - python).max() < 1e-5
    np.testing.assert_allclose(python[:, [0, 2]], python_full[:, [0, 2]], atol=1e-12)
    assert np.abs(python[:, 1] - python_full[:, 1]).min() > 1e-3


def test_a_sealed_file_with_an_impossible_field_is_refused(tmp_path):
    """A checkpoint and an export whose physics_only_axes cannot be honoured (edited and
    re-sealed, as a tool that forgets the rule would write it) are refused at load, named."""
    path = _checkpoint(tmp_path, use_prior=False)
    export(path, tmp_path / "out")
    payload = torch.load(path, weights_only=True)
    meta = json.loads(payload["meta"])
    meta.pop("sha256")
    payload["meta"] = json.dumps(seal({**meta, "physics_only_axes": ["Fw"]}))
    torch.save(payload, tmp_path / "bad.pt")
    with pytest.raises(ck.CheckpointError, match="corrupt checkpoint.*physics_only_axes"):
        ck.load_checkpoint(tmp_path / "bad.pt")
    where = tmp_path / "out" / "hybrid.json"
    spec = json.loads(where.read_text())
    spec.pop("sha256")
    where.write_text(json.dumps(seal({**spec, "physics_only_axes": ["Fx", "Fx"]})))
    with pytest.raises(ExportError, match="physics_only_axes must be distinct"):
        run_export(tmp_path / "out", recording(20))


def test_save_and_the_stream_refuse_what_cannot_honour_it(tmp_path):
    features, _ = hybrid_columns(False)
    model, xs, ys = model_and_scalers(len(features))
    no_base = ck.TrainedModel("hybrid", CONFIG, features, xs, ys, (), model=model,
                              physics_only_axes=("Fx",))
    with pytest.raises(ck.CheckpointError, match="needs a residual model"):
        no_base.save(tmp_path / "x.pt")
    assert not (tmp_path / "x.pt").exists()
    variance, xs, ys = model_and_scalers(len(HYBRID_FEATURES), uncertainty=True)
    with pytest.raises(StreamingError, match="predicts its variance"):
        StreamingEstimator(variance, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, StandInPrior(),
                           physics_only_axes=("Fx",))
    record = ck.TrainedModel("hybrid", CONFIG, HYBRID_FEATURES, xs, ys, BASE_COLUMNS,
                             model=variance, physics_only_axes=("Fx",))
    frame = recording(50)
    with pytest.raises(ValueError, match="predicts its variance"):
        predict_trial(record, _trial(frame, StandInPrior()), with_std=True)
