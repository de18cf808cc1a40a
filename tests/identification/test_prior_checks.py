"""Priors refuse to call a bad fit good (issue 14, item 4): loaded parameters checked against
their bounds, a poor held-out fit not saved without --accept-poor-fit."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from psmforce.core.integrity import seal
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import InternalForcePrior
from psmforce.identification.prior_report import POOR_FIT_RMS_N, fit_prior_cli
from psmforce.cli.main import main


def _saved(tmp_path):
    prior = InternalForcePrior(converged=True)  # the default, physical parameters
    path = tmp_path / "prior.json"
    prior.save(path)
    return path, json.loads(path.read_text())


@pytest.mark.parametrize("name, value, shown", [
    ("pulley_radius_pitch", -1.0, "-1.0"), ("pretension_total", float("nan"), "nan"),
    ("bias_fz", "0.1", "'0.1'"), ("distal_mass", None, "None"), ("twist_gain", True, "True")])
def test_a_parameter_outside_its_bounds_or_not_a_number_is_refused(tmp_path, name, value, shown):
    path, d = _saved(tmp_path)
    InternalForcePrior.load(path)  # as saved: loads
    d["parameters"][name]["value"] = value
    # resealed, as a careless tool would: the envelope then holds and the bounds must refuse it
    # (json writes NaN as the literal NaN, which it reads back)
    path.write_text(json.dumps(seal(d)))
    with pytest.raises(IdentificationInputError, match=f"parameter '{name}'") as err:
        InternalForcePrior.load(path)
    assert str(path) in str(err.value) and shown in str(err.value)


@pytest.mark.parametrize("text", ["", "[1, 2]", "{\"format\": 3}", "not json"])
def test_a_file_that_is_not_a_prior_is_refused_naming_it(tmp_path, text):
    path = tmp_path / "prior.json"
    path.write_text(text)
    with pytest.raises(IdentificationInputError) as err:
        InternalForcePrior.load(path)
    assert str(path) in str(err.value)


@pytest.fixture(scope="module")
def corrupted_bench(tmp_path_factory):
    """A bench where one training Free trial's fz reads 1e6 N (issue 14's reproduction)."""
    from psmforce.io.recording import write_recording
    from psmforce.sim import Effects, simulate
    out = tmp_path_factory.mktemp("poor") / "d"
    simulate("automated", scale=0.02, seed=4, out=out, effects=Effects.reduced(noise=True))
    trial = sorted(out.glob("train/Free/*.csv"))[0]
    frame = pd.read_csv(trial)
    frame["fz"] = 1e6
    write_recording(frame, trial)
    return out


@pytest.mark.slow
def test_a_poor_fit_is_not_saved_unless_accepted(corrupted_bench, tmp_path, capsys):
    """The all-free fit (a curve fit) follows the corrupted trial; the identified fit holds
    what that trial spoils at design values (lack of fit) and is not poor on held-out trials,
    so the gate is exercised with the default (all free)."""
    out = tmp_path / "prior.json"
    assert main(["fit-prior", "--data", str(corrupted_bench), "--out", str(out)]) == 2
    printed, err = capsys.readouterr()
    assert "fz RMS" in printed and "verdict: all 17 parameters free" in printed
    assert len(err.strip().splitlines()) == 1 and "--accept-poor-fit" in err
    assert not out.exists()
    assert fit_prior_cli(corrupted_bench, out, accept_poor_fit=False,
                         identify=False)["model"] is None
    assert not out.exists()
    report = fit_prior_cli(corrupted_bench, out, identify=False)  # the library saves, reports
    assert report["poor_fit"] and report["poor_fit_threshold_rms_n"] == POOR_FIT_RMS_N
    assert out.exists()
