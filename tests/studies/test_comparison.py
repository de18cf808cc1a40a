"""studies/comparison.py: the point and its table from a reproduce result (nothing trained), and
the seeds it refuses."""

import pytest

from studies import comparison


def _results(errors: dict, converged=None) -> dict:
    """A reproduce result: per model, per seed, one causal error per axis (the paper metric
    twice it)."""
    from psmforce.experiments.plan import plan
    seeds = [101, 102, 103]
    per_seed = {mt: {plan(m).label: [{a: k * v for a in comparison.AXES} for v in vals]
                     for m, vals in errors.items()} for mt, k in (("causal", 1), ("paper", 2))}
    training = {f"{m} full 1.0 seed {s}": {"epochs_run": 30, "converged": (converged or {}).get(
        m, True), "stopped_by": "patience"} for m in errors for s in seeds}
    by_condition = {"Free": {"causal": {plan(m).label: {a: {"rmse_n": {
        "mean": 0.01 * sum(vals) / len(vals), "std": 0.001}} for a in comparison.AXES}
        for m, vals in errors.items()}}}
    return {"automated_nrmse_pct_per_seed": per_seed, "training": training,
            "automated_by_condition": by_condition,
            "call": {"models": list(errors), "seeds": seeds, "device": "cpu"},
            "benches": {f"automated seed {s}": "2.3" for s in seeds}}


def test_the_point_pairs_the_hybrid_with_each_model_and_keeps_the_unconverged_out():
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [2.0, 4.1, 2.9],
                    "fcn": [1.0, 2.1, 1.4]}, converged={"fcn": False})
    p = comparison.point(res, "2.3", 0.1, 1.0)
    hybrid = p["models"]["hybrid"]["summary"]["causal"]["Fx"]
    assert hybrid["mean"] == pytest.approx(1.5) and hybrid["sd"] == pytest.approx(0.5)  # ddof 1
    t = p["paired"]["transformer"]["causal"]["Fx"]
    assert t["verdict"] == "ahead" and t["high"] < 1.0            # about 0.5x on every seed
    assert p["not_converged"] == ["fcn"] and "fcn" not in p["paired"]
    assert p["not_compared"] == ["fcn"]
    text = comparison.table({"points": {"2.3 scale 0.1": p}})
    assert "| hybrid / Transformer (paper) | 0.5" in text and "| FCN |" in text
    assert "| NO |" in text and "Not compared" in text
    assert "| model | Free Fx | Free Fy | Free Fz |" in text
    assert "| Transformer (paper) | 0.030 ± 0.001 |" in text        # mean of 2.0, 4.1, 2.9 / 100


def test_a_tie_when_the_interval_holds_one():
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [0.8, 2.5, 1.5]})
    p = comparison.point(res, "2.3", 0.1, 1.0)
    r = p["paired"]["transformer"]["causal"]["Fx"]
    assert r["low"] < 1.0 < r["high"] and r["verdict"] == "tie"


def test_design_and_undeclared_seeds_are_refused(tmp_path):
    for seeds in (["1", "101"], ["999"]):
        with pytest.raises(SystemExit):
            comparison.main(["--scale", "0.1", "--seeds", *seeds, "--json",
                             str(tmp_path / "c.json"), "--work", str(tmp_path)])
    assert not (tmp_path / "c.json").exists()


def test_a_results_file_that_is_not_a_comparison_is_refused_in_one_line_and_kept(tmp_path,
                                                                                  capsys):
    bad = tmp_path / "c.json"
    for text in ('{"points": [1]', '{"points": [1]}', '[1]'):
        bad.write_text(text)
        assert comparison.main(["--scale", "0.1", "--json", str(bad), "--work",
                                str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert "c.json: not a comparison's results" in err and "Traceback" not in err
        assert bad.read_text() == text


def test_the_first_screen_states_each_point_with_its_interval_and_the_bench_against_the_robot():
    from reports.readme_page import fresh_comparison
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [0.8, 2.5, 1.5],
                    "fcn": [1.0, 2.1, 1.4]}, converged={"fcn": False})
    p = comparison.point(res, "2.3", 0.1, 1.0)
    calibration = {"rows": [{"candidate": "2.3", "paper_budget": True, "label": "FCN",
                             "seeds": [1], "ratio": {"Fx": 0.8, "Fy": 1.1, "Fz": 0.9}}],
                   "verdicts": {"2.3": {"transformer_held_out": "not checked"}}}
    text = fresh_comparison({"points": {"2.3 scale 0.1": p}}, calibration)
    assert "| hybrid / Transformer (paper) | 1.00x [" in text and "] tie" in text  # holds 1
    assert "| hybrid / FCN" not in text and "| FCN (NOT converged) |" in text
    assert "The hybrid is against the Transformer (paper) tied on every axis on both metrics." \
        in text
    assert "NOT converged: fcn" in text and "Not compared (a training did not stop early): fcn" \
        in text
    assert "FCN 0.80x / 1.10x / 0.90x" in text and "held-out check, not run yet" in text
    assert "not measured yet, so nothing is claimed there: scale 0.25, 1 (" in text
    assert "No comparison on fresh seeds yet" in fresh_comparison({"points": {}})


def test_the_first_screen_words_each_verdict_by_axis_and_metric():
    from reports.readme_page import fresh_comparison
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [2.0, 4.1, 2.9]})
    p = comparison.point(res, "2.3", 0.1, 1.0)
    p["paired"]["transformer"]["paper"]["Fy"]["verdict"] = "behind"
    text = fresh_comparison({"points": {"2.3 scale 0.1": p}})
    assert ("against the Transformer (paper) causal ahead on every axis; paper metric ahead on "
            "Fx and Fz, behind on Fy.") in text
