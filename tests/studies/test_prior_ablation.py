"""The prior ablation (studies/prior_ablation.py) measures the prior alone: its ``no_prior`` arm
is the hybrid with the prior's law switched off and the insertion-effort base kept (issue 43:
the arm used to drop the insertion base together with the prior)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from studies.prior_ablation import (NO_PRIOR_FEATURES, law_switched_off,  # noqa: E402
                                    no_prior_inputs)
from psmforce.estimators.data.hybrid_inputs import (BASE_COLUMNS, HYBRID_INPUTS,  # noqa: E402
                                                    INSERTION_FZ, PRIOR_FZ, compensated_hex10)
from psmforce.io.recording import HEX10  # noqa: E402


@pytest.mark.slow
def test_the_no_prior_arm_keeps_the_insertion_base_and_drops_only_the_prior(tmp_path):
    from psmforce.estimators.data.dataset import load_dataset
    from psmforce.estimators.data.hybrid_inputs import add_prior_columns
    from psmforce.estimators.training.train import fit_prior
    from psmforce.sim import simulate

    simulate("automated", scale=0.02, seed=3, out=str(tmp_path / "d"))
    ds = load_dataset(tmp_path / "d")
    train = ds.select(split="train")
    prior = fit_prior(train)
    off = law_switched_off(prior)
    add_prior_columns(ds, off)
    inputs = no_prior_inputs(train)
    # the same inputs and base as the hybrid with the prior, but prior_fz (0 without it)
    assert set(NO_PRIOR_FEATURES) == set(HYBRID_INPUTS) - {PRIOR_FZ}
    assert INSERTION_FZ in inputs.features and inputs.uses_prior
    assert inputs.base[2] == INSERTION_FZ == BASE_COLUMNS[2]  # the axial base in both arms
    frame = train[0].frame
    cols = compensated_hex10(frame, off)
    np.testing.assert_array_equal(off.predict(frame), 0.0)  # the law switched off
    for k, name in enumerate(HEX10):
        np.testing.assert_array_equal(cols[f"comp_{name}"], frame[name].to_numpy())
    np.testing.assert_array_equal(cols[INSERTION_FZ], prior.insertion_axial_force(frame))
    assert np.abs(compensated_hex10(frame, prior)["comp_fz"] - frame["fz"]).max() > 1.0
