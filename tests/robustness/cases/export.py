"""Bad input against the export runner: as strict as the stream, confined to its folder, tables it cannot read."""

from __future__ import annotations

from pathlib import Path
import json
import shutil

import numpy as np
import pandas as pd

from tests.robustness.harness import Attempt, Case, registrar, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- the export runner: as strict as the stream, confined to its folder -------------------
    def export_copy(s, d, edit=None, reseal=False):
        from psmforce.core.integrity import seal
        out = d / "exp"
        shutil.copytree(s.export, out)
        if edit is not None:
            spec = json.loads((out / "hybrid.json").read_text())
            edit(spec)
            (out / "hybrid.json").write_text(json.dumps(seal(spec) if reseal else spec))
        return out

    def runner(name, edit=None, reseal=False, frame=None, names=None, escape=False,
               prepare_more=None):
        def prepare(s, d):
            from psmforce.estimators.runtime.export import run_export
            out = export_copy(s, d, edit, reseal)
            if prepare_more is not None:
                prepare_more(s, d, out)
            rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
            if frame is not None:
                rec = frame(rec)
            return Attempt(call=lambda: run_export(out, rec),
                           names=names or (str(out / "hybrid.json"),), escape=escape)
        found.append(Case("api run_export", name, "REJECTED", prepare))

    @case("api run_export", "JSON names an absolute path to a matching graph outside")
    def _(s, d):
        from psmforce.estimators.runtime.export import run_export
        from psmforce.core.integrity import seal
        out = export_copy(s, d)
        target = d.parent.parent / "outside" / f"{d.name}.onnx"
        target.write_bytes((s.export / "hybrid_step.onnx").read_bytes())
        spec = json.loads((out / "hybrid.json").read_text())
        (out / "hybrid.json").write_text(json.dumps(seal({**spec, "onnx": str(target)})))
        rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
        return Attempt(call=lambda: run_export(out, rec), names=(str(out / "hybrid.json"),),
                       escape=True)
    for label, rel in (("'../' path", "../exp2/hybrid_step.onnx"),
                       ("'sub/../..' path", "sub/../../x.onnx"), ("'.'", "."), ("''", ""),
                       ("a number", 3)):
        runner(f"JSON names the graph as {label}", lambda sp, rel=rel: sp.update(onnx=rel),
               reseal=True, escape=True)

    @case("api run_export", "the graph is a link to a file outside the folder")
    def _(s, d):
        from psmforce.estimators.runtime.export import run_export
        out = export_copy(s, d)
        target = d.parent.parent / "outside" / f"{d.name}.onnx"
        target.write_bytes((s.export / "hybrid_step.onnx").read_bytes())
        (out / "hybrid_step.onnx").unlink()
        (out / "hybrid_step.onnx").symlink_to(target)
        rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
        return Attempt(call=lambda: run_export(out, rec), names=(str(out / "hybrid.json"),),
                       escape=True)

    runner("JSON target_scaler edited", lambda sp: sp["target_scaler"]["mean"].__setitem__(
        0, 9.0))
    runner("JSON features swapped", lambda sp: sp.update(
        features=[sp["features"][1], sp["features"][0], *sp["features"][2:]]))
    runner("JSON raw_columns edited", lambda sp: sp.update(raw_columns=sp["raw_columns"][1:]))
    runner("JSON envelope removed", lambda sp: sp.pop("sha256"))
    runner("JSON format_version '3'", lambda sp: sp.update(format_version="3"))
    runner("JSON format_version 2 (before the envelope)", lambda sp: (
        sp.pop("sha256"), sp.update(format_version=2)))
    runner("resealed: a state tensor of 1e12 values", lambda sp: sp["graph"]["state"][0].update(
        shape=[10 ** 6, 10 ** 6]), reseal=True)
    runner("resealed: input_scaler std 0", lambda sp: sp["input_scaler"].update(
        std=[0.0] * len(sp["features"])), reseal=True)
    runner("resealed: graph.y of 4 columns", lambda sp: sp["graph"]["y"].update(shape=[1, 4]),
           reseal=True)
    runner("JSON not JSON", prepare_more=lambda s, d, out: (out / "hybrid.json").write_text(
        "{graph: "))
    runner("JSON a list", prepare_more=lambda s, d, out: (out / "hybrid.json").write_text(
        "[1, 2]"))

    def flip_graph(s, d, out):
        raw = bytearray((out / "hybrid_step.onnx").read_bytes())
        raw[-32] ^= 0xFF
        (out / "hybrid_step.onnx").write_bytes(bytes(raw))
    runner("graph bytes flipped", prepare_more=flip_graph,
           names=(str(Path("exp") / "hybrid_step.onnx"),))
    runner("graph missing", prepare_more=lambda s, d, out: (out / "hybrid_step.onnx").unlink(),
           names=("hybrid_step.onnx",))
    for label, column, value, in (("NaN", "fx", np.nan), ("1e30", "roll_position", 1e30),
                                  ("inf", "insertion_effort", np.inf),
                                  ("-1e39", "fz", -1e39)):
        runner(f"recording: {column} {label}", frame=lambda f, c=column, v=value: f.assign(
            **{c: f[c].where(f.index != 7, v)}), names=(f"column {column} row 7",))
    runner("recording: a text cell", frame=lambda f: f.astype({"fy": object}).assign(
        fy=lambda g: g["fy"].where(g.index != 4, "abc")), names=("column fy",))
    runner("recording: a column missing", frame=lambda f: f.drop(columns=["tz"]),
           names=("['tz']",))
    runner("recording: a numpy array, not a table", frame=lambda f: f.to_numpy(),
           names=("DataFrame",))

    # --- the export runner: tables it cannot read as the stream would --------------------
    def runner_frame(name, frame, names):
        def prepare(s, d):
            from psmforce.estimators.runtime.export import run_export
            rec = frame(pd.read_csv(trial(s.bench, "test", "Palpation")))
            return Attempt(call=lambda: run_export(s.export, rec), names=names)
        found.append(Case("api run_export", name, "REJECTED", prepare))

    runner_frame("recording: a column twice", lambda f: pd.concat([f, f[["fx"]]], axis=1),
                 ("fx",))
    runner_frame("recording: a bool column", lambda f: f.assign(fy=f["fy"] > 0), ("fy",))
    runner_frame("recording: a complex column", lambda f: f.assign(fz=f["fz"] + 1j),
                 ("fz",))
    runner_frame("recording: no rows", lambda f: f.iloc[:0], ("no rows", "empty"))
    runner_frame("recording: time steps back", lambda f: f.assign(
        time=f["time"].where(f.index != 10, f["time"][3])), ("time does not increase",))
    runner_frame("recording: time repeats", lambda f: f.assign(
        time=f["time"].where(f.index != 10, f["time"][9])), ("time does not increase",))
    runner_frame("recording: time in reverse", lambda f: f.assign(time=f["time"][::-1].to_numpy()),
                 ("time does not increase",))

    # --- a graph replaced under its export, its digest recomputed (class 10) ---------------
    def replaced(name, graph):
        """The export's graph replaced by ``graph(shared, export_spec) -> bytes`` and the JSON
        resealed over it: only the check of the graph against the JSON can refuse it."""
        def prepare_more(s, d, out):
            from psmforce.core.integrity import seal, sha256_bytes
            spec = json.loads((out / "hybrid.json").read_text())
            raw = graph(s, spec)
            (out / "hybrid_step.onnx").write_bytes(raw)
            spec = {k: v for k, v in spec.items() if k != "sha256"}
            (out / "hybrid.json").write_text(json.dumps(seal({**spec,
                                                              "onnx_sha256": sha256_bytes(raw)})))
        runner(f"graph replaced: {name}", prepare_more=prepare_more, names=("hybrid_step.onnx",))

    def other_network(n_extra=0, **config):
        def graph(s, spec):
            from psmforce.estimators.networks.recipes import build_model
            from psmforce.estimators.runtime.steppers import step_onnx_bytes
            from psmforce.estimators.training.checkpoint import load_checkpoint
            record = load_checkpoint(s.hybrid)
            model = build_model("hybrid", len(spec["features"]) + n_extra,
                                {**record.config, **config})
            return step_onnx_bytes(model)
        return graph

    def edited(change):
        def graph(s, spec):
            import onnx
            model = onnx.load_from_string((s.export / "hybrid_step.onnx").read_bytes())
            change(model.graph)
            return model.SerializeToString()
        return graph

    def rename(entries, old, new):
        for entry in entries:
            if entry.name == old:
                entry.name = new

    replaced("two more inputs", other_network(2))
    replaced("a wider network (state of another shape)", other_network(d_model=48, n_heads=4))
    replaced("a longer attention window (state of another shape)",
             other_network(attention_window=60))
    replaced("input x renamed", edited(lambda g: rename(g.input, "x", "inputs")))
    replaced("output y renamed", edited(lambda g: rename(g.output, "y", "force")))
    replaced("input x declared float64", edited(
        lambda g: g.input[0].type.tensor_type.__setattr__("elem_type", 11)))
    replaced("input x of batch 4", edited(
        lambda g: g.input[0].type.tensor_type.shape.dim[0].__setattr__("dim_value", 4)))
    replaced("one input more", edited(lambda g: g.input.append(
        __import__("onnx").helper.make_tensor_value_info("extra", 1, [1, 1]))))
    return found
