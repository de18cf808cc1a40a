"""Checkpoints carry a SHA-256 of their weights; corrupt, empty or foreign files are refused in
one line naming the file (issue 14, items 5 and 6)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from hybrid import checkpoint as ck
from hybrid.data import Scaler
from hybrid.recipes import build_model
from psmforce.cli import main

torch.set_num_threads(1)
FEATURES = ("fx", "fy", "fz", "tx")


def _saved(tmp_path):
    torch.manual_seed(0)
    model = build_model("fcn", len(FEATURES))
    scaler = Scaler(np.zeros(len(FEATURES), np.float32), np.ones(len(FEATURES), np.float32))
    target = Scaler(np.zeros(3, np.float32), np.ones(3, np.float32))
    path = ck.TrainedModel("fcn", {}, FEATURES, scaler, target, model=model).save(
        tmp_path / "m.pt")
    return path, model


def test_checksum_is_stored_and_a_byte_changed_in_the_weights_is_refused(tmp_path):
    path, model = _saved(tmp_path)
    meta = json.loads(torch.load(path, weights_only=True)["meta"])
    assert meta["format_version"] == ck.FORMAT_VERSION == 2
    assert meta["weights_sha256"] == ck.weights_sha256(model.state_dict())
    ck.load_checkpoint(path)  # intact: loads
    # overwrite 8 bytes inside the largest tensor's stored data (the zip stores it uncompressed)
    name, tensor = max(model.state_dict().items(), key=lambda kv: kv[1].numel())
    raw = path.read_bytes()
    where = raw.find(tensor.detach().numpy().tobytes()[:64])
    assert where > 0, f"{name}'s bytes not found in the file"
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(raw[:where + 16] + b"\x7f" * 8 + raw[where + 24:])
    with pytest.raises(ck.CheckpointError, match="do not match their SHA-256") as err:
        ck.load_checkpoint(corrupt)
    assert str(corrupt) in str(err.value)


def test_version_1_checkpoints_without_checksum_still_load(tmp_path):
    path, _ = _saved(tmp_path)
    payload = torch.load(path, weights_only=True)
    meta = json.loads(payload["meta"])
    del meta["weights_sha256"]
    payload["meta"] = json.dumps({**meta, "format_version": 1})
    torch.save(payload, tmp_path / "v1.pt")
    assert ck.load_checkpoint(tmp_path / "v1.pt").features == FEATURES


@pytest.mark.parametrize("content, reason", [
    (b"", "empty file"),
    (b"hello, this is a text file\n", "corrupt or not a psmforce checkpoint"),
    (b"[1, 2, 3]", "corrupt or not a psmforce checkpoint")])
def test_empty_or_text_file_is_refused_in_one_line_naming_it(tmp_path, capsys, content, reason):
    bad = tmp_path / "model.pt"
    bad.write_bytes(content)
    with pytest.raises(ck.CheckpointError, match=reason) as err:
        ck.load_checkpoint(bad)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)
    out = tmp_path / "onnx"
    assert main(["export", str(bad), "--out", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and reason in lines[0]
    assert not out.exists()


def test_a_payload_without_tensors_is_refused(tmp_path):
    path, _ = _saved(tmp_path)
    payload = torch.load(path, weights_only=True)
    payload["state_dict"] = {"w": 3}
    torch.save(payload, tmp_path / "odd.pt")
    with pytest.raises(ck.CheckpointError, match="not a dict of tensors"):
        ck.load_checkpoint(tmp_path / "odd.pt")
