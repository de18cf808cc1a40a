"""studies/learning_curve.py assembles finished reproduce runs into the curve: minutes of
training data from the benches, the spread rule between the hybrid and the paper transformer,
unfinished scales listed as missing, and a table and one figure per axis beside the JSON."""

from __future__ import annotations

import pytest

import json
import math
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from studies.learning_curve import (  # noqa: E402
    HYBRID,
    MODELS,
    TRANSFORMER,
    assemble,
    crossovers,
    data_efficiency,
    lane_jobs,
    main,
    run_dir,
    run_lanes,
    standing,
)
from psmforce.experiments.plan import plan  # noqa: E402
from psmforce.estimators.evaluation.tables import SPREAD  # noqa: E402


def _spread(mean, std):
    return {"nrmse_pct": {"mean": mean, "std": std, "n": 2}}


def _finished_run(out: Path, scale: float, hybrid_fx: float, transformer_fx: float,
                  seeds=(1, 2), models=MODELS, hybrid_optimiser=None,
                  device="cpu", spread=SPREAD) -> None:
    for seed in seeds:
        data = out / "work" / "data" / f"automated_seed{seed}"
        data.mkdir(parents=True)
        trials = [{"split": "train", "rows": 6000 * seed}, {"split": "test", "rows": 999}]
        (data / "metadata.json").write_text(json.dumps({"sample_rate_hz": 100.0,
                                                        "trials": trials}))
    axes = lambda fx: {"Fx": _spread(fx, 0.05), "Fy": _spread(1.0, 0.05),  # noqa: E731
                       "Fz": _spread(2.0, 0.5)}
    fx = {"hybrid": hybrid_fx, "transformer": transformer_fx}
    per_metric = {plan(m).label: axes(fx.get(m, 1.5)) for m in models}
    (out / "results.json").write_text(json.dumps({
        "call": {"scale": scale, "seeds": list(seeds), "models": list(models),
                 "device": device},
        "benches": {"a": "2.1", "b": "2.1"},
        "all_converged": True, **({"spread": spread} if spread else {}),
        "training": {f"{m} full 1.0 seed {s}": {
            "stopped_by": "patience", "epochs_run": 10 + s, "converged": True,
            "optimiser": hybrid_optimiser if m == "hybrid" else {}}
            for m in models if m != "rocket" for s in seeds},
        "automated": {"causal": per_metric, "paper": per_metric,
                                             "causal_lowpass": per_metric}}))


@pytest.mark.slow
def test_the_curve_holds_finished_scales_their_minutes_and_the_spread_rule(tmp_path):
    work = tmp_path / "work"
    _finished_run(run_dir(work, 0.05), 0.05, hybrid_fx=0.4, transformer_fx=1.1)
    _finished_run(run_dir(work, 0.1), 0.1, hybrid_fx=0.6, transformer_fx=0.62)
    run_dir(work, 0.25).mkdir(parents=True)  # started, not finished: not a point yet
    _finished_run(run_dir(work, 0.5), 0.5, 0.3, 0.3, seeds=[3])  # one seed beside the main call
    _finished_run(run_dir(work, 1.0), 1.0, 0.3, 0.3, models=["hybrid"])  # not every model yet
    out = tmp_path / "curve" / "learning_curve.json"
    curve = assemble(work, [0.05, 0.1, 0.25, 0.5, 1.0], out)
    assert [p["scale"] for p in curve["points"]] == [0.05, 0.1]
    assert curve["missing_scales"] == [0.25, 0.5, 1.0]
    assert curve["points"][0]["training_minutes"] == 1.5  # 60 s and 120 s of training rows
    fx = [p["hybrid_vs_transformer"]["causal"]["Fx"]["verdict"] for p in curve["points"]]
    assert fx == ["hybrid ahead", "tie"]
    assert curve["points"][0]["hybrid_vs_transformer"]["causal"]["Fz"]["verdict"] == "tie"
    assert json.loads(out.read_text())["points"] == json.loads(json.dumps(curve["points"]))
    page = (out.parent / "README.md").read_text()
    assert "| 0.1 | | | | hybrid / transformer | | 0.97x (tie)" in page
    assert "Scales not yet measured: 0.25, 0.5, 1." in page
    assert [p["scale"] for p in curve["partial"]] == [1.0]  # the hybrid alone so far
    assert "At scale 1 only Hybrid (ours) so far" in page
    from reports.results_page import learning_curve
    section = learning_curve(curve)  # docs/results.md says what the partial point holds
    assert ("At scale 1 (1.5 min of training data, 2 seeds, every run converged), so far only: "
            "Hybrid (ours) causal 0.30 ± 0.05 / 1.00 ± 0.05 / 2.00 ± 0.50.") in section
    assert ("At the paper's own budget (scale 1) the hybrid against the transformer is not "
            "measured yet: no claim is made for it.") in section
    assert "Networks trained on: scale 0.05 cpu; scale 0.1 cpu; scale 1 cpu." in page
    assert curve["points"][0]["stopped"][HYBRID] == ["11 epochs", "12 epochs"]
    assert sorted(p.name for p in out.parent.glob("*.png")) == ["Fx.png", "Fy.png", "Fz.png",
                                                               "learning_curve.png"]


