"""Bad input against datasets: whole or refused, and the data sanity checks before learning."""

from __future__ import annotations

import contextlib
import io
import json
import shutil

from tests.robustness.harness import Attempt, Case, edit_csv, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- datasets: whole or refused ---------------------------------------------------------
    def dataset_case(name, damage, expect="REJECTED"):
        def prepare(s, d):
            data = s.copy(d)
            named = damage(data)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(named or str(data),))
        found.append(Case("cli train: dataset", name, expect, prepare))

    def metadata(text):
        def damage(data):
            (data / "metadata.json").write_text(text)
            return str(data / "metadata.json")
        return damage

    def meta_trials(edit):
        def damage(data):
            meta = json.loads((data / "metadata.json").read_text())
            meta["trials"] = edit(meta["trials"])
            (data / "metadata.json").write_text(json.dumps(meta))
            return str(data / "metadata.json")
        return damage

    dataset_case("interrupted simulate (no metadata.json)",
                 lambda data: (data / "metadata.json").unlink())
    dataset_case("metadata.json zero bytes", metadata(""))
    dataset_case("metadata.json invalid JSON", metadata("{trials: ["))
    dataset_case("metadata.json a list", metadata("[1, 2]"))
    dataset_case("metadata trials []", meta_trials(lambda t: []))
    dataset_case("metadata trial without path",
                 meta_trials(lambda t: [{k: v for k, v in e.items() if k != "path"} for e in t]))
    dataset_case("metadata trial path outside the folder",
                 meta_trials(lambda t: [{**t[0], "path": "../../etc/passwd"}] + t[1:]))
    dataset_case("metadata trial path a number",
                 meta_trials(lambda t: [{**t[0], "path": 3}] + t[1:]))

    def listed_missing(data):
        path = trial(data)
        path.unlink()
        return str(path)
    dataset_case("a listed recording deleted", listed_missing)
    def no_train_split(data):
        meta_trials(lambda t: [e for e in t if e["split"] != "train"])(data)
        return str(data)
    dataset_case("no train split", no_train_split)

    def no_targets(data):
        bad = trial(data)
        edit_csv(bad, lambda f: f.drop(columns=["ati_fx", "ati_fy", "ati_fz"]))
        return str(bad)
    dataset_case("recording without ATI targets", no_targets)

    # issue 46, class 5: columns and entries named once, known, plausible
    dataset_case("a trial listed twice", meta_trials(lambda t: t + t[:1]))
    dataset_case("an unknown condition", meta_trials(
        lambda t: [{**t[0], "condition": "Freee"}] + t[1:]))
    dataset_case("an unknown split", meta_trials(lambda t: [{**t[0], "split": "tarin"}] + t[1:]))

    def repeated_column(data):
        bad = trial(data)
        lines = bad.read_text().splitlines()
        first = lines[0].split(",")[1]
        bad.write_text("\n".join([lines[0] + "," + first]
                                 + [line + ",0" for line in lines[1:]]) + "\n")
        return str(bad)
    dataset_case("a recording naming a column twice", repeated_column)

    def ati_in_millinewton(data):
        bad = trial(data, condition="Traction")
        edit_csv(bad, lambda f: f.assign(ati_fz=f["ati_fz"] * 1e3 + 1e4))
        return str(bad)
    dataset_case("an ATI target in the wrong unit", ati_in_millinewton)

    # issue 46, class 4: the rate is measured from the data, one rate, in seconds
    def times_scaled(scale, condition=None):
        def damage(data):
            paths = sorted(data.rglob("*.csv")) if condition is None else [
                trial(data, condition=condition)]
            for path in paths:
                edit_csv(path, lambda f: f.assign(time=f["time"] * scale))
            return str(paths[0]) if condition else str(data)  # every file: the folder
        return damage
    dataset_case("times in milliseconds", times_scaled(1e3))
    dataset_case("times in nanoseconds", times_scaled(1e9))
    dataset_case("one recording at another rate", times_scaled(0.5, condition="Free"))

    @case("cli train: dataset", "train recording shorter than the transformer's window")
    def _(s, d):
        data = s.copy(d)
        bad = trial(data, "train", "Traction")
        edit_csv(bad, lambda f: f.iloc[:50])
        return Attempt(argv=["train", "--data", str(data), "--model", "transformer",
                             "--epochs", "1", "--out", str(d / "m.pt")],
                       names=(bad.relative_to(data).as_posix(),))

    @case("cli train: dataset", "data folder missing")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(d / "nowhere"), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(d / "nowhere"),))

    @case("cli train: dataset", "data folder empty")
    def _(s, d):
        (d / "empty").mkdir()
        return Attempt(argv=["train", "--data", str(d / "empty"), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(d / "empty"),))

    @case("cli train: dataset", "data is a file")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(s.fcn), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(s.fcn),))

    @case("api train", "short Traction trials (240 < chunk 400) trained on, not dropped",
          "HANDLED")
    def _(s, d):
        from psmforce.estimators.training.checkpoint import load_checkpoint
        from psmforce.estimators.data.dataset import load_dataset
        from psmforce.estimators.training.train import train
        out = d / "h.pt"

        def check(result):
            ckpt = load_checkpoint(out)
            used = set(ckpt.provenance["train_trials"]) | set(ckpt.provenance["val_trials"])
            listed = {t.path for t in load_dataset(s.bench).select(split="train")}
            traction = [p for p in used if "/Traction/" in p]
            return (used == listed and bool(traction),
                    f"chunk {result['chunk']}: all {len(listed)} train recordings used, "
                    f"{len(traction)} Traction")

        def run():
            with contextlib.redirect_stderr(io.StringIO()):
                return train(s.bench, "hybrid", out, epochs=1, prior=s.prior)
        return Attempt(call=run, check=check)

    @case("cli index", "interrupted simulate indexed explicitly", "HANDLED")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        n = len(list(data.rglob("*.csv")))

        def check(stdout):
            from psmforce.estimators.data.dataset import load_dataset
            got = len(load_dataset(data).trials)
            return got == n, f"{got} of {n} recordings listed: {stdout.strip()}"
        return Attempt(argv=["index", str(data)], check=check)

    @case("cli index", "folder already a dataset")
    def _(s, d):
        data = s.copy(d)
        return Attempt(argv=["index", str(data)], names=(str(data),))

    @case("cli index", "missing folder")
    def _(s, d):
        return Attempt(argv=["index", str(d / "nowhere")], names=(str(d / "nowhere"),))

    @case("cli index", "folder without recordings")
    def _(s, d):
        (d / "empty").mkdir()
        (d / "empty" / "notes.txt").write_text("no csv here\n")
        return Attempt(argv=["index", str(d / "empty")], names=(str(d / "empty"),))

    @case("cli index", "a file")
    def _(s, d):
        path = d / "rec.csv"
        shutil.copy(trial(s.bench), path)
        return Attempt(argv=["index", str(path)], names=(str(path),))

    # --- data sanity before learning ------------------------------------------------------------
    def zero_targets(f):
        return f.assign(ati_fx=0.0, ati_fy=0.0, ati_fz=0.0)

    for label, condition, change in (
            ("all-zero ATI in a Traction recording", "Traction", zero_targets),
            ("all-zero ATI in a Free recording", "Free", zero_targets),
            ("constant ATI fz = 5 N", "Palpation", lambda f: f.assign(ati_fz=5.0))):
        def degenerate(s, d, condition=condition, change=change):
            data = s.copy(d)
            bad = trial(data, "train", condition)
            edit_csv(bad, change)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: targets", label, "REJECTED", degenerate))

        def degenerate_eval(s, d, condition=condition, change=change):
            data = s.copy(d)
            bad = trial(data, "test", condition)
            edit_csv(bad, change)
            return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                                 "--out", str(d / "eval")], names=(str(bad),))
        found.append(Case("cli evaluate: targets", label, "REJECTED", degenerate_eval))

    @case("cli finetune: targets", "every ATI column zero in every recording")
    def _(s, d):
        data = s.copy(d)
        for path in sorted(data.rglob("*.csv")):
            edit_csv(path, zero_targets)
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                             "--out", str(d / "t.pt")], names=("ati_fx is constant",))

    def leaked(s, d):
        data = s.copy(d)
        train_rel = sorted(data.glob("train/Traction/*.csv"))[0]
        test = trial(data, "test", "Traction")
        shutil.copy(train_rel, test)
        return data, test

    @case("cli evaluate: overlap", "a test recording is a training recording of the checkpoint")
    def _(s, d):
        data, test = leaked(s, d)
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(test),))

    @case("cli evaluate: overlap", "the same with --allow-train-overlap: flagged per file",
          "HANDLED")
    def _(s, d):
        data, test = leaked(s, d)
        out = d / "eval"
        argv = ["evaluate", str(s.fcn), "--data", str(data), "--out", str(out),
                "--allow-train-overlap", "--json", str(d / "e.json")]

        def check(stdout):
            report = json.loads((d / "e.json").read_text())
            rel = test.relative_to(data).as_posix()
            return (report.get("train_overlap", [{}])[0].get("test") == rel,
                    f"scored, overlap recorded: {report.get('train_overlap')}")
        return Attempt(argv=argv, check=check)
    return found
