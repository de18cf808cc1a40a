"""studies/hybrid_plateau.py: each variant changes the hybrid it names and nothing else, and a
missing learning-curve run is refused with a message, not a traceback."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from studies.hybrid_plateau import (  # noqa: E402
    INSERTION_STATE,
    LATERAL_BASE_OFF,
    RAW_HEX10,
    VARIANTS,
    Variant,
    main,
)
from psmforce.estimators.data.dataset import NO_BASE, Trial  # noqa: E402
from psmforce.estimators.networks.recipes import recipe  # noqa: E402

DEFAULT = recipe("hybrid").inputs(None, True)


@pytest.fixture(scope="module")
def trials():
    """A training trial on which the lateral base lowers the target's variance and the axial one
    does not, so the trainer's selection keeps (comp_fx, comp_fy) and drops insertion_fz."""
    rng = np.random.default_rng(0)
    ati = rng.standard_normal((400, 3))
    frame = pd.DataFrame(ati, columns=["ati_fx", "ati_fy", "ati_fz"])
    frame[["comp_fx", "comp_fy"]] = ati[:, :2] + 0.1 * rng.standard_normal((400, 2))
    frame["insertion_fz"] = 3.0 * rng.standard_normal(400)
    return [Trial("t.csv", "Traction", "train", frame)]


def test_unchanged_inputs_are_the_recipes_with_the_trainers_base(trials):
    for name in ("default", "wide_64", "dropout_0", "attention_window_1", "batch_4_chunks",
                 "fcn_hybrid_inputs", "fcn_hybrid_inputs_chunks"):
        inputs = VARIANTS[name].inputs(trials)
        assert inputs.features == DEFAULT.features and inputs.uses_prior
        assert inputs.base == ("comp_fx", "comp_fy", NO_BASE)


def test_input_changes_touch_only_what_they_name(trials):
    default = Variant("unchanged").inputs(trials)
    dropped = VARIANTS["no_insertion_state"].inputs(trials)
    assert set(default.features) - set(dropped.features) == set(INSERTION_STATE)
    assert dropped.base == default.base
    added = VARIANTS["plus_raw_hex10"].inputs(trials)
    assert added.features == default.features + RAW_HEX10 and added.base == default.base
    for name in ("no_lateral_base", "fcn_hybrid_inputs_no_lateral_base"):
        no_base = VARIANTS[name].inputs(trials)
        assert no_base.features == default.features
        assert no_base.base == LATERAL_BASE_OFF == (NO_BASE, NO_BASE, DEFAULT.base[2])
    paper = VARIANTS["paper_inputs"].inputs(trials)
    assert paper == recipe("fcn").inputs(None, True) and not paper.uses_prior and paper.base == ()


def test_only_the_fcn_variants_change_the_model():
    assert {n for n, v in VARIANTS.items() if v.model != "hybrid"} == {
        "fcn_hybrid_inputs", "fcn_hybrid_inputs_no_lateral_base", "fcn_hybrid_inputs_chunks",
        "fcn_hybrid_inputs_chunks_of_2"}


def test_hybrid_variants_change_the_curves_training_not_the_recipes():
    """The rows compare with checkpoints trained before short chunks became the recipe's
    default: a variant's base is those settings, whatever the recipe says now."""
    from studies.hybrid_plateau import CURVE_HYBRID_TRAINING, training
    from psmforce.experiments.reproduce import _config
    default = training(VARIANTS["default"], 2)
    assert (default.chunk, default.chunk_supervised, default.chunk_batch_size,
            default.max_epochs, default.seed) == (400, None, 16, 300, 2)
    short = training(VARIANTS["short_chunks_64"], 2)
    assert (short.chunk, short.chunk_batch_size) == (124, 64)
    assert {k: v for k, v in vars(short).items() if k not in ("chunk", "chunk_batch_size")} == \
        {k: v for k, v in vars(default).items() if k not in ("chunk", "chunk_batch_size")}
    assert training(VARIANTS["fcn_hybrid_inputs_chunks"], 2) == default
    assert training(VARIANTS["fcn_hybrid_inputs"], 2) == _config("full", "pretrain", 2, "cpu",
                                                                 "fcn", recipe("fcn").optimiser)
    assert set(CURVE_HYBRID_TRAINING) <= set(vars(default))


def test_a_checkpoint_retrained_with_other_settings_is_refused(tmp_path):
    from studies.hybrid_plateau import CURVE_HYBRID_RECIPE, check_first_training
    first = {"reproduce": {"recipe": {"optimiser": dict(CURVE_HYBRID_RECIPE)}}}
    check_first_training(first, tmp_path / "hybrid.pt")  # the curve's first training: scored
    retrained = {"reproduce": {"recipe": {"optimiser": recipe("hybrid").optimiser}}}
    for provenance in (retrained, {}):
        with pytest.raises(SystemExit, match="not the ones the variants change"):
            check_first_training(provenance, tmp_path / "hybrid.pt")


def test_missing_run_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--work", str(tmp_path), "--json", str(tmp_path / "out.json")])
    assert exit_.value.code == 2
    assert "no learning-curve run at scale 0.5" in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()


def test_chunk_fcn_is_the_fcns_network_on_every_sample():
    import torch

    from studies.hybrid_plateau import ChunkFCN
    from psmforce.estimators.networks.contract import check_model, is_chunk
    from psmforce.estimators.networks.baselines import FCN
    torch.manual_seed(0)
    chunked, fcn = ChunkFCN(5), FCN(5)
    check_model(chunked, "chunk_fcn")
    assert is_chunk(chunked) and not is_chunk(fcn)
    fcn.load_state_dict({k.removeprefix("fcn."): v for k, v in chunked.state_dict().items()})
    x = torch.randn(2, 7, 5)
    per_sample = torch.stack([fcn(x[:, t:t + 1]) for t in range(7)], dim=1)
    torch.testing.assert_close(chunked(x), per_sample)


def test_table_averages_seeds_and_counts_paired_wins():
    from studies.hybrid_plateau import table

    def row(name, seed, val):
        return {"name": name, "scale": 0.5, "seed": seed, "validation": val, "test": val}
    rows = [row("existing_hybrid", 1, [0.4, 0.4, 2.0]), row("existing_hybrid", 2, [0.3, 0.3, 2.0]),
            row("fcn_hybrid_inputs", 1, [0.2, 0.3, 3.0]),   # lower laterally
            row("fcn_hybrid_inputs", 2, [0.2, 0.5, 1.0])]   # Fy higher: not counted
    text = table({"variants": rows})   # 0.4, 0.3: the sample std, 0.05 * sqrt(2)
    assert "| 0.5 | `existing_hybrid` |" in text and "| 1, 2 | 0.35 ± 0.07 / 0.35 ± 0.07 / 2.00" in text
    assert "`fcn_hybrid_inputs` lower on Fx and Fy at scale 0.5 on 1 of 2 seeds (1, 2)." in text
    assert "`short_chunks_64`: not measured beside it yet." in text
