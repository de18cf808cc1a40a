"""studies/hybrid_calibrated_design.py: it chooses, so it refuses a seed a claim rests on, and its
variants change one thing each against the comparison's hybrid."""

from studies import hybrid_calibrated_design as study
from psmforce.experiments.seeds import COMPARISON_SEEDS


def test_a_fresh_seed_is_refused_before_anything_is_simulated(tmp_path, capsys):
    seed = COMPARISON_SEEDS[0.1][0]
    rc = study.main(["--seed", str(seed), "--work", str(tmp_path / "w"),
                     "--json", str(tmp_path / "out.json")])
    assert rc == 2 and "not a design seed" in capsys.readouterr().err
    assert not (tmp_path / "w").exists() and not (tmp_path / "out.json").exists()


def test_each_hybrid_variant_changes_one_thing_from_the_default():
    default = study.VARIANTS["default"]
    assert default == ("hybrid", {}, False)
    for name, (model, config, crosstalk) in study.VARIANTS.items():
        if model == "hybrid" and name != "default":
            assert (config != {}) + (crosstalk != default[2]) == 1, name
