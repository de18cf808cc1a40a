"""Checkpoints carry a SHA-256 of their weights and an envelope over their metadata; corrupt,
edited, empty or foreign files are refused in one line naming the file (issue 14, items 5 and 6;
issue 26, item 1)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.data.dataset import Scaler
from psmforce.estimators.networks.recipes import build_model
from psmforce.cli.main import main

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
    assert meta["format_version"] == ck.FORMAT_VERSION == 3
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


def _rewritten(tmp_path, path, edit, name="edited.pt"):
    """The checkpoint at ``path`` with its metadata passed through ``edit`` (in place)."""
    payload = torch.load(path, weights_only=True)
    meta = json.loads(payload["meta"])
    edit(meta)
    payload["meta"] = json.dumps(meta)
    torch.save(payload, tmp_path / name)
    return tmp_path / name


@pytest.mark.parametrize("field, edit", [
    ("features", lambda m: m.update(features=[m["features"][1], m["features"][0],
                                              *m["features"][2:]])),
    ("input_scaler", lambda m: m["input_scaler"].update(std=[1.0] * len(m["features"]),
                                                        mean=[0.5] * len(m["features"]))),
    ("target_scaler", lambda m: m["target_scaler"]["mean"].__setitem__(0, 3.0)),
    ("config", lambda m: m["config"].update(hidden=64)),
    ("provenance", lambda m: m["provenance"].update(data_dir="elsewhere")),
    ("derivation", lambda m: m.update(derivation="lstm")),
    ("base_columns", lambda m: m.update(base_columns=["fx", "fy", "fz"]))])
def test_a_checkpoint_with_one_metadata_field_changed_is_refused_naming_it(tmp_path, field, edit):
    path, _ = _saved(tmp_path)
    meta = json.loads(torch.load(path, weights_only=True)["meta"])
    assert "sha256" in meta and "prior_sha256" in meta
    edited = _rewritten(tmp_path, path, edit)
    with pytest.raises(ck.CheckpointError, match=f"changed: {field}") as err:
        ck.load_checkpoint(edited)
    assert str(edited) in str(err.value) and "\n" not in str(err.value)


def test_an_edited_prior_or_an_added_field_is_refused(tmp_path):
    path, _ = _saved(tmp_path)
    payload = torch.load(path, weights_only=True)
    payload["prior_json"] = '{"format": "psmforce-internal-force-prior"}'
    torch.save(payload, tmp_path / "prior.pt")
    with pytest.raises(ck.CheckpointError, match="prior does not match"):
        ck.load_checkpoint(tmp_path / "prior.pt")
    rate = _rewritten(tmp_path, path, lambda m: m.update(sample_rate_hz=1000.0), "rate.pt")
    with pytest.raises(ck.CheckpointError, match="changed: sample_rate_hz"):
        ck.load_checkpoint(rate)
    added = _rewritten(tmp_path, path, lambda m: m.update(note="trust me"))
    with pytest.raises(ck.CheckpointError, match="added: note"):
        ck.load_checkpoint(added)
    stripped = _rewritten(tmp_path, path, lambda m: m.pop("sha256"), "stripped.pt")
    with pytest.raises(ck.CheckpointError, match="carries no SHA-256 envelope"):
        ck.load_checkpoint(stripped)


@pytest.mark.parametrize("version", ["3", 3.0, True, None, [3]])
def test_a_format_version_that_is_not_an_integer_is_refused(tmp_path, version):
    path, _ = _saved(tmp_path)
    edited = _rewritten(tmp_path, path, lambda m: m.update(format_version=version))
    with pytest.raises(ck.CheckpointError, match="is not an integer") as err:
        ck.load_checkpoint(edited)
    assert str(edited) in str(err.value)


def _as_version_2(meta):
    for key in ("sha256", "prior_sha256"):
        meta.pop(key)
    meta["format_version"] = 2


def test_a_version_2_checkpoint_is_refused_naming_the_upgrade_and_the_upgrade_checks_it(
        tmp_path, capsys):
    """Issue 46, class 3: a version 3 file relabelled 2 once loaded with any edit unseen (swapped
    features, other scalers, another prior). Version 2 is refused with the one command that
    seals it; the upgrade checks what it can (here a collapsed scaler, repeated features) and
    writes version 3; version 1 stays refused."""
    path, _ = _saved(tmp_path)
    relabelled = _rewritten(tmp_path, path, lambda m: (m.update(features=["tx", "fz", "fy", "fx"]),
                                                       m.update(format_version=2)), "relabel.pt")
    with pytest.raises(ck.CheckpointError, match=r"version 2 has no checksum over its metadata"
                       r".*psmforce upgrade-checkpoint .*relabel.pt --out NEW.pt") as err:
        ck.load_checkpoint(relabelled)
    assert len(str(err.value).splitlines()) == 1
    v2 = _rewritten(tmp_path, path, _as_version_2, "v2.pt")
    for bad, match in ((lambda m: m["target_scaler"].update(std=[0, 1, 1]),
                        "target_scaler must be finite with std >= 1e-09 in float32"),
                       (lambda m: m.update(features=["fx", "fx", "fz", "tx"]),
                        "distinct column names")):
        with pytest.raises(ck.CheckpointError, match=match):
            ck.upgrade_checkpoint(_rewritten(tmp_path, v2, bad, "bad.pt"), tmp_path / "no.pt")
        assert not (tmp_path / "no.pt").exists()
    assert main(["upgrade-checkpoint", str(v2), "--out", str(tmp_path / "v3.pt")]) == 0
    assert "sealed" in capsys.readouterr().out
    upgraded = ck.load_checkpoint(tmp_path / "v3.pt")
    assert upgraded.features == FEATURES
    assert json.loads(torch.load(tmp_path / "v3.pt", weights_only=True)["meta"])[
        "format_version"] == 3
    v1 = _rewritten(tmp_path, v2, lambda m: (m.pop("weights_sha256"),
                                             m.update(format_version=1)), "v1.pt")
    for call in (ck.load_checkpoint, lambda f: ck.upgrade_checkpoint(f, tmp_path / "x.pt")):
        with pytest.raises(ck.CheckpointError, match="version 1 carries no checksum"):
            call(v1)


def test_the_trial_hashes_come_from_the_file_never_from_paths_it_names(tmp_path):
    """Issue 46, class 3: a provenance naming a data folder outside ``--data`` made evaluate read
    (or, for a pipe, hang on) files there to compute the hashes it should have recorded."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.csv").write_text("not yours to read")
    provenance = {"data_dir": str(outside), "train_trials": ["secret.csv"], "val_trials": []}
    assert ck.trial_hashes(provenance) == {}
    recorded = {"trial_sha256": {"train/a.csv": "ab" * 32, "train/b.csv": 3}}
    assert ck.trial_hashes(recorded) == {"train/a.csv": "ab" * 32}


