"""A prior of the physics-only axes' own: on those axes every path (the streaming estimator
online and in batch, the evaluation's predict_trial, the export run back) answers the base
computed with it, while the network reads the checkpoint's prior and the other axes are the
hybrid's as without it; the field round-trips sealed, and what cannot honour it is refused."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import torch

from psmforce.core.integrity import seal
from psmforce.estimators.data.dataset import Dataset, Trial
from psmforce.estimators.data.hybrid_inputs import (BASE_COLUMNS, HEX10, HYBRID_FEATURES,
                                                    HybridInputError, add_prior_columns,
                                                    physics_base_problem, prior_to_json)
from psmforce.estimators.evaluation.evaluate import predict_trial
from psmforce.estimators.runtime.export import ExportError, export, run_export
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.training.remount import RemountError, recalibrate_checkpoint
from psmforce.identification.prior import NAMES
from tests.estimators.test_export import _checkpoint
from tests.estimators.test_streaming import (StandInPrior, model_and_scalers, one_thread,  # noqa: F401
                                             recording)


def _online(estimator, frame) -> np.ndarray:
    return np.stack([estimator.step(r).force_hex10 for r in frame.to_dict("records")])


def test_the_physics_axes_read_their_own_prior_and_the_network_its_own():
    """Fx (physics-only, its own prior) is HEX10 minus that prior's internal force exactly; Fy
    and Fz are what the estimator without the second prior gives, to the last bit."""
    frame, prior, own = recording(300), StandInPrior(seed=4), StandInPrior(seed=9)
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES))
    plain = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, prior,
                               physics_only_axes=("Fx",))
    both = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, prior,
                              physics_only_axes=("Fx",), physics_prior=own)
    plain_online, both_online = _online(plain, frame), _online(both, frame)
    expected_fx = frame["fx"].to_numpy() - own.predict(frame)[:, 0]
    np.testing.assert_allclose(both_online[:, 0], expected_fx, atol=1e-9)
    assert np.abs(both_online[:, 0] - plain_online[:, 0]).min() > 1e-3  # another prior
    np.testing.assert_array_equal(both_online[:, 1:], plain_online[:, 1:])
    np.testing.assert_allclose(both.predict_recording(frame), both_online, atol=1e-4)


def test_an_insertion_base_comes_from_the_own_prior_too():
    """On Fz the base is the insertion model's axial force: with an own prior, its model's."""
    class OtherInsertion(StandInPrior):
        def insertion_axial_force(self, frame):
            return 2.0 - 3.0 * frame["insertion_effort"].to_numpy(float)

        def predict_sample(self, values):
            return np.r_[self.A @ values[:4] + self.b, 2.0 - 3.0 * values[4]]

    frame, prior = recording(120), StandInPrior(seed=4)
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES))
    est = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, prior,
                             physics_only_axes=("Fz",), physics_prior=OtherInsertion(seed=4))
    np.testing.assert_allclose(_online(est, frame)[:, 2],
                               2.0 - 3.0 * frame["insertion_effort"].to_numpy(), atol=1e-9)


@pytest.mark.parametrize("axes, base, problem", [
    ((), BASE_COLUMNS, "at least one such axis"),
    (("Fx",), (), "needs a residual model"),
    (("Fx",), ("fx", "fy", "insertion_fz"), "do not come from a prior"),
    (("Fq",), BASE_COLUMNS, "do not come from a prior")])
def test_what_an_own_prior_cannot_answer_is_named(axes, base, problem):
    assert problem in physics_base_problem(base, axes)
    assert physics_base_problem(BASE_COLUMNS, ("Fx", "Fz")) is None


def test_an_own_prior_without_physics_axes_is_refused_by_the_stream():
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES))
    with pytest.raises(HybridInputError, match="at least one such axis"):
        StreamingEstimator(model, HYBRID_FEATURES, xs, ys, BASE_COLUMNS, StandInPrior(),
                           physics_prior=StandInPrior(seed=1))


def _with_own_prior(tmp_path) -> tuple[Path, Path]:
    """(the test checkpoint with Fx and Fy physics-only, the same with a prior of their own
    whose lateral offsets and cross-talk differ)."""
    path = _checkpoint(tmp_path, use_prior=True)
    record = ck.load_checkpoint(path)
    record.physics_only_axes = ("Fx", "Fy")
    plain = record.save(tmp_path / "plain.pt")
    prior = record.prior()
    params = prior.params.copy()
    for name, value in (("bias_fx", 0.3), ("bias_fy", -0.2), ("crosstalk_fy", 0.004)):
        params[NAMES.index(name)] = value
    record.physics_prior_json = prior_to_json(dataclasses.replace(prior, params=params))
    return plain, record.save(tmp_path / "own.pt")


def test_the_own_prior_round_trips_and_every_path_agrees(tmp_path):
    plain, own = _with_own_prior(tmp_path)
    record = ck.load_checkpoint(own)
    assert record.physics_prior_json is not None
    assert record.physics_prior_json != record.prior_json
    frame = recording(150)
    both_online = _online(StreamingEstimator.from_checkpoint(own), frame)
    plain_online = _online(StreamingEstimator.from_checkpoint(plain), frame)
    np.testing.assert_array_equal(both_online[:, 2], plain_online[:, 2])
    assert np.abs(both_online[:, :2] - plain_online[:, :2]).min() > 0.1
    expected = (frame[list(HEX10[:2])].to_numpy()
                - record.physics_prior().predict(frame)[:, :2])
    np.testing.assert_allclose(both_online[:, :2], expected, atol=1e-9)
    trial = Trial("t.csv", "Free", "test", frame.copy())
    add_prior_columns(Dataset(Path("."), [trial], {}), record.prior())
    evaluated = predict_trial(record, trial)
    warm = record.model.window
    np.testing.assert_allclose(evaluated[warm:], both_online[warm:], atol=1e-4)
    export(own, tmp_path / "out")
    spec = json.loads((tmp_path / "out" / "hybrid.json").read_text())
    assert spec["physics_prior"] == json.loads(record.physics_prior_json)
    assert any("physics_prior" in step for step in spec["pipeline"])
    assert np.abs(run_export(tmp_path / "out", frame) - both_online).max() < 1e-5


def _resealed(path: Path, out: Path, meta_change=None, payload_change=None) -> Path:
    """``path`` with its metadata and payload edited and sealed again, as a tool that forgets
    a rule would write it."""
    payload = torch.load(path, weights_only=True)
    meta = json.loads(payload["meta"])
    meta.pop("sha256")
    meta.update(meta_change or {})
    payload.update(payload_change or {})
    payload["meta"] = json.dumps(seal(meta))
    torch.save(payload, out)
    return out


def test_a_checkpoint_with_an_own_prior_that_cannot_hold_is_refused(tmp_path):
    plain, own = _with_own_prior(tmp_path)
    record = ck.load_checkpoint(own)
    record.physics_only_axes = ()
    with pytest.raises(ck.CheckpointError, match="at least one such axis"):
        record.save(tmp_path / "none.pt")
    assert not (tmp_path / "none.pt").exists()
    text = record.physics_prior_json
    edited = _resealed(own, tmp_path / "edited.pt",
                       payload_change={"physics_prior_json": text.replace("0.3", "0.4", 1)})
    with pytest.raises(ck.CheckpointError, match="physics-only axes' prior does not match"):
        ck.load_checkpoint(edited)
    dropped = _resealed(own, tmp_path / "dropped.pt", payload_change={"physics_prior_json": None})
    with pytest.raises(ck.CheckpointError, match="physics-only axes' prior does not match"):
        ck.load_checkpoint(dropped)
    garbage = "{\"format\": \"something else\"}"
    from psmforce.core.integrity import sha256_bytes
    foreign = _resealed(own, tmp_path / "foreign.pt",
                        meta_change={"physics_prior_sha256": sha256_bytes(garbage.encode())},
                        payload_change={"physics_prior_json": garbage})
    with pytest.raises(ck.CheckpointError, match="does not read as a prior"):
        ck.load_checkpoint(foreign)
    no_axes = _resealed(own, tmp_path / "no_axes.pt", meta_change={"physics_only_axes": []})
    with pytest.raises(ck.CheckpointError, match="corrupt checkpoint.*at least one such axis"):
        ck.load_checkpoint(no_axes)


def test_an_export_with_an_own_prior_that_cannot_hold_is_refused(tmp_path):
    _, own = _with_own_prior(tmp_path)
    export(own, tmp_path / "out")
    where = tmp_path / "out" / "hybrid.json"
    spec = json.loads(where.read_text())
    spec.pop("sha256")
    where.write_text(json.dumps(seal({**spec, "physics_only_axes": []})))
    with pytest.raises(ExportError, match="at least one such axis"):
        run_export(tmp_path / "out", recording(20))


def test_remount_refuses_a_checkpoint_with_two_priors(tmp_path):
    _, own = _with_own_prior(tmp_path)
    with pytest.raises(RemountError, match="calibrate the checkpoint it came from again"):
        recalibrate_checkpoint(own, tmp_path, tmp_path / "remounted.pt")
    assert not (tmp_path / "remounted.pt").exists()
