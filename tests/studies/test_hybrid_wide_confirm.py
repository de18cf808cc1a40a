"""studies/hybrid_wide_confirm.py: it runs only on the seeds declared for it, pairs the wide hybrid
with every model over the seeds both finished, and applies its rule only when every declared
seed is in."""

import json

import pytest

from psmforce.experiments.seeds import COMPARISON_SEEDS, DESIGN_SEEDS, WIDE_HYBRID_SEEDS
from studies import hybrid_wide_confirm as study

DECLARED = WIDE_HYBRID_SEEDS[0.1]


@pytest.mark.parametrize("seed", [min(DESIGN_SEEDS), COMPARISON_SEEDS[0.1][0]])
def test_a_seed_not_declared_for_it_is_refused_before_anything_is_simulated(seed, tmp_path,
                                                                            capsys):
    rc = study.main(["--seed", str(seed), "--work", str(tmp_path / "w"),
                     "--json", str(tmp_path / "out.json")])
    assert rc == 2 and "not declared for this study" in capsys.readouterr().err
    assert not (tmp_path / "w").exists() and not (tmp_path / "out.json").exists()


def test_its_models_are_the_comparisons_and_the_wide_hybrid_differs_only_in_width():
    from studies.comparison import MODELS as COMPARED
    assert set(study.MODELS) == {*study.CANDIDATES, *COMPARED}
    assert study.MODELS["hybrid_wide"].changes() == ["config"]
    assert study.MODELS["hybrid_transformer"].changes() == ["model", "inputs_of"]
    assert study.MODELS["hybrid"].changes() == []
    assert set(study.LABELS) == set(study.MODELS)


def _record(fx, fy=2.0, fz=3.0, converged=True) -> dict:
    errors = {"Fx": fx, "Fy": fy, "Fz": fz}
    return {"parameters": 10, "epochs": 5, "stopped_by": "patience", "converged": converged,
            "test_nrmse_pct": {"causal": dict(errors), "paper": dict(errors)},
            "test_causal_rmse_n_by_condition": {"Free": {"Fx": 0.01, "Fy": 0.02, "Fz": 0.03}}}


def _records(wide_fx, seeds=DECLARED, **kw) -> dict:
    return {s: {"hybrid_wide": _record(wide_fx * (1 + 0.01 * k), **kw),
                "hybrid": _record(2.0), "transformer": _record(1.0 + 0.02 * k)}
            for k, s in enumerate(seeds)}


def test_the_rule_waits_for_every_declared_seed_then_judges_the_lateral_axes():
    partial = study.summarise(_records(1.5, DECLARED[:3]), 0.1)
    wide = partial["paired"]["hybrid_wide"]
    assert partial["rule"] == {"hybrid_wide": "pending"}
    assert wide["hybrid"]["seeds"] == list(DECLARED[:3])
    whole = study.summarise(_records(1.5), 0.1)
    assert whole["paired"]["hybrid_wide"]["hybrid"]["causal"]["Fx"]["verdict"] == "ahead"
    assert whole["paired"]["hybrid_wide"]["transformer"]["causal"]["Fx"]["verdict"] == "behind"
    assert whole["rule"] == {"hybrid_wide": "replaces"}
    # ahead on Fx but behind on Fz: kept
    assert study.summarise(_records(1.5, fz=4.0), 0.1)["rule"]["hybrid_wide"] == "kept"
    # a tie on both lateral axes: kept
    tie = _records(2.0)
    for k, s in enumerate(DECLARED):
        tie[s]["hybrid_wide"]["test_nrmse_pct"]["causal"]["Fx"] = 2.0 + (-0.1 if k % 2 else 0.1)
    assert study.summarise(tie, 0.1)["rule"]["hybrid_wide"] == "kept"


