"""Issue 26: exports and cached task results carry the integrity envelope and are refused (or
recomputed) when edited; the export runner is as strict as the stream and confined to its
folder; the stream never raises on a timestamp; model configs are checked before allocation."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from psmforce.estimators.runtime.export import ExportError, export, run_export
from psmforce.experiments.task_cache import GridError, cache_path, read_result, run_grid, task
from psmforce.core.integrity import IntegrityError, check_version, seal, verify
from psmforce.estimators.networks.recipes import RecipeError, build_model, check_config
from psmforce.estimators.runtime.streaming import Flags
from tests.estimators.test_export import _checkpoint
from tests.estimators.test_streaming import estimator, one_thread, recording  # noqa: F401


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    root = tmp_path_factory.mktemp("export")
    export(_checkpoint(root, use_prior=False), root / "out")
    return root / "out"


def _copy(exported, tmp_path, edit=None):
    out = tmp_path / "copy"
    out.mkdir()
    for name in ("hybrid.json", "hybrid_step.onnx"):
        (out / name).write_bytes((exported / name).read_bytes())
    if edit is not None:
        spec = json.loads((out / "hybrid.json").read_text())
        edit(spec)
        (out / "hybrid.json").write_text(json.dumps(spec))
    return out


def test_an_intact_export_runs_and_an_edited_one_is_refused_naming_the_field(exported, tmp_path):
    frame = recording(40)
    assert np.isfinite(run_export(exported, frame)).all()
    out = _copy(exported, tmp_path, lambda s: s["target_scaler"]["mean"].__setitem__(0, 9.0))
    with pytest.raises(ExportError, match="changed: target_scaler") as err:
        run_export(out, frame)
    assert str(out / "hybrid.json") in str(err.value) and "\n" not in str(err.value)


def test_an_export_pointing_outside_its_folder_is_refused(exported, tmp_path):
    """The JSON may not name a graph elsewhere, even one that would match its digest."""
    outside = tmp_path / "elsewhere.onnx"
    outside.write_bytes((exported / "hybrid_step.onnx").read_bytes())
    for k, target in enumerate((str(outside), "../elsewhere.onnx", "sub/../../elsewhere.onnx")):
        folder = tmp_path / f"case{k}"
        folder.mkdir()
        out = _copy(exported, folder, lambda s: s.update(onnx=target))
        spec = json.loads((out / "hybrid.json").read_text())
        (out / "hybrid.json").write_text(json.dumps(seal(spec)))  # even with a fresh envelope
        with pytest.raises(ExportError, match="inside the export folder") as err:
            run_export(out, recording(10))
        assert str(out / "hybrid.json") in str(err.value)
    link_dir = tmp_path / "linked"
    link_dir.mkdir()
    out = _copy(exported, link_dir)
    os.remove(out / "hybrid_step.onnx")
    os.symlink(outside, out / "hybrid_step.onnx")
    with pytest.raises(ExportError, match="leads outside the export folder"):
        run_export(out, recording(10))


def test_an_edited_graph_and_an_older_version_are_refused(exported, tmp_path):
    out = _copy(exported, tmp_path)
    raw = bytearray((out / "hybrid_step.onnx").read_bytes())
    raw[-20] ^= 0xFF
    (out / "hybrid_step.onnx").write_bytes(bytes(raw))
    with pytest.raises(ExportError, match="does not match the SHA-256"):
        run_export(out, recording(10))
    old = tmp_path / "v2"
    old.mkdir()
    out = _copy(exported, old, lambda s: (s.pop("sha256"), s.update(format_version=2)))
    with pytest.raises(ExportError, match="export the checkpoint again"):
        run_export(out, recording(10))
    text = tmp_path / "text"
    text.mkdir()
    out = _copy(exported, text, lambda s: s.update(format_version="3"))
    with pytest.raises(ExportError, match="is not an integer"):
        run_export(out, recording(10))


@pytest.mark.parametrize("column, value, reason", [
    ("fx", np.nan, "column fx row 7"), ("roll_position", 1e30, "column roll_position row 7"),
    ("insertion_effort", np.inf, "column insertion_effort row 7")])
def test_the_runner_refuses_what_the_stream_refuses(exported, column, value, reason):
    frame = recording(20)
    frame.loc[7, column] = value
    with pytest.raises(ExportError, match=reason):
        run_export(exported, frame)


def test_the_runner_refuses_missing_and_text_columns(exported):
    with pytest.raises(ExportError, match="lacks the columns"):
        run_export(exported, recording(20).drop(columns=["fy"]))
    frame = recording(20)
    frame["fz"] = frame["fz"].astype(object)
    frame.loc[3, "fz"] = "abc"
    with pytest.raises(ExportError, match="column fz: not numeric"):
        run_export(exported, frame)
    with pytest.raises(ExportError, match="must be a pandas DataFrame"):
        run_export(exported, recording(20).to_numpy())


@pytest.mark.parametrize("change, reason", [
    (lambda f: f.assign(fz=f["fz"] + 1j), "column fz: not numeric"),  # not cast to real
    (lambda f: f.assign(fy=f["fy"] > 0), "column fy: not numeric"),
    (lambda f: f.join(f[["fx"]], rsuffix="_").rename(columns={"fx_": "fx"}),
     "column fx: appears more than once"),
    (lambda f: f.iloc[:0], "no rows")])
def test_the_runner_refuses_tables_the_stream_could_not_read(exported, change, reason):
    with pytest.raises(ExportError, match=reason):
        run_export(exported, change(recording(20)))


@pytest.mark.parametrize("change", [lambda x: x + 0j, lambda x: x.astype(str)])
def test_an_array_sample_of_complex_or_text_is_invalid_not_cast(change):
    """numpy would cast such an array into the float buffer (the imaginary part dropped, the
    text parsed) without a word: the stream flags it as it does any malformed sample."""
    est = estimator(use_prior=False)
    frame = recording(200)
    values = frame[list(est.columns)].to_numpy(np.float64)
    out = [est.step(x, time=t) for x, t in zip(values[:150], frame["time"])]
    bad = est.step(change(values[150]), time=frame["time"][150])
    assert bad.flags & Flags.INVALID_INPUT
    good = est.step(values[151], time=frame["time"][151])
    assert not good.flags & Flags.INVALID_INPUT and np.isfinite(good.force_hex10).all()
    assert np.isfinite(out[-1].force_hex10).all()


@pytest.mark.parametrize("jump", [1e307, 1.7e308, -1e307])
def test_step_with_a_huge_timestamp_flags_and_carries_on(jump):
    """A finite timestamp whose gap overflows to infinitely many samples is a GAP (or, going
    back, TIME_BACKWARDS), never an exception; the stream goes on estimating afterwards."""
    est = estimator(use_prior=False)
    rows = recording(200).to_dict("records")
    out = [est.step(r) for r in rows[:100]]
    odd = est.step({**rows[100], "time": jump})
    assert odd.flags & (Flags.GAP | Flags.TIME_BACKWARDS)
    after = [est.step(r) for r in rows[101:]]
    assert all(np.isfinite(e.force_hex10).all() for e in out[-5:] + after[-5:])
    assert not after[-1].flags & Flags.INVALID_INPUT


@task("test_double")
def _double(params: dict) -> dict:
    return {"x": 2 * params["x"]}


def test_an_edited_cached_result_is_recomputed_never_returned(tmp_path):
    cache = tmp_path / "cache"
    logged = []
    assert run_grid([(_double, {"x": 3})], cache, log=logged.append) == [{"x": 6}]
    path = cache_path(cache, _double, {"x": 3})
    record = json.loads(path.read_text())
    assert record["format_version"] == 1 and "sha256" in record
    record["result"]["x"] = 1000  # an edited number
    path.write_text(json.dumps(record))
    with pytest.raises(GridError, match="changed: result"):
        read_result(path, _double, {"x": 3})
    assert run_grid([(_double, {"x": 3})], cache, log=logged.append) == [{"x": 6}]
    assert any("recomputing" in line and str(path) in line for line in logged)
    legacy = {k: record[k] for k in ("task", "params", "seconds")} | {"result": {"x": 7}}
    path.write_text(json.dumps(legacy))  # written before results were sealed
    assert run_grid([(_double, {"x": 3})], cache, log=logged.append) == [{"x": 6}]


def test_envelope_and_version_helpers():
    record = seal({"a": 1, "b": [1.5, float("nan")], "c": (1, 2)})
    verify(record, "f.json", "thing")
    with pytest.raises(IntegrityError, match="f.json: thing does not match .*changed: a"):
        verify({**record, "a": 2}, "f.json", "thing")
    with pytest.raises(IntegrityError, match="removed: c"):
        verify({k: v for k, v in record.items() if k != "c"}, "f.json", "thing")
    for bad in ("1", 1.0, True, None):
        with pytest.raises(IntegrityError, match="not an integer"):
            check_version(bad, (1,), "f.json", "thing")
    assert check_version(1, (1,), "f.json", "thing") == 1


@pytest.mark.parametrize("model, config, key", [
    ("hybrid", {"n_heads": 0}, "n_heads"), ("hybrid", {"d_model": 0}, "d_model"),
    ("hybrid", {"n_heads": 5}, "n_heads must divide d_model"),
    ("hybrid", {"attention_window": 100_000}, "attention_window"),
    ("hybrid", {"dropout": 1.0}, "dropout"), ("hybrid", {"n_layers": 2.0}, "n_layers"),
    ("transformer", {"n_heads": 0}, "n_heads"), ("transformer", {"n_heads": 7}, "n_heads"),
    ("transformer", {"window": 0}, "window"), ("fcn", {"hidden": -1}, "hidden"),
    ("lstm", {"max_torque": [1, 1]}, "max_torque"), ("rocket", {"window": 10 ** 9}, "window"),
    ("fcn", {"width": 3}, "'width' is not an argument")])
def test_configs_are_checked_before_any_allocation_naming_the_key(model, config, key):
    with pytest.raises(RecipeError, match=key) as err:
        check_config(model, 36 if model == "lstm" else 21, config)
    assert "\n" not in str(err.value)
    with pytest.raises(RecipeError, match=key):
        build_model(model, 36 if model == "lstm" else 21, config)


def _prior_file(tmp_path):
    from psmforce.identification.prior import InternalForcePrior
    path = tmp_path / "prior.json"
    InternalForcePrior(converged=True).save(path)
    return path, json.loads(path.read_text())


@pytest.mark.parametrize("field, edit", [
    ("parameters", lambda d: d["parameters"]["bias_fz"].update(value=0.25)),  # in bounds
    ("axis_weights", lambda d: d["axis_weights"].__setitem__(0, 0.5)),
    ("info", lambda d: d.update(info={"note": "edited"})),
    ("note", lambda d: d.update(note="a field added"))])
def test_a_prior_with_one_field_edited_is_refused_naming_it(tmp_path, field, edit):
    from psmforce.identification.errors import IdentificationInputError
    from psmforce.identification.prior import FORMAT_VERSION, InternalForcePrior
    path, d = _prior_file(tmp_path)
    assert d["format_version"] == FORMAT_VERSION and "sha256" in d
    InternalForcePrior.load(path)  # as saved: loads
    edit(d)
    path.write_text(json.dumps(d))
    with pytest.raises(IdentificationInputError, match=f"SHA-256 envelope .*{field}") as err:
        InternalForcePrior.load(path)
    assert str(path) in str(err.value)


@pytest.mark.parametrize("version", ["2", 2.0, True, None, 1, "next"])
def test_a_prior_whose_format_version_is_not_the_integer_is_refused(tmp_path, version):
    from psmforce.identification.errors import IdentificationInputError
    from psmforce.identification.prior import InternalForcePrior
    from psmforce.identification.prior import FORMAT_VERSION
    path, d = _prior_file(tmp_path)
    version = FORMAT_VERSION + 1 if version == "next" else version  # a later version's file
    path.write_text(json.dumps(seal({**d, "format_version": version})))  # even resealed
    with pytest.raises(IdentificationInputError, match="prior format version") as err:
        InternalForcePrior.load(path)
    assert str(path) in str(err.value)
    legacy = {k: v for k, v in d.items() if k not in ("sha256", "format_version")}
    path.write_text(json.dumps(legacy))  # written before the envelope: loads, bounds checked
    assert InternalForcePrior.load(path).converged


@pytest.mark.parametrize("seeds", [[1, 1], [2, 3, 2]])
def test_reproduce_from_python_refuses_repeated_seeds_before_writing(tmp_path, seeds,
                                                                    monkeypatch):
    import psmforce.experiments.reproduce
    from psmforce.experiments.reproduce import reproduce

    def reached(*args, **kwargs):
        raise AssertionError("the run started with repeated seeds")
    monkeypatch.setattr(psmforce.experiments.reproduce, "run_grid", reached)
    with pytest.raises(ValueError, match="^seeds: .* more than once"):
        reproduce(tmp_path / "run", seeds=seeds)
    assert not (tmp_path / "run").exists()