def test_a_point_with_the_population_std_is_converted_exactly_and_judged_again(tmp_path):
    """Runs before issue 45 wrote the population std (no ``spread`` entry): the curve shows the
    sample std, std * sqrt(n / (n - 1)), and draws its verdicts from it; today's runs are kept."""
    from studies.learning_curve import point, sample_spread
    _finished_run(tmp_path / "old", 0.05, hybrid_fx=0.4, transformer_fx=0.52, spread=None)
    _finished_run(tmp_path / "new", 0.05, hybrid_fx=0.4, transformer_fx=0.52)
    old, new = point(tmp_path / "old"), point(tmp_path / "new")
    assert new["spread"] == SPREAD and sample_spread(new) == new
    converted = sample_spread(old)
    cell = converted["models"][HYBRID]["causal"]["Fx"]
    assert cell["std"] == pytest.approx(0.05 * 2 ** 0.5) and cell["n"] == 2
    # 0.4 + 0.05 < 0.52 - 0.05: ahead with the population std; with the sample std a tie
    assert old["hybrid_vs_transformer"]["causal"]["Fx"]["verdict"] == "hybrid ahead"
    assert converted["hybrid_vs_transformer"]["causal"]["Fx"]["verdict"] == "tie"
    assert converted["spread"] == SPREAD and sample_spread(converted) == converted


@pytest.mark.slow
def test_a_point_whose_run_is_gone_is_kept_from_the_json(tmp_path):
    work, out = tmp_path / "work", tmp_path / "curve" / "learning_curve.json"
    _finished_run(run_dir(work, 0.05), 0.05, hybrid_fx=0.4, transformer_fx=1.1)
    first = assemble(work, [0.05], out)
    shutil.rmtree(work)  # a new machine: runs/ is not committed
    _finished_run(run_dir(work, 0.1), 0.1, hybrid_fx=0.6, transformer_fx=0.62)
    again = assemble(work, [0.1], out)  # a call for one scale keeps the others
    assert [p["scale"] for p in again["points"]] == [0.05, 0.1]
    assert again["points"][0] == first["points"][0]
    assert again["missing_scales"] == [0.25, 0.5, 1.0]


