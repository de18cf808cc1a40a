"""Export: ONNX step graph + JSON, run back with ONNX Runtime, equal to the Python estimator."""

from __future__ import annotations

import json

import numpy as np
import pytest

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.runtime.export import ExportError, export, run_export
from psmforce.estimators.data.hybrid_inputs import hybrid_columns, prior_to_json
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.identification.prior import InternalForcePrior
from tests.estimators.test_streaming import (INSERTION, model_and_scalers, one_thread, recording)  # noqa: F401
from tests.checkpoints import untrained_checkpoint


def _checkpoint(tmp_path, use_prior: bool):
    features, base = hybrid_columns(use_prior)
    model, xs, ys = model_and_scalers(len(features))
    return ck.TrainedModel(
        "hybrid", {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8},
        features, xs, ys, base, model=model,
        derivation="prior" if use_prior else "none",
        # the identification prior with its default (physical) parameters, as a fit would save it
        prior_json=prior_to_json(InternalForcePrior(converged=True, insertion=INSERTION))
        if use_prior else None,
        provenance={"seed": 3}).save(tmp_path / "hybrid.pt")


@pytest.mark.parametrize("use_prior", [True, False])
def test_export_round_trip_matches_python_estimator(tmp_path, use_prior):
    path = _checkpoint(tmp_path, use_prior)
    summary = export(path, tmp_path / "out")
    assert summary["onnx_vs_torch_max_abs_diff"] < 1e-5
    spec = json.loads((tmp_path / "out" / "hybrid.json").read_text())
    assert spec["features"] == list(hybrid_columns(use_prior)[0])
    assert spec["provenance"] == {"seed": 3} and spec["window"] == 2 * 7 + 1
    assert (spec["prior"] is not None) == use_prior
    assert spec["format_version"] == 3 and spec["graph"]["state"] == [  # the model's own state
        {"name": "keys", "shape": [2, 1, 8, 16], "dtype": "float32"},
        {"name": "values", "shape": [2, 1, 8, 16], "dtype": "float32"},
        {"name": "n_valid", "shape": [1], "dtype": "int64"}]
    assert not list((tmp_path / "out").glob("*.part"))
    frame = recording(150)
    exported = run_export(tmp_path / "out", frame)
    est = StreamingEstimator.from_checkpoint(path)
    python = np.stack([est.step(r).force_hex10 for r in frame.to_dict("records")])
    assert np.abs(exported - python).max() < 1e-5


def test_export_refuses_other_models_and_foreign_folders(tmp_path):
    path = untrained_checkpoint("lstm", tmp_path / "lstm.pt")
    with pytest.raises(ExportError, match="'lstm' model, which does not stream"):
        export(path, tmp_path / "out")
    assert not (tmp_path / "out").exists()   # refused: no folder left behind
    with pytest.raises(ExportError, match="no readable hybrid.json"):
        run_export(tmp_path / "nothing", recording(5))


@pytest.mark.parametrize("use_prior", [False])
def test_an_export_into_a_folder_another_command_holds_is_refused(tmp_path, use_prior):
    """Issue 46, class 6: two exports into one folder both succeeded, and one was lost."""
    from psmforce.core.files import OutputError, locked_folder
    path = _checkpoint(tmp_path, use_prior)
    with locked_folder(tmp_path / "out"):
        with pytest.raises(OutputError, match="another command is writing this folder"):
            export(path, tmp_path / "out")
        assert [p.name for p in (tmp_path / "out").iterdir()] == [".psmforce.lock"]
    export(path, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["hybrid.json",
                                                                    "hybrid_step.onnx"]


def test_a_graph_replaced_under_its_export_is_refused_before_it_runs(tmp_path):
    """Issue 46, class 10: an export whose graph was replaced (and its digest recomputed) made
    run_export raise ONNX Runtime's own errors or hang; the graph's inputs and outputs are now
    checked against the export's metadata first."""
    from psmforce.core.integrity import seal, sha256_bytes
    from psmforce.estimators.runtime.steppers import step_onnx_bytes
    export(_checkpoint(tmp_path, False), tmp_path / "out")
    spec = json.loads((tmp_path / "out" / "hybrid.json").read_text())
    other, _, _ = model_and_scalers(len(spec["features"]) + 2)  # a graph of more inputs
    graph = step_onnx_bytes(other)
    (tmp_path / "out" / "hybrid_step.onnx").write_bytes(graph)
    resealed = seal({**{k: v for k, v in spec.items() if k != "sha256"},
                     "onnx_sha256": sha256_bytes(graph)})
    (tmp_path / "out" / "hybrid.json").write_text(json.dumps(resealed))
    with pytest.raises(ExportError, match="the graph's input x is tensor.float. .*the export says"):
        run_export(tmp_path / "out", recording(20))


def test_the_runner_refuses_a_recording_whose_time_runs_backwards(tmp_path):
    """Issue 46, class 10: the stream flags a step back in time; the batch runner accepted it."""
    export(_checkpoint(tmp_path, False), tmp_path / "out")
    frame = recording(20)
    frame.loc[10, "time"] = frame.loc[3, "time"]
    with pytest.raises(ExportError, match="column time row 10: time does not increase"):
        run_export(tmp_path / "out", frame)