def test_each_candidate_is_judged_on_its_own_and_never_paired_with_the_other():
    records = _records(1.5)
    for k, s in enumerate(DECLARED):
        records[s]["hybrid_transformer"] = _record(2.0 + (-0.1 if k % 2 else 0.1))
    point = study.summarise(records, 0.1)
    assert point["rule"] == {"hybrid_wide": "replaces", "hybrid_transformer": "kept"}
    assert set(point["paired"]["hybrid_transformer"]) == {"hybrid", "transformer"}
    assert "hybrid_transformer" not in point["paired"]["hybrid_wide"]
    text = study.table({"points": {"p": point}})
    assert "| hybrid's physics + transformer / hybrid (as shipped) | 5 |" in text
    assert ("hybrid's physics, the paper transformer's network: the hybrid as shipped is kept"
            in text)


def test_the_first_screen_words_the_shipped_models_pairs_and_counts_a_partial_pair():
    from reports.readme_page import shipped_model
    records = _records(1.5)
    for k, s in enumerate(DECLARED):
        records[s]["hybrid_transformer"] = _record(1.5 * (1 + 0.01 * k))
    del records[DECLARED[-1]]["transformer"]   # its last training not in yet
    text = shipped_model({"points": {"p": study.summarise(records, 0.1)}})
    assert "against the hybrid with its causal network (`hybrid`) ahead on Fx, tied on Fy and " \
        "Fz on both metrics;" in text
    assert (f"against the paper transformer behind on Fx, tied on Fy and Fz on both metrics (on "
            f"{len(DECLARED) - 1} of the {len(DECLARED)} declared seeds so far)") in text
    assert "no paired check yet" in shipped_model({"points": {}})


def test_a_training_that_did_not_stop_early_is_not_paired():
    records = _records(1.5)
    records[DECLARED[0]]["hybrid"]["converged"] = False
    point = study.summarise(records, 0.1)
    assert DECLARED[0] not in point["paired"]["hybrid_wide"]["hybrid"]["seeds"]
    assert point["rule"] == {"hybrid_wide": "pending"}
    assert point["models"]["hybrid"]["not_converged"] == [DECLARED[0]]
    assert "not converged" in study.table({"points": {"p": point}})


def test_the_table_shows_every_model_and_the_paired_cells():
    text = study.table({"points": {"p": study.summarise(_records(1.5), 0.1)}})
    assert "| hybrid, the paper transformer's width | 5 | 1.53 ± 0.02 |" in text
    assert "| wide hybrid / hybrid (as shipped) | 5 | 0.76x [" in text
    assert "the paper transformer's width: it replaces the hybrid as shipped" in text
    assert study.table({}).strip() == "No training yet."


def test_a_record_read_back_is_checked_and_names_its_file(tmp_path):
    folder = tmp_path / f"seed{DECLARED[0]}_scale0.1" / "models"
    folder.mkdir(parents=True)
    (folder / "hybrid.json").write_text(json.dumps(_record(2.0)))
    out = study.assemble(tmp_path, tmp_path / "out.json")
    assert out["points"]["2.3 scale 0.1"]["models"]["hybrid"]["seeds"] == [DECLARED[0]]
    (folder / "fcn.json").write_text('{"parameters": 10')
    with pytest.raises(ValueError, match=r"fcn.json: not JSON"):
        study.assemble(tmp_path, tmp_path / "out.json")
    (folder / "fcn.json").write_text('{"parameters": 10}')
    with pytest.raises(ValueError, match=r"fcn.json: lacks epochs"):
        study.assemble(tmp_path, tmp_path / "out.json")
    (folder / "fcn.json").unlink()
    (folder / "gpt.json").write_text(json.dumps(_record(2.0)))
    with pytest.raises(ValueError, match=r"gpt.json: not a training of this study"):
        study.assemble(tmp_path, tmp_path / "out.json")


