"""A hybrid whose prior fits the HEX10's cross-talk (``train(..., prior_crosstalk=True)``,
``psmforce train --prior-crosstalk``): the prior it keeps, the calibrations that refit the law it
was trained with, and the streaming path that reads the sensor's fz for it."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.training.calibrate import calibrate
from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.estimators.training.train import TrainConfig, TrainingError, train
from psmforce.estimators.data.dataset import load_dataset
from psmforce.identification.prior_law import CROSSTALK, CROSSTALK_LATERAL, FRICTION, NAMES
from psmforce.io.recording import HEX10
from psmforce.identification.prior_remount import FORCE_PER_MOUNT
from psmforce.sim import simulate

torch.set_num_threads(1)
CHEAP = TrainConfig(progress=False, max_batches_per_epoch=2, max_val_batches=2)
"""Smoke settings: these tests check the mechanics, not how well anything converges."""


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """A small bench and a hybrid smoke-trained on it with the cross-talk in its prior."""
    root = tmp_path_factory.mktemp("crosstalk")
    simulate("automated", scale=0.01, seed=1, out=root / "bench")
    train(root / "bench", "hybrid", root / "h.pt", epochs=1, train_config=CHEAP,
          prior_crosstalk=True)
    return root


EFFORTS_HOLD = (*FRICTION, "pitch_path_pretension", *CROSSTALK_LATERAL)
"""What the efforts reading holds besides the axial cross-talk: the law its priors were trained
with, and the lateral cross-talk, which ``prior_crosstalk`` does not ask for."""


@pytest.mark.slow
def test_the_prior_fits_the_cross_talk_and_says_so(bench):
    prior = load_checkpoint(bench / "h.pt").prior()
    assert prior.has_crosstalk
    assert not set(CROSSTALK) & set(prior.info["fixed"])     # fitted, not held
    assert prior.info["fixed"] == dict.fromkeys(EFFORTS_HOLD, 0.0)  # what the efforts still hold


@pytest.mark.slow
def test_calibrations_refit_the_law_the_checkpoint_has(bench, tmp_path):
    old = load_checkpoint(bench / "h.pt").prior()
    summary = calibrate(bench / "h.pt", bench / "bench", tmp_path / "free.pt", minutes=30.0,
                        epochs=1, train_config=CHEAP, free_space=True)
    refit = summary["calibration"]["prior_refit"]
    assert refit["held_by_reading"] == sorted(EFFORTS_HOLD)
    # the sensor is zeroed at every mount: an offset the data cannot pin down is still this
    # mount's, refitted, never the checkpoint's (on this bench every offset is listed)
    assert refit["offsets_refitted_although_listed"]
    assert not [n for n in refit["held_from_checkpoint"] if n.startswith("bias_")]
    new = load_checkpoint(tmp_path / "free.pt").prior()
    held = set(refit["held_from_checkpoint"])
    for name in CROSSTALK:  # each either refitted, or held at the checkpoint's fitted value
        i = NAMES.index(name)
        assert name in held and new.params[i] == old.params[i] or name not in held
    refitted = refit["offsets_refitted_although_listed"]   # a refit that moves nothing holds
    assert all(new.params[NAMES.index(n)] != old.params[NAMES.index(n)] for n in refitted)
    assert new.has_crosstalk
    mounted = calibrate(bench / "h.pt", bench / "bench", tmp_path / "mount.pt", minutes=30.0,
                        epochs=1, train_config=CHEAP, free_space=True, prior_refit="per_mount")
    assert mounted["calibration"]["prior_refit"]["held_by_reading"] == []
    after = load_checkpoint(tmp_path / "mount.pt").prior()
    moved = {n for n, a, b in zip(NAMES, old.params, after.params) if a != b}
    assert moved and moved <= set(FORCE_PER_MOUNT)      # the cross-talk kept as trained


@pytest.mark.slow
def test_the_stream_reads_the_sensors_fz_and_equals_the_offline_path(bench):
    est = StreamingEstimator.from_checkpoint(bench / "h.pt")
    assert est.inputs.prior.input_columns[-1] == HEX10[2]   # its law reads the sensor's fz
    frame = load_dataset(bench / "bench").select(split="test")[0].frame.iloc[:300]
    offline = est.predict_recording(frame)
    online = np.stack([est.step(row).force_hex10 for row in frame.to_dict("records")])
    assert np.abs(online - offline).max() < 1e-4


def test_the_option_is_refused_where_no_prior_is_fitted(tmp_path):
    with pytest.raises(TrainingError, match="prior_crosstalk"):
        train(tmp_path / "absent", "hybrid", tmp_path / "h.pt", prior_crosstalk=True,
              use_prior=False)
    with pytest.raises(TrainingError, match=r"--prior-crosstalk.*'fcn', which is trained "
                                             r"without a prior"):
        train(tmp_path / "absent", "fcn", tmp_path / "f.pt", prior_crosstalk=True)
