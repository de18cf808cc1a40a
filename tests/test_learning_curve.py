"""benchmarks/learning_curve.py assembles finished reproduce runs into the curve: minutes of
training data from the benches, the spread rule between the hybrid and the paper transformer,
unfinished scales listed as missing, and a table and one figure per axis beside the JSON."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.learning_curve import HYBRID, TRANSFORMER, assemble, run_dir  # noqa: E402


def _spread(mean, std):
    return {"nrmse_pct": {"mean": mean, "std": std, "n": 2}}


def _finished_run(out: Path, scale: float, hybrid_fx: float, transformer_fx: float) -> None:
    for seed in (1, 2):
        data = out / "work" / "data" / f"automated_seed{seed}"
        data.mkdir(parents=True)
        trials = [{"split": "train", "rows": 6000 * seed}, {"split": "test", "rows": 999}]
        (data / "metadata.json").write_text(json.dumps({"sample_rate_hz": 100.0,
                                                        "trials": trials}))
    axes = lambda fx: {"Fx": _spread(fx, 0.05), "Fy": _spread(1.0, 0.05),  # noqa: E731
                       "Fz": _spread(2.0, 0.5)}
    per_metric = {HYBRID: axes(hybrid_fx), TRANSFORMER: axes(transformer_fx)}
    (out / "results.json").write_text(json.dumps({
        "call": {"scale": scale, "seeds": [1, 2]}, "benches": {"a": "2.1", "b": "2.1"},
        "all_converged": True, "automated": {"causal": per_metric, "paper": per_metric,
                                             "causal_lowpass": per_metric}}))


def test_the_curve_holds_finished_scales_their_minutes_and_the_spread_rule(tmp_path):
    work = tmp_path / "work"
    _finished_run(run_dir(work, 0.05), 0.05, hybrid_fx=0.4, transformer_fx=1.1)
    _finished_run(run_dir(work, 0.1), 0.1, hybrid_fx=0.6, transformer_fx=0.62)
    run_dir(work, 0.25).mkdir(parents=True)  # started, not finished: not a point yet
    out = tmp_path / "curve" / "learning_curve.json"
    curve = assemble(work, [0.05, 0.1, 0.25], out)
    assert [p["scale"] for p in curve["points"]] == [0.05, 0.1]
    assert curve["missing_scales"] == [0.25]
    assert curve["points"][0]["training_minutes"] == 1.5  # 60 s and 120 s of training rows
    fx = [p["hybrid_vs_transformer"]["causal"]["Fx"]["verdict"] for p in curve["points"]]
    assert fx == ["hybrid ahead", "tie"]
    assert curve["points"][0]["hybrid_vs_transformer"]["causal"]["Fz"]["verdict"] == "tie"
    assert json.loads(out.read_text())["points"] == json.loads(json.dumps(curve["points"]))
    page = (out.parent / "README.md").read_text()
    assert "| 0.1 | | | | hybrid / transformer | 0.97x (tie)" in page
    assert "Scales not yet measured: 0.25." in page
    assert sorted(p.name for p in out.parent.glob("*.png")) == ["Fx.png", "Fy.png", "Fz.png"]