def test_records_the_json_holds_survive_a_fresh_work_folder_and_a_new_run_replaces_its_own(
        tmp_path):
    """``runs/`` is not committed: a new machine's run must add to the committed JSON, not
    replace it with what that machine trained."""
    first = tmp_path / "first" / f"seed{DECLARED[0]}_scale0.1" / "models"
    first.mkdir(parents=True)
    (first / "hybrid.json").write_text(json.dumps(_record(2.0)))
    (first / "fcn.json").write_text(json.dumps(_record(3.0)))
    out = tmp_path / "out.json"
    out.write_text(json.dumps(study.assemble(tmp_path / "first", out)))
    again = tmp_path / "fresh" / f"seed{DECLARED[1]}_scale0.1" / "models"   # another machine
    again.mkdir(parents=True)
    (again / "hybrid.json").write_text(json.dumps(_record(2.2)))
    redo = tmp_path / "fresh" / f"seed{DECLARED[0]}_scale0.1" / "models"
    redo.mkdir(parents=True)
    (redo / "fcn.json").write_text(json.dumps(_record(2.5)))              # trained again
    point = study.assemble(tmp_path / "fresh", out)["points"]["2.3 scale 0.1"]
    assert point["models"]["hybrid"]["seeds"] == list(DECLARED[:2])
    assert point["records"][str(DECLARED[0])]["hybrid"] == _record(2.0)  # kept from the JSON
    assert point["models"]["fcn"]["per_seed"]["causal"][0]["Fx"] == 2.5  # the new one wins
    kept = json.loads(out.read_text())
    del kept["points"]["2.3 scale 0.1"]["records"][str(DECLARED[0])]["hybrid"]["epochs"]
    out.write_text(json.dumps(kept))
    with pytest.raises(ValueError, match=rf"out.json: scale 0.1 seed {DECLARED[0]} hybrid: "
                                         r"lacks epochs"):
        study.assemble(tmp_path / "fresh", out)
    out.write_text('{"points": [1, 2]}')
    with pytest.raises(ValueError, match=r"out.json: not this study's results"):
        study.assemble(tmp_path / "fresh", out)


def test_the_cost_of_each_training_is_shown_from_its_records():
    records = _records(1.5)
    for k, s in enumerate(DECLARED):
        records[s]["hybrid"]["seconds"] = 60.0 * (2 + k)        # 2..6 minutes
        records[s]["hybrid_wide"]["seconds"] = 600.0
    text = study.table({"points": {"p": study.summarise(records, 0.1)}})
    assert "| hybrid (as shipped) | 5 | 10 | 5 | 4.0 ± 1.6 |" in text
    assert "| hybrid, the paper transformer's width | 5 | 10 | 5 | 10.0 ± 0.0 |" in text
    assert "| paper transformer | 5 |" not in text.split("| training cost |")[1]   # no seconds
    del records[DECLARED[0]]["hybrid_wide"]["seconds"]
    only = study.table({"points": {"p": study.summarise(records, 0.1)}})
    assert "| hybrid, the paper transformer's width | 5 | 10 |" not in only


def test_one_seed_shows_its_mean_without_a_spread():
    text = study.table({"points": {"p": study.summarise(_records(1.5, DECLARED[:1]), 0.1)}})
    assert "| hybrid (as shipped) | 1 | 2.00 | 2.00 | 3.00 |" in text and "nan" not in text


def _design(**by_seed) -> dict:
    """A design study's JSON: per seed, (candidate's, default's) test Fx / Fy / Fz."""
    points = {}
    for name, (new, old) in by_seed.items():
        seed = int(name[1:])
        points[name] = {"version": "2.3", "scale": 0.1, "seed": seed, "variants": {
            v: {"test_causal_nrmse_pct": dict(zip(("Fx", "Fy", "Fz"), e))}
            for v, e in (("transformer_hybrid_inputs", new), ("default", old))}}
    return {"points": points}