@pytest.mark.slow
def test_parts_of_a_point_run_apart_on_the_same_benches_make_the_point(tmp_path):
    out = tmp_path / "curve" / "learning_curve.json"
    _finished_run(run_dir(tmp_path / "cpu", 1.0), 1.0, 0, 0, seeds=(1, 2),
                  models=["fcn", "rocket"])
    first = assemble(tmp_path / "cpu", [1.0], out)
    assert first["points"] == [] and [p["model_names"] for p in first["partial"]] == [
        ["fcn", "rocket"]]
    assert first["missing_scales"] == [0.05, 0.1, 0.25, 0.5, 1.0]

    # another machine, the other models on the same seeds: the JSON's part completes the point
    _finished_run(run_dir(tmp_path / "gpu", 1.0), 1.0, 0.3, 0.6, seeds=(1, 2),
                  models=["hybrid", "transformer"], device="cuda")
    whole = assemble(tmp_path / "gpu", [1.0], out)
    assert whole["partial"] == [] and whole["missing_scales"] == [0.05, 0.1, 0.25, 0.5]
    (p,) = whole["points"]
    assert set(p["models"]) == {HYBRID, TRANSFORMER, "FCN", "MultiRocket-Hydra"}
    assert p["models"]["FCN"] == first["partial"][0]["models"]["FCN"]
    assert p["hybrid_vs_transformer"]["causal"]["Fx"]["verdict"] == "hybrid ahead"
    assert p["devices"] == {"FCN": "cpu", HYBRID: "cuda", TRANSFORMER: "cuda"}
    page = (out.parent / "README.md").read_text()
    assert "scale 1 cpu (FCN), cuda (Hybrid (ours), Transformer (paper))" in page
    # the claim at the paper's budget: the JSON's verdicts, and the README's headline shows them
    from reports.readme_page import headline
    from reports.results_page import learning_curve
    verdicts = {m: {a: v["verdict"] for a, v in p["hybrid_vs_transformer"][m].items()}
                for m in ("causal", "paper")}
    assert verdicts == {m: {"Fx": "hybrid ahead", "Fy": "tie", "Fz": "tie"}
                        for m in ("causal", "paper")}
    shown = headline(whole)
    assert "is ahead on Fx (0.50x), tied on Fy (1.00x) and Fz (1.00x);" in shown
    assert "| hybrid / transformer | 0.50x (hybrid ahead) | 1.00x (tie) |" in shown
    assert "not measured yet" not in learning_curve(whole)

    # the same seeds simulated again elsewhere into other bytes: not the same data, not merged
    _finished_run(run_dir(tmp_path / "resim", 1.0), 1.0, 0.3, 0.6, seeds=(1, 2),
                  models=["hybrid", "transformer"], device="cuda")
    (run_dir(tmp_path / "resim", 1.0) / "work" / "data" / "automated_seed2" / "t.csv").write_text(
        "fx\n0.1000000001\n")
    out3 = tmp_path / "curve3" / "learning_curve.json"
    assemble(tmp_path / "cpu", [1.0], out3)
    (run_dir(tmp_path / "cpu", 1.0) / "work" / "data" / "automated_seed2" / "t.csv").write_text(
        "fx\n0.1\n")
    cpu_part = assemble(tmp_path / "cpu", [1.0], out3)["partial"][0]
    assert cpu_part["bench_sha256"]["1"] == p["bench_sha256"]["1"]   # seed 1: same files
    resim = assemble(tmp_path / "resim", [1.0], out3)
    assert resim["points"] == [] and set(resim["partial"][0]["models"]) == {HYBRID, TRANSFORMER}

    # a part on other benches (seeds) is not merged: the newer run stands alone
    out2 = tmp_path / "curve2" / "learning_curve.json"
    assemble(tmp_path / "cpu", [1.0], out2)
    _finished_run(run_dir(tmp_path / "other", 1.0), 1.0, 0.3, 0.6, seeds=(3, 4),
                  models=["hybrid", "transformer"])
    alone = assemble(tmp_path / "other", [1.0], out2)
    assert alone["points"] == [] and alone["partial"][0]["seeds"] == [3, 4]
    assert set(alone["partial"][0]["models"]) == {HYBRID, TRANSFORMER}

    # nor does a part on other benches replace a whole point
    _finished_run(run_dir(tmp_path / "more", 1.0), 1.0, 0, 0, seeds=(5, 6), models=["fcn"])
    kept = assemble(tmp_path / "more", [1.0], out)
    assert kept["points"] == whole["points"] and kept["partial"] == []


def test_a_training_finished_on_another_device_is_named_per_seed(tmp_path):
    """A GPU run finished on the CPU (``--finish-on cpu``): the seed whose training moved names
    both devices in order, the others the run's; trainings cached before trainings recorded
    their devices count as the run's."""
    run = run_dir(tmp_path, 1.0)
    _finished_run(run, 1.0, 0.3, 0.6, seeds=(1, 2), models=["hybrid", "transformer"],
                  device="cuda")
    results = json.loads((run / "results.json").read_text())
    results["training"]["hybrid full 1.0 seed 1"]["devices"] = ["cuda", "cpu"]
    results["training"]["hybrid full 1.0 seed 2"]["devices"] = ["cuda"]
    (run / "results.json").write_text(json.dumps(results))
    curve = assemble(tmp_path, [1.0], tmp_path / "curve" / "learning_curve.json")
    assert curve["partial"][0]["devices"] == {
        HYBRID: "cuda then cpu (seed 1); cuda (seed 2)", TRANSFORMER: "cuda"}
    page = (tmp_path / "curve" / "README.md").read_text()
    assert "cuda then cpu (seed 1); cuda (seed 2) (Hybrid (ours))" in page


@pytest.mark.slow
def test_the_table_says_which_recipe_settings_each_scale_trained_with(tmp_path):
    """A recipe change retrains the model at the scales run after it: the page names the
    settings per scale, so a curve across the change is not read as one recipe's."""
    work, out = tmp_path / "work", tmp_path / "curve" / "learning_curve.json"
    _finished_run(run_dir(work, 0.05), 0.05, 0.4, 1.1, hybrid_optimiser={"max_epochs": 300})
    _finished_run(run_dir(work, 0.1), 0.1, 0.4, 1.1,
                  hybrid_optimiser={"max_epochs": 300, "chunk_supervised": 25})
    curve = assemble(work, [0.05, 0.1], out)
    assert curve["points"][1]["optimiser"] == {
        HYBRID: [{"max_epochs": 300, "chunk_supervised": 25}], TRANSFORMER: [{}], "FCN": [{}]}
    page = (out.parent / "README.md").read_text()
    assert ('- Hybrid (ours): `{"max_epochs": 300}` at scale 0.05; '
            '`{"chunk_supervised": 25, "max_epochs": 300}` at scale 0.1') in page
    assert "- Transformer (paper):" not in page  # the defaults everywhere: nothing to say