@pytest.mark.parametrize("config, key", [
    ({"n_heads": 0}, "n_heads"), ({"n_heads": 3}, "n_heads must divide d_model"),
    ({"attention_window": 10 ** 7}, "attention_window"), ({"d_model": 0}, "d_model"),
    ({"attention_window": 4096, "n_layers": 16, "d_model": 512}, "attention_window too large")])
def test_a_version_2_checkpoint_asking_for_an_impossible_model_is_refused_before_building(
        tmp_path, monkeypatch, config, key):
    """A config read from a file is checked like one typed in, before any allocation (here by
    the upgrade, the one reader of version 2 files)."""
    path, _ = _saved(tmp_path)

    def edit(meta):
        _as_version_2(meta)
        meta.update(model="hybrid", config=config)
    edited = _rewritten(tmp_path, path, edit)
    built = []
    monkeypatch.setattr("psmforce.estimators.networks.causal.CausalTransformer.__init__",
                        lambda *a, **k: built.append(k))
    with pytest.raises(ck.CheckpointError, match=key) as err:
        ck.upgrade_checkpoint(edited, tmp_path / "upgraded.pt")
    assert str(edited) in str(err.value) and not built
    assert not (tmp_path / "upgraded.pt").exists()


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


@pytest.mark.parametrize("scaler, field", [
    ({"std": [1e-300, 1, 1]}, "std"), ({"std": [1e39, 1, 1]}, "std"),
    ({"mean": [1e39, 0, 0]}, "mean"), ({"std": [1e-12, 1, 1]}, "std")])
def test_scalers_are_checked_in_float32_the_dtype_they_are_used_in(tmp_path, scaler, field):
    """Issue 46, class 7: a std of 1e-300 passed a float64 check, became 0 in float32, and export
    wrote a folder its own runner refused (evaluate blamed the window length)."""
    from psmforce.core.integrity import seal
    path, _ = _saved(tmp_path)

    def edit(meta):
        meta["target_scaler"].update(scaler)
        meta.update(seal({k: v for k, v in meta.items() if k != "sha256"}))  # a careless tool
    edited = _rewritten(tmp_path, path, edit)
    with pytest.raises(ck.CheckpointError, match="target_scaler must be finite with std >= "
                                                 "1e-09 in float32"):
        ck.load_checkpoint(edited)