def test_the_design_gate_opens_only_when_every_gate_seed_agrees():
    better, worse = ((1.4, 1.6, 2.0), (1.9, 2.1, 2.3)), ((1.5, 2.2, 2.0), (1.9, 2.1, 2.3))
    assert study.design_gate("hybrid_wide", {}) == "open"             # not gated
    assert study.design_gate("hybrid_transformer", _design(s2=better)) == "pending"
    assert study.design_gate("hybrid_transformer", _design(s1=better, s2=better)) == "open"
    assert study.design_gate("hybrid_transformer", _design(s1=worse, s2=better)) == "closed"
    fz_up = ((1.8, 2.0, 2.5), (1.9, 2.1, 2.3))                        # Fz +9 %, laterals -5 %
    assert study.design_gate("hybrid_transformer", _design(s1=fz_up, s2=better)) == "closed"
    broken = _design(s1=better, s2=better)
    del broken["points"]["s1"]["variants"]["default"]["test_causal_nrmse_pct"]["Fy"]
    with pytest.raises(ValueError, match="seed 1's test errors"):
        study.design_gate("hybrid_transformer", broken)


def test_a_gated_candidate_is_not_trained_while_its_gate_is_not_open(tmp_path, monkeypatch,
                                                                     capsys):
    monkeypatch.setattr("psmforce.experiments.reproduce.prepare_benches", lambda *a, **k: None)
    design = tmp_path / "design.json"
    design.write_text(json.dumps(_design(s2=((1.4, 1.6, 2.0), (1.9, 2.1, 2.3)))))
    monkeypatch.setattr(study, "DESIGN_JSON", design)
    monkeypatch.setattr(study, "_train_model", lambda *a: pytest.fail("trained past its gate"))
    rc = study.main(["--seed", str(DECLARED[0]), "--models", "hybrid_transformer",
                     "--work", str(tmp_path / "w"), "--json", str(tmp_path / "out.json")])
    assert rc == 0 and "skipped hybrid_transformer: its design gate is pending" in \
        capsys.readouterr().err


def test_a_resumed_training_counts_the_minutes_of_its_earlier_processes(tmp_path, monkeypatch):
    """The trainer's clock runs across resumes; the record's seconds must too, or a training
    stopped and resumed twice reads as cheap as its last part (seed 112's paper transformer read
    32 min where its trainer had counted 112)."""
    overall = {mt: {a: {"nrmse_pct": 1.0} for a in ("Fx", "Fy", "Fz")}
               for mt in ("causal", "paper")}
    scores = {"overall": overall, "by_condition": {
        "Free": {"causal": {a: {"rmse_n": 0.01} for a in ("Fx", "Fy", "Fz")}}}}
    monkeypatch.setattr("psmforce.experiments.reproduce._scores", lambda *a: scores)

    class Data:
        def select(self, **kw):
            return self
    rep = {"seconds": 3600.0, "epochs_run": 30, "stopped_by": "patience", "converged": True,
           "parameters": 10}
    monkeypatch.setattr(study, "train", lambda *a: (None, rep, Data(), None))
    assert study._train_model("transformer", tmp_path, DECLARED[0], 1)["seconds"] >= 3600.0


def test_again_writes_an_existing_record_anew_and_nothing_else(tmp_path, monkeypatch):
    monkeypatch.setattr("psmforce.experiments.reproduce.prepare_benches", lambda *a, **k: None)
    models = tmp_path / "w" / f"seed{DECLARED[0]}_scale0.1" / "models"
    models.mkdir(parents=True)
    for name in ("transformer", "fcn"):
        (models / f"{name}.json").write_text(json.dumps(_record(9.0)))
    trained = []
    monkeypatch.setattr(study, "_train_model",
                        lambda name, *a: trained.append(name) or _record(1.0))
    argv = ["--seed", str(DECLARED[0]), "--models", "transformer", "fcn", "--work",
            str(tmp_path / "w"), "--json", str(tmp_path / "out.json")]
    assert study.main(argv) == 0 and trained == []
    assert study.main([*argv, "--again", "transformer"]) == 0 and trained == ["transformer"]
    assert json.loads((models / "transformer.json").read_text()) == _record(1.0)
    assert json.loads((models / "fcn.json").read_text()) == _record(9.0)