def _point(scale, minutes, hybrid, transformer, verdict="hybrid ahead"):
    spread = lambda x: {"mean": x, "std": 0.01}  # noqa: E731
    models = {label: {"causal": {a: spread(x) for a in ("Fx", "Fy", "Fz")}}
              for label, x in ((HYBRID, hybrid), (TRANSFORMER, transformer))}
    v = {"causal": {a: {"verdict": verdict, "ratio": hybrid / transformer}
                    for a in ("Fx", "Fy", "Fz")}}
    return {"scale": scale, "training_minutes": minutes, "models": models,
            "hybrid_vs_transformer": v}


def test_where_the_transformer_matches_and_how_much_data_it_needs():
    points = [_point(0.05, 10.0, 0.5, 1.6), _point(0.1, 20.0, 0.4, 0.8),
              _point(0.25, 50.0, 0.3, 0.2, verdict="transformer ahead")]
    cross = crossovers(points)
    assert cross["Fx"] == {"scale": 0.25, "minutes": 50.0, "verdict": "transformer ahead"}
    eff = data_efficiency(points, 0.1)["Fx"]
    # the transformer falls from 0.8 % at 20 min to 0.2 % at 50 min; 0.4 % lies halfway in log
    assert eff["bound"] == "interpolated"
    assert math.isclose(eff["transformer_minutes"], 20.0 * 2.5 ** 0.5)
    assert math.isclose(eff["ratio"], 2.5 ** 0.5)
    short = data_efficiency(points[:2], 0.1)["Fx"]  # never reaches 0.4 % within 20 min
    assert short["bound"] == "more than" and short["transformer_minutes"] == 20.0
    assert crossovers(points[:2])["Fx"] is None
    lines = standing({"points": points[:2], "crossover": crossovers(points[:2]),
                      "efficiency_scale": 0.1, "data_efficiency": data_efficiency(points[:2])})
    assert "- Fx: the hybrid is ahead at every measured scale (0.05, 0.1)." in lines
    assert any("more than 20 min" in line for line in lines)


def test_lanes_start_the_longest_trainings_first():
    assert lane_jobs([1, 2], ["hybrid", "transformer", "fcn", "rocket"]) == [
        (1, "transformer"), (2, "transformer"), (1, "hybrid"), (2, "hybrid"),
        (1, "fcn"), (2, "fcn"), (1, "rocket"), (2, "rocket")]
    assert lane_jobs([3], ["lstm", "fcn"]) == [(3, "lstm"), (3, "fcn")]  # unranked: costliest


@pytest.mark.e2e
def test_lanes_prepare_each_bench_once_then_train_and_name_the_log_of_a_failed_call(
        tmp_path, monkeypatch):
    import subprocess
    calls = []

    def fake_run(cmd, stdout, stderr):
        flags = [k for k in range(2, len(cmd)) if cmd[k].startswith("--")]
        args = {cmd[k]: cmd[k + 1] for k in flags if k + 1 in range(len(cmd))
                and not cmd[k + 1].startswith("--")}
        what = "bench" if "--benches-only" in cmd else args["--models"]
        calls.append((int(args["--seeds"]), what))
        assert (args["--scales"], args["--threads"], args["--device"], args["--work"]) == (
            "0.5", "1", "cuda", str(tmp_path))
        return subprocess.CompletedProcess(cmd, 3 if calls[-1] == (2, "bench") else 0)

    monkeypatch.setattr(subprocess, "run", fake_run)
    run_lanes(tmp_path, 0.5, [1], ["rocket", "transformer"], 1, 1, "cuda")  # one lane: in order
    assert calls == [(1, "bench"), (1, "transformer"), (1, "rocket")]
    run = run_dir(tmp_path, 0.5)  # claimed for the bench, holding nothing else
    assert [p.relative_to(run).as_posix() for p in run.rglob("*") if p.is_file()] == [
        "work/scale.json"]

    calls.clear()  # a failed bench stops the scale before any training
    try:
        run_lanes(tmp_path, 0.5, [1, 2], ["transformer"], 2, 1, "cuda")
    except RuntimeError as e:
        assert "bench_seed2" in str(e) and "bench_seed2.log" in str(e)
        assert "bench_seed1" not in str(e)
    else:
        raise AssertionError("a failed lane call must raise")
    assert sorted(calls) == [(1, "bench"), (2, "bench")]


def test_the_command_refuses_unknown_models_and_lanes_below_one(tmp_path, capsys):
    for argv in (["--models", "gpt"], ["--lanes", "0"]):
        try:
            main(argv + ["--work", str(tmp_path), "--json", str(tmp_path / "c.json")])
        except SystemExit as e:
            assert e.code == 2
        else:
            raise AssertionError(f"{argv} must be refused")
    err = capsys.readouterr().err
    assert "unknown ['gpt']" in err and "at least 1" in err
    assert list(tmp_path.iterdir()) == []  # refused before anything is written
