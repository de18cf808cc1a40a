"""Pieces of the reproduction: tables, ablation inputs, teleoperation folds, budgets."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from psmforce.estimators.data.dataset import FEATURE_SETS, Trial
from psmforce.estimators.data import hybrid_inputs as hybrid_mod
from psmforce.estimators.data.hybrid_inputs import hybrid_feature_set
from psmforce.estimators.networks.recipes import RECIPES
from psmforce.experiments.reproduce import (BUDGETS, _checkpoint, _config, _recipe_params,
                                            _regime_parameter, _teleop_folds, reproduce,
                                            task_device)
from psmforce.estimators.evaluation.tables import (SPREAD, automated_table, compare, mean_std,
                                                  spread, spread_table, spread_text,
                                                  std_over_seeds, teleop_table, verdicts)


def _m(v: float) -> dict:
    return {a: {"range_n": 5.0, "rmse_n": v, "nrmse_pct": 20 * v, "r2_pct": 90.0}
            for a in ("Fx", "Fy", "Fz")}


def test_automated_table_layout_and_bold_best():
    md = automated_table({"A": _m(0.2), "B": _m(0.1)}, "t")
    lines = md.strip().splitlines()
    assert lines[0] == "**t**"
    assert lines[2].startswith("| Axis | Range (N) | A RMSE (N) | A NRMSE (%) | A R² (%) | B RMSE")
    assert lines[4] == "| Fx | 5.00 | 0.200 | 4.00 | 90.00 | 0.100 | **2.00** | 90.00 |"


def test_teleop_table_mean_and_sample_std_over_folds():
    md = teleop_table({"A": {"Rigid/Unseen": [_m(0.1), _m(0.3)]}})
    row = md.strip().splitlines()[2]   # RMSE 0.1, 0.3: sample std 0.1 * sqrt(2)
    assert row == ("| Rigid | Unseen | Fx | 5.00 ± 0.00 | 0.20 ± 0.14 | 4.00 ± 2.83 | "
                   "90.00 ± 0.00 |")
    one = teleop_table({"A": {"Rigid/Unseen": [_m(0.1)]}}).strip().splitlines()[2]
    assert one == "| Rigid | Unseen | Fx | 5.00 | 0.10 | 2.00 | 90.00 |"   # one fold: no ±


def test_the_spread_over_seeds_is_the_sample_std_and_one_seed_has_none():
    assert std_over_seeds([1.0, 3.0]) == pytest.approx(np.sqrt(2.0))   # ddof 1, not 1.0
    assert std_over_seeds([2.0]) is None
    assert mean_std([1.0, 3.0]) == {"mean": 2.0, "std": pytest.approx(np.sqrt(2.0)), "n": 2}
    assert mean_std([2.0]) == {"mean": 2.0, "std": None, "n": 1}
    s = spread([_m(0.1), _m(0.3)])["Fx"]["rmse_n"]
    assert s["std"] == pytest.approx(0.1 * np.sqrt(2.0)) and s["n"] == 2
    assert spread([_m(0.1)])["Fx"]["rmse_n"]["std"] is None
    assert spread_text({"mean": 2.0, "std": np.sqrt(2.0)}) == "2.00 ± 1.41"
    assert spread_text({"mean": 2.0, "std": None}) == spread_text({"mean": 2.0, "std": np.nan}) \
        == "2.00"


def test_without_a_spread_the_rule_says_tie():
    far, near = {"mean": 1.0, "std": 0.1}, {"mean": 9.0, "std": 0.1}
    assert compare(far, near) == -1 and compare(near, far) == 1
    for one_seed in ({"mean": 9.0, "std": None}, {"mean": 9.0, "std": np.nan}):
        assert compare(far, one_seed) == 0 and compare(one_seed, far) == 0
    v = verdicts(_spread({"A": (1.0, 0.1), "B": (9.0, None), "C": (9.0, 0.1)}))
    assert v["Fx"] == {"best": "A", "win": False, "tied_with": ["B"]}
    v = verdicts(_spread({"A": (1.0, None), "B": (9.0, 0.1)}))
    assert v["Fx"] == {"best": "A", "win": False, "tied_with": ["B"]}
    table = spread_table(_spread({"A": (1.0, None), "B": (9.0, 0.1)}), None, "t")
    assert "| A | 1.00 (tie) |" in table and "| B | 9.00 ± 0.10 (tie) |" in table


def test_ablations_drop_the_compensated_columns_of_the_removed_sources():
    feats, base = hybrid_feature_set(None)
    assert feats == hybrid_mod.HYBRID_INPUTS and base == hybrid_mod.BASE_COLUMNS
    no_hex10, base = hybrid_feature_set("no_hex10")
    assert len(no_hex10) == 19 and base == hybrid_mod.BASE_COLUMNS
    assert not set(no_hex10) & set(hybrid_mod.COMPENSATED_HEX10)
    assert {hybrid_mod.PRIOR_FZ, hybrid_mod.INSERTION_FZ} <= set(no_hex10)  # the prior's outputs
    assert len(hybrid_feature_set("no_efforts")[0]) == 18
    # an ablation removes its whole signal group: the insertion state's position or velocity too
    velocity, position = hybrid_mod.INSERTION_STATE
    for name, insertion in (("no_positions_velocities", {velocity, position}),
                            ("no_positions", {position}), ("no_velocities", {velocity})):
        assert set(hybrid_feature_set(name)[0]) == (
            set(feats) - (set(FEATURE_SETS["paper"]) - set(FEATURE_SETS[name])) - insertion)
    raw, raw_base = hybrid_feature_set(None, use_prior=False)
    assert raw == FEATURE_SETS["paper"] and raw_base == ("fx", "fy", "fz")


def test_teleop_folds_leave_one_configuration_out():
    trials = [Trial(f"config_{c}/{cond}/demo_{k}.csv", cond, f"config_{c}", pd.DataFrame())
              for c in range(3) for cond in ("Rigid", "Soft", "Free") for k in range(3)]

    class _DS:
        def __init__(self, trials):
            self.trials = trials

        def select(self, split=None, condition=None):
            return [t for t in self.trials if (split is None or t.split == split)
                    and (condition is None or t.condition == condition)]
    folds = _teleop_folds(_DS(trials))
    assert [f["unseen"] for f in folds] == ["config_0", "config_1", "config_2"]
    for f in folds:
        assert len(f["train"]) == 12 and len(f["seen_test"]) == 6 and len(f["unseen_test"]) == 9
        assert all(t.split != f["unseen"] for t in f["train"] + f["seen_test"])
        assert all(t.path.endswith("demo_2.csv") for t in f["seen_test"])
        assert not {t.path for t in f["train"]} & {t.path for t in f["seen_test"]}


def _own(stage: str, budget: str, model: str, regime: str = "own"):
    optimiser = _recipe_params(model, "full", regime)["optimiser"]
    return _config(budget, stage, 0, "cpu", model, optimiser)


def test_budgets_keep_the_papers_optimiser_settings():
    full = _own("pretrain", "full", "transformer")
    assert (full.max_epochs, full.lr, full.weight_decay, full.batch_size, full.patience,
            full.lr_patience, full.stride) == (100, 1e-3, 1e-4, 256, 10, 3, 5)
    assert full.max_batches_per_epoch is None and full.max_val_batches is None
    lstm = _own("pretrain", "cpu", "lstm")
    assert (lstm.lr, lstm.weight_decay, lstm.chunk) == (5e-3, 1e-6, 1000)
    tele_lstm = _own("finetune", "full", "lstm")
    assert (tele_lstm.lr, tele_lstm.weight_decay, tele_lstm.chunk) == (1e-3, 1e-4, 1000)
    hybrid = _own("pretrain", "full", "hybrid")
    assert hybrid.max_epochs == 300 and hybrid.max_batches_per_epoch is None
    assert _own("pretrain", "quick", "hybrid").max_epochs == 2   # caps win
    assert set(BUDGETS) == {"full", "cpu", "quick"}
    for stage in BUDGETS["full"].values():   # the published budget caps nothing
        assert not any(k.startswith("max_") for caps in stage.values() for k in caps)


def test_a_regime_swaps_the_recipes_and_keys_its_own_tasks():
    swapped = _own("pretrain", "full", "hybrid", "paper")
    assert (swapped.chunk_supervised, swapped.chunk_stride, swapped.max_epochs) == (1, 5, 100)
    dense = _own("pretrain", "full", "transformer", "dense")
    assert (dense.stride, dense.max_epochs, dense.lr) == (1, 300, 1e-3)
    assert _regime_parameter("own", "hybrid") == {} and _regime_parameter("dense", "rocket") == {}
    p = {"model": "hybrid", "variant": "full", "fraction": 1.0, "seed": 1, "budget": "full",
         "device": "cpu"}
    own = _checkpoint("run", p)
    assert _checkpoint("run", {**p, **_regime_parameter("paper", "hybrid")}) != own
    assert own.name == "hybrid_full_f1.0_seed1_full_cpu.pt"   # runs before regimes keep theirs
    with pytest.raises(ValueError, match="training regime"):
        reproduce("unused", regime="fast")


def _spread(means: dict) -> dict:
    return {m: {a: {"nrmse_pct": {"mean": mu, "std": sd, "n": 3}} for a in ("Fx", "Fy", "Fz")}
            for m, (mu, sd) in means.items()}


def test_a_win_needs_to_clear_the_spread():
    v = verdicts(_spread({"A": (1.0, 0.1), "B": (1.5, 0.2), "C": (3.0, 0.1)}))
    assert v["Fx"] == {"best": "A", "win": True, "tied_with": []}
    v = verdicts(_spread({"A": (1.0, 0.3), "B": (1.5, 0.3), "C": (3.0, 0.1)}))
    assert v["Fx"] == {"best": "A", "win": False, "tied_with": ["B"]}


@pytest.mark.slow
def test_reproduce_resumes_and_reports_convergence(tmp_path, monkeypatch):
    """A tiny grid end to end: two seeds, spread and floors, convergence recorded per run; a
    rerun reuses every task (no training), a changed recipe reruns its model's tasks only, and
    a run at another scale is refused."""
    logs: list[str] = []
    rocket = ("rocket",) if importlib.util.find_spec("aeon") else ()
    if rocket:  # the fewest kernels and windows it takes: the grid's path, not the regressor, is
        # under test here (tests/estimators/test_rocket.py tests the regressor at its own sizes)
        small = dict(n_kernels_multirocket=84, n_kernels_hydra=16, max_train_windows=2000)
        build = RECIPES["rocket"].build
        monkeypatch.setitem(RECIPES, "rocket", dataclasses.replace(
            RECIPES["rocket"], build=lambda n, config: build(n, {**small, **config})))
    kw = dict(scale=0.01, seeds=(1, 2), budget="quick", models=("fcn", "hybrid") + rocket,
              ablations=False, efficiency=False, teleop=False)
    r = reproduce(tmp_path / "run", log=logs.append, **kw)
    assert r["automated"]["causal"]["FCN"]["Fx"]["nrmse_pct"]["n"] == 2
    assert r["floor"]["automated"]["causal"]["Fx"]["nrmse_pct"]["mean"] == 0.0
    assert r["floor"]["automated"]["paper"]["Fx"]["nrmse_pct"]["mean"] > 0.0
    assert not r["all_converged"]          # quick caps batches: never called converged
    for name, t in r["training"].items():
        if name.startswith("rocket"):     # closed form: converged by construction
            assert t["converged"] and t["stopped_by"] == "closed form"
        else:
            assert not t["converged"] and (t["capped"] or t["stopped_by"] == "epoch_limit")
    if rocket:
        assert r["automated"]["causal"]["MultiRocket-Hydra"]["Fz"]["nrmse_pct"]["n"] == 2
    from psmforce.sim.dataset import SIM_VERSION
    assert r["benches"] == {"automated seed 1": SIM_VERSION, "automated seed 2": SIM_VERSION}
    md = (tmp_path / "run" / "results.md").read_text()
    assert "not converged" in md and "floor (truth post-processed)" in md
    assert f"simulator versions of the benches: ['{SIM_VERSION}']" in md
    assert (tmp_path / "run" / "figures" / "learning_curves.png").exists()
    logs.clear()   # moved elsewhere (another folder, or another machine's): read back as it is
    run = (tmp_path / "run").rename(tmp_path / "moved")
    shutil.rmtree(run / "figures")   # redrawn from the checkpoints where they are now
    again = reproduce(run, log=logs.append, **kw)
    assert not any("to run" in line and not line.endswith("0 to run") for line in logs)
    assert again["automated"] == r["automated"]
    assert (run / "figures" / "automated_time_series.png").exists()
    logs.clear()   # another optimiser for the FCN: its two trainings are stale, the rest is not
    monkeypatch.setitem(RECIPES, "fcn", dataclasses.replace(RECIPES["fcn"], optimiser={"lr": 2e-3}))
    import psmforce.experiments.reproduce as rep
    with monkeypatch.context() as m:  # what is checked here is which tasks rerun; the figures
        # (each network predicting over the test set: a tenth of this test) are checked drawn by
        # the two calls above and not looked at after this one
        m.setattr(rep, "_figures", lambda *args, **kwargs: [])
        reproduce(run, log=logs.append, **kw)
    assert [line for line in logs if "to run" in line and not line.endswith("0 to run")] == [
        f"grid: {2 * len(kw['models'])} tasks, {2 * len(kw['models']) - 2} cached, 2 to run"]
    if rocket:   # a closed-form fit never touches the run's device: a GPU run reuses the CPU's
        logs.clear()
        on_gpu = reproduce(run, log=logs.append,
                           **{**kw, "models": rocket, "device": "cuda"})
        assert not any("to run" in line and not line.endswith("0 to run") for line in logs)
        assert "grid: 2 tasks, 2 cached, 0 to run" in logs   # the two rocket fits
        assert on_gpu["call"]["device"] == "cuda"
        assert (on_gpu["automated"]["causal"]["MultiRocket-Hydra"]
                == r["automated"]["causal"]["MultiRocket-Hydra"])
    with pytest.raises(ValueError, match="another bench"):
        reproduce(run, **{**kw, "scale": 0.02})
    with pytest.raises(ValueError, match="another bench"):
        reproduce(run, **{**kw, "port": "cannula"})


@pytest.mark.slow
def test_reproduce_on_a_bench_with_a_port(tmp_path):
    """``port`` simulates every bench of the run through that cannula, is recorded in the call,
    and an unknown port is refused before anything is written."""
    with pytest.raises(ValueError, match="port"):
        reproduce(tmp_path / "bad", scale=0.01, seeds=(1,), port="trocar")
    assert not (tmp_path / "bad").exists()
    r = reproduce(tmp_path / "run", scale=0.01, seeds=(1,), budget="quick", models=("fcn",),
                  ablations=False, efficiency=False, teleop=False, port="cannula",
                  log=lambda _: None)
    assert r["call"]["port"] == "cannula"
    meta = json.loads((tmp_path / "run" / "work" / "data" / "automated_seed1" /
                       "metadata.json").read_text())
    assert meta["port"]["name"] == "cannula"


def test_only_the_networks_follow_the_runs_device():
    assert task_device("hybrid", "cuda") == "cuda" and task_device("fcn", "cpu") == "cpu"
    assert task_device("rocket", "cuda") == "cpu"   # MultiRocket-Hydra fits in closed form


TINY = dict(scale=0.01, seeds=(1,), budget="quick", models=("fcn",), ablations=False,
            efficiency=False, teleop=False, log=lambda _: None)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """One FCN seed on a tiny bench, trained uninterrupted: (run folder, results)."""
    run = tmp_path_factory.mktemp("tiny") / "run"
    return run, reproduce(run, **TINY)


@pytest.mark.slow
def test_a_task_derives_only_the_columns_its_model_reads(tiny_run):
    """``_load`` adds the derived columns asked for and no others (the LSTM's Jacobian maps are
    the costly ones), and each model's pretraining asks for its recipe's derivation."""
    from psmforce.experiments.reproduce import _derivation, _load
    run = str((tiny_run[0] / "work").resolve())

    def columns(derivations):
        return set(_load(run, "automated", 1, derivations).trials[0].frame.columns)

    recorded = columns(())
    lstm, prior = columns(("lstm",)) - recorded, columns(("prior",)) - recorded
    assert lstm and prior and not lstm & prior
    assert set(_load(run, "automated", 1).trials[0].frame.columns) == recorded | lstm | prior
    assert _derivation("lstm", "full") == "lstm"
    assert _derivation("hybrid", "full") == "prior" and _derivation("hybrid", "no_prior") == "none"
    assert _derivation("transformer", "full") == RECIPES["transformer"].inputs().derivation


@pytest.mark.slow
def test_a_task_killed_while_scoring_resumes_its_finished_training(tiny_run, tmp_path,
                                                                    monkeypatch):
    """The training state is cleared only once the test scores are in: a task that dies while
    scoring (a session's end) reruns no epoch, and ends as an uninterrupted run does."""
    import io

    import torch

    import psmforce.experiments.reproduce as rep
    kw, (whole_run, whole) = TINY, tiny_run
    scores = rep._scores

    def killed(*args, **kwargs):
        raise KeyboardInterrupt("killed while scoring")

    monkeypatch.setattr(rep, "_scores", killed)
    with pytest.raises(KeyboardInterrupt):
        reproduce(tmp_path / "run", **kw)
    [state] = (tmp_path / "run" / "work" / "resume").glob("*.state")
    saved = torch.load(io.BytesIO(torch.load(state, weights_only=True)["payload"]),
                       weights_only=True)["history"]
    monkeypatch.setattr(rep, "_scores", scores)
    again = reproduce(tmp_path / "run", **kw)
    assert not state.exists()
    assert again["automated"] == whole["automated"]

    def history(run):
        [task] = (run / "work" / "cache").glob("pretrain-*.json")
        return json.loads(task.read_text())["result"]["training"]["history"]

    resumed = history(tmp_path / "run")   # the saved epochs' own wall-clock stamps: none again
    assert [h["elapsed_s"] for h in resumed] == [h["elapsed_s"] for h in saved]
    assert ([(h["train_loss"], h["val_loss"]) for h in resumed]
            == [(h["train_loss"], h["val_loss"]) for h in history(whole_run)])


@pytest.mark.slow
def test_a_run_moved_without_its_benches_simulates_them_again(tmp_path, monkeypatch):
    """Only the benches are large: a run folder copied without ``work/data`` has each seed's
    bench simulated again (byte for byte here) and its prior fitted again (the same parameters;
    only the fit's wall time differs), not trusted from the cache; a bench that comes back other
    bytes is refused, since the run's cached results were computed on the first."""
    from psmforce.experiments.reproduce import prepare_benches
    logs: list[str] = []
    prepare_benches(tmp_path / "run", 0.01, (1,), teleop=False, log=logs.append)
    data = tmp_path / "run" / "work" / "data"

    def bench():
        files = {p.relative_to(data): p.read_bytes() for p in data.rglob("*") if p.is_file()}
        prior = json.loads(files.pop(Path("prior_seed1.json")))
        return files, {k: v for k, v in prior.items() if k not in ("info", "sha256")}

    before = bench()
    shutil.rmtree(data)
    logs.clear()
    prepare_benches(tmp_path / "run", 0.01, (1,), teleop=False, log=logs.append)
    assert any("simulating it again" in line for line in logs)
    assert bench() == before
    logs.clear()   # with its bench on disk, nothing runs again
    prepare_benches(tmp_path / "run", 0.01, (1,), teleop=False, log=logs.append)
    assert not any("simulating" in line or line.endswith(" 1 to run") for line in logs)

    # simulated again into other bytes (as other library versions might): refused, every time
    import psmforce.sim
    cache = tmp_path / "run" / "work" / "cache"
    record = next(cache.glob("simulate-*.json")).read_bytes()
    simulate = psmforce.sim.simulate

    def other_bytes(*args, **kwargs):
        summary = simulate(*args, **kwargs)
        first = sorted((data / "automated_seed1" / "train").rglob("*.csv"))[0]
        first.write_text(first.read_text().replace("0", "1", 1))
        return summary

    shutil.rmtree(data)
    monkeypatch.setattr(psmforce.sim, "simulate", other_bytes)
    for _ in range(2):
        with pytest.raises(ValueError, match="bench automated seed 1 simulated again .* differs"):
            prepare_benches(tmp_path / "run", 0.01, (1,), teleop=False, log=logs.append)
        assert not data.joinpath("automated_seed1").exists()
        assert not data.joinpath("prior_seed1.json").exists()
        assert next(cache.glob("simulate-*.json")).read_bytes() == record
    monkeypatch.setattr(psmforce.sim, "simulate", simulate)   # the same files again: accepted
    prepare_benches(tmp_path / "run", 0.01, (1,), teleop=False, log=logs.append)
    assert bench() == before


@pytest.mark.slow
def test_the_figures_networks_predict_on_the_runs_device(tiny_run, tmp_path, monkeypatch):
    """The figures' predictions over the first seed's test set run where the networks trained
    (a transformer over a paper-scale test set is minutes on a CPU): checked with the device
    recorded and the work done on the CPU, which is all this machine may have."""
    import psmforce.experiments.reproduce as rep
    asked = []
    load, predict = rep.load_checkpoint, rep.predict_trial
    monkeypatch.setattr(rep, "load_checkpoint",
                        lambda path, device="cpu": asked.append(("load", device)) or load(path))
    monkeypatch.setattr(rep, "predict_trial", lambda ckpt, trial, device="cpu": asked.append(
        ("predict", device)) or predict(ckpt, trial))
    run = tiny_run[0]
    work = str((run / "work").resolve())
    checkpoints = {("fcn", "full", 1.0, 1): next((run / "work" / "checkpoints").glob("fcn_*.pt"))}
    [task] = (run / "work" / "cache").glob("pretrain-*.json")
    pre_by = {("fcn", "full", 1.0, 1): json.loads(task.read_text())["result"]}
    rep._figures(tmp_path, work, 1, ["fcn"], pre_by, checkpoints, "cuda")
    assert set(asked) == {("load", "cuda"), ("predict", "cuda")}


@pytest.mark.slow
def test_a_gpu_run_finishes_on_the_cpu_under_its_keys(tiny_run, tmp_path):
    """``finish_on="cpu"``: the tasks keep the keys (and checkpoint names) of the run's device
    and compute on the CPU, so the FCN trained there equals the CPU run's to the bit, and its
    training records where it ran. The checkpoint's scalers, rebuilt from this machine's bench
    (``studies/trained_data_identity.py``), come out identical: the check's control."""
    from studies.trained_data_identity import compare_run
    from psmforce.experiments.task_cache import task_key
    from psmforce.experiments.reproduce import _pretrain_task
    run = tmp_path / "gpu_run"
    moved = reproduce(run, **{**TINY, "device": "cuda", "finish_on": "cpu"})
    assert moved["automated"] == tiny_run[1]["automated"]
    [task] = (run / "work" / "cache").glob("pretrain-*.json")
    record = json.loads(task.read_text())
    assert record["params"]["device"] == "cuda" and record["params"]["finish_on"] == "cpu"
    assert task.stem.endswith(task_key(_pretrain_task, {**record["params"], "finish_on": None}))
    assert record["result"]["training"]["devices"] == ["cpu"]
    assert [p.name for p in (run / "work" / "checkpoints").glob("*.pt")] == [
        "fcn_full_f1.0_seed1_quick_cuda.pt"]
    [(name, row)] = compare_run(run).items()
    assert row["trained_on"] == ["cpu"] and row["input_scaler"] == row["target_scaler"] == 0.0
    # a checkpoint fitted on other data (its scaler moved by 1e-3) is reported as such
    from psmforce.estimators.training.checkpoint import load_checkpoint
    path = run / "work" / "checkpoints" / name
    other = load_checkpoint(path)
    other.input_scaler.mean = other.input_scaler.mean + np.float32(1e-3)
    other.save(path)
    [(_, row)] = compare_run(run).items()
    assert row["input_scaler"] == pytest.approx(1e-3, rel=1e-3) and row["target_scaler"] == 0.0


RUN_BEFORE_THE_MOVE = Path(__file__).resolve().parents[1] / "data" / "run_made_by_0.1.0"
"""A tiny run (:data:`TINY`) made by psmforce 0.1.0, whose modules were ``hybrid`` and
``psm_model`` and whose cache keys hashed ``hybrid.reproduce:_pretrain_task`` and the like:
its cache, checkpoint, prior and results. Its bench (7.6 MB of CSV) is not committed: the test
lays it where the run had it by simulating its seed, as 0.1.0 did (the bytes differ only in the
software version its metadata records)."""


@pytest.mark.slow
def test_a_run_made_before_the_package_moved_reads_back_without_retraining(tmp_path,
                                                                          monkeypatch):
    import psmforce.experiments.reproduce as rep
    from psmforce.sim import simulate
    run = tmp_path / "run"
    shutil.copytree(RUN_BEFORE_THE_MOVE, run)
    simulate("automated", scale=TINY["scale"], seed=1, out=run / "work" / "data" / "automated_seed1")
    before = json.loads((run / "results.json").read_text())
    assert {json.loads(p.read_text())["task"].split(":")[0]
            for p in (run / "work" / "cache").glob("*.json")} == {"hybrid.reproduce"}

    def no_training(*args, **kwargs):
        raise AssertionError("a cached training ran again")

    monkeypatch.setattr(rep, "train_model", no_training)
    logs: list[str] = []
    again = reproduce(run, **{**TINY, "log": logs.append})
    # the scores read back exactly; the spread over its one seed, which the run of that time
    # wrote as a population std of 0, is none under today's rule (tables.std_over_seeds)
    assert again["spread"] == SPREAD and "spread" not in before

    def one_seed_rule(cell):
        if isinstance(cell, dict) and set(cell) == {"mean", "std", "n"}:
            return {**cell, "std": None} if cell["n"] == 1 else cell
        return {k: one_seed_rule(v) for k, v in cell.items()} if isinstance(cell, dict) else cell

    assert again["automated"] == one_seed_rule(before["automated"])
    assert "grid: 1 results cached under an earlier key read back" in logs  # the bench
    assert logs.count("grid: 1 tasks, 1 cached, 0 to run") == 3  # bench, floor, pretraining
    assert not any("to run" in line and " 0 to run" not in line for line in logs)
