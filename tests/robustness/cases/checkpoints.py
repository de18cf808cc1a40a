"""Bad input against checkpoints: damaged files, one metadata field edited, versions that are not integers, resealed nonsense."""

from __future__ import annotations

import json

from tests.robustness.harness import (Attempt, CHECKPOINT_DAMAGE, CHECKPOINT_EDITS, Case,
                                      edit_checkpoint, edit_csv, registrar, trial)


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- checkpoints -------------------------------------------------------------------------
    for damage, make in CHECKPOINT_DAMAGE.items():
        def checkpoint(s, d, make=make):
            path = d / "model.pt"
            make(s, path)
            return path

        def evaluate_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["evaluate", str(path), "--data", str(s.bench),
                                 "--out", str(d / "eval")], names=(str(path),))

        def finetune_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["finetune", str(path), "--data", str(s.bench), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(path),))

        def export_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["export", str(path), "--out", str(d / "onnx")],
                           names=(str(path),))

        def stream_with(s, d, checkpoint=checkpoint):
            from psmforce.estimators.runtime.streaming import StreamingEstimator
            path = checkpoint(s, d)
            return Attempt(call=lambda: StreamingEstimator.from_checkpoint(path),
                           names=(str(path),))
        found.append(Case("cli evaluate: checkpoint", damage, "REJECTED", evaluate_with))
        found.append(Case("cli finetune: checkpoint", damage, "REJECTED", finetune_with))
        found.append(Case("cli export: checkpoint", damage, "REJECTED", export_with))
        found.append(Case("api StreamingEstimator.from_checkpoint", damage, "REJECTED",
                          stream_with))

    @case("cli export: checkpoint", "an LSTM checkpoint (a model that does not stream)")
    def _(s, d):
        return Attempt(argv=["export", str(s.lstm), "--out", str(d / "onnx")],
                       names=(str(s.lstm),))

    @case("cli evaluate: options", "--out not empty")
    def _(s, d):
        (d / "eval").mkdir()
        (d / "eval" / "metrics.json").write_text("{}\n")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "eval")], names=("--out",))

    @case("cli evaluate: options", "--out is a file")
    def _(s, d):
        (d / "eval").write_text("")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "eval")], names=("--out",))

    @case("cli evaluate: dataset", "a test recording shorter than the evaluation start")
    def _(s, d):
        data = s.copy(d)
        bad = trial(data, "test", "Traction")
        edit_csv(bad, lambda f: f.iloc[:60])
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(bad.relative_to(data).as_posix(),))

    @case("cli evaluate: dataset", "no test split")
    def _(s, d):
        data = s.copy(d)
        meta = json.loads((data / "metadata.json").read_text())
        meta["trials"] = [e for e in meta["trials"] if e["split"] != "test"]
        (data / "metadata.json").write_text(json.dumps(meta))
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(data),))

    @case("cli evaluate: dataset", "interrupted simulate (no metadata.json)")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(data),))

    @case("cli evaluate: options", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "blocker" / "eval")], names=("--out",))

    @case("cli export: options", "--out is a file")
    def _(s, d):
        (d / "onnx").write_text("")
        return Attempt(argv=["export", str(s.hybrid), "--out", str(d / "onnx")],
                       names=("--out",))

    @case("cli finetune: dataset", "interrupted simulate (no metadata.json)")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                             "--out", str(d / "t.pt")], names=(str(data),))

    @case("cli export: options", "--out not empty")
    def _(s, d):
        (d / "onnx").mkdir()
        (d / "onnx" / "model.onnx").write_text("older\n")
        return Attempt(argv=["export", str(s.hybrid), "--out", str(d / "onnx")],
                       names=("--out",))

    @case("cli finetune: options", "--epochs 0")
    def _(s, d):
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(s.bench), "--epochs", "0",
                             "--out", str(d / "t.pt")], names=("--epochs",))

    @case("cli finetune: options", "--out is the folder itself")
    def _(s, d):
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(s.bench), "--epochs", "1",
                             "--out", str(d)], names=("--out",))

    # --- checkpoints: one field edited, a version that is not an integer, resealed nonsense --
    for damage, (edit, reseal) in CHECKPOINT_EDITS.items():
        def edited(s, d, edit=edit, reseal=reseal):
            return edit_checkpoint(s.hybrid, d / "model.pt", edit, reseal)

        def evaluate_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["evaluate", str(path), "--data", str(s.bench),
                                 "--out", str(d / "eval")], names=(str(path),))

        def export_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["export", str(path), "--out", str(d / "onnx")],
                           names=(str(path),))

        def finetune_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["finetune", str(path), "--data", str(s.bench), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(path),))

        def stream_with(s, d, edited=edited):
            from psmforce.estimators.runtime.streaming import StreamingEstimator
            path = edited(s, d)
            return Attempt(call=lambda: StreamingEstimator.from_checkpoint(path),
                           names=(str(path),))
        found.append(Case("cli evaluate: checkpoint metadata", damage, "REJECTED",
                          evaluate_with))
        found.append(Case("cli export: checkpoint metadata", damage, "REJECTED", export_with))
        found.append(Case("cli finetune: checkpoint metadata", damage, "REJECTED",
                          finetune_with))
        found.append(Case("api StreamingEstimator.from_checkpoint: metadata", damage,
                          "REJECTED", stream_with))

    def to_v2(meta, payload):
        meta.pop("sha256")
        meta.pop("prior_sha256")
        meta["format_version"] = 2

    @case("api load_checkpoint", "a version 2 file (previous format) is refused naming the upgrade")
    def _(s, d):
        from psmforce.estimators.training.checkpoint import load_checkpoint
        path = edit_checkpoint(s.hybrid, d / "v2.pt", to_v2)
        return Attempt(call=lambda: load_checkpoint(path), names=(str(path),))

    @case("cli upgrade-checkpoint", "a version 2 file is sealed as version 3", "HANDLED")
    def _(s, d):
        from psmforce.estimators.training.checkpoint import load_checkpoint
        path = edit_checkpoint(s.hybrid, d / "v2.pt", to_v2)

        def check(result):
            same = load_checkpoint(d / "v3.pt").features == load_checkpoint(s.hybrid).features
            return same, f"upgraded, features as written: {same}"
        return Attempt(argv=["upgrade-checkpoint", str(path), "--out", str(d / "v3.pt")],
                       check=check)

    for name, edit in (("features swapped", lambda m: m.update(features=m["features"][::-1])),
                       ("another target scaler", lambda m: m["target_scaler"].update(
                           mean=[9.0, 9.0, 9.0])),
                       ("a provenance naming files outside", lambda m: m.update(provenance={
                           "data_dir": "/etc", "train_trials": ["passwd"]}))):
        def relabelled(s, d, edit=edit):
            from psmforce.estimators.training.checkpoint import load_checkpoint

            def to_edited_v2(meta, payload):
                to_v2(meta, payload)
                edit(meta)
            path = edit_checkpoint(s.hybrid, d / "relabelled.pt", to_edited_v2)
            return Attempt(call=lambda: load_checkpoint(path), names=(str(path),))
        found.append(Case("api load_checkpoint", f"version 3 relabelled 2, {name}", "REJECTED",
                          relabelled))
    return found
