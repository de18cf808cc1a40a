"""The declared seeds: a claim's seeds are fresh, and sets of different purposes do not overlap."""
import pytest

from psmforce.experiments.seeds import (ATI_FREE_IDENTIFICATION_SEEDS, COMPARISON_SEEDS,
                                        DESIGN_SEEDS, LOAD_PATH_SEEDS, PRIOR_ABLATION_SEEDS,
                                        RECIPE_SWAP_SEEDS, WIDE_HYBRID_SEEDS, check_fresh)


def test_declared_seeds_are_fresh_and_disjoint():
    comparison = {s for seeds in COMPARISON_SEEDS.values() for s in seeds}
    assert not comparison & DESIGN_SEEDS and not set(RECIPE_SWAP_SEEDS) & DESIGN_SEEDS
    assert not comparison & set(RECIPE_SWAP_SEEDS)
    ablation = set(PRIOR_ABLATION_SEEDS)
    assert not ablation & (DESIGN_SEEDS | comparison | set(RECIPE_SWAP_SEEDS))
    assert not set(LOAD_PATH_SEEDS) & (DESIGN_SEEDS | comparison | set(RECIPE_SWAP_SEEDS)
                                       | ablation)
    assert not set(ATI_FREE_IDENTIFICATION_SEEDS) & (
        DESIGN_SEEDS | comparison | set(RECIPE_SWAP_SEEDS) | ablation | set(LOAD_PATH_SEEDS))
    wide = {s for seeds in WIDE_HYBRID_SEEDS.values() for s in seeds}
    assert not wide & (DESIGN_SEEDS | comparison | set(RECIPE_SWAP_SEEDS) | ablation
                       | set(LOAD_PATH_SEEDS) | set(ATI_FREE_IDENTIFICATION_SEEDS))
    assert len(WIDE_HYBRID_SEEDS[0.1]) >= 5
    assert all(len(COMPARISON_SEEDS[s]) >= 5 for s in (0.1, 0.25))
    assert len(COMPARISON_SEEDS[1.0]) >= 3


def test_a_design_seed_is_refused_for_a_claim():
    check_fresh(RECIPE_SWAP_SEEDS, "recipe swap")
    with pytest.raises(ValueError, match=r"recipe swap: seed\(s\) \[1, 18\]"):
        check_fresh((1, 18, 201), "recipe swap")


def test_the_load_paths_blind_seeds_were_never_used():
    """``ATI_FREE_READING_SEEDS`` share no seed with any other declared set."""
    import psmforce.experiments.seeds as seeds
    from psmforce.experiments.seeds import ATI_FREE_READING_SEEDS
    others = set()
    for name, value in vars(seeds).items():
        if name.endswith("_SEEDS") and name != "ATI_FREE_READING_SEEDS":
            values = value.values() if isinstance(value, dict) else [value]
            others |= {s for v in values for s in (v if isinstance(v, (tuple, list, set,
                                                                        frozenset)) else [v])}
    assert others and not set(ATI_FREE_READING_SEEDS) & others
    check_fresh(ATI_FREE_READING_SEEDS, "the load path's blind rerun")
