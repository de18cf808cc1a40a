"""Internal-force prior: parameter recovery on the simulator's reduced class, persistence, errors."""
import json

import numpy as np
import pytest

from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.prior import NAMES, InternalForcePrior
from psmforce.identification.prior_report import fit_prior_cli


@pytest.fixture(scope="module")
def reduced_dataset(tmp_path_factory):
    from psmforce.sim import Effects, simulate

    out = tmp_path_factory.mktemp("reduced")
    simulate(protocol="automated", scale=0.05, seed=2, out=str(out / "d"),
             effects=Effects.reduced(noise=True))
    return out / "d"


@pytest.mark.slow
def test_recovers_reduced_class_parameters(reduced_dataset, tmp_path):
    # all 17 free (the law's own fit): with identify=True bias_fz, which only 76 % of a 0.1 N
    # offset separates from the pretension, is held at its design value 0 (test_prior_selection)
    rep = fit_prior_cli(reduced_dataset, tmp_path / "prior.json", use_loaded=True,
                        identify=False)
    assert rep["converged"]
    truth = json.loads((reduced_dataset / "metadata.json").read_text())["instrument"]  # comparison only
    p = rep["parameters"]
    for name, true in (("pretension_total", truth["pretension_total_n"]),
                       ("pulley_radius_pitch", truth["pulley_radius_pitch_m"]),
                       ("pulley_radius_blade", truth["pulley_radius_blade_m"]),
                       ("distal_mass", truth["distal_body_mass_kg"] + truth["jaw_mass_kg"])):
        assert abs(p[name] / true - 1) < 0.05, (name, p[name], true)
    # the constant axial level (bias - pretension) is recovered; the split between the two is only
    # seen through slack samples
    assert abs((p["bias_fz"] - p["pretension_total"]) - (truth["hex10_residual_bias_n"][2]
                                                         - truth["pretension_total_n"])) < 0.05
    for k, name in enumerate(("bias_fx", "bias_fy")):
        assert abs(p[name] - truth["hex10_residual_bias_n"][k]) < 0.005
    m = rep["test_free_metrics"]
    assert m["fx"]["rms"] < 0.3 and m["fy"]["rms"] < 0.3

    prior = InternalForcePrior.load(tmp_path / "prior.json")
    assert prior.params.tolist() == [p[n] for n in NAMES]
    # the insertion model beside it: the weight the insertion stage carries along the shaft (the
    # upright base's gravity is -z, so its coefficient on d_z is m g; about 1 N) to 0.05 N, and
    # the carriage's Coulomb level
    gx, gy, gz, coulomb, _, _ = rep["insertion"]["parameters"].values()
    assert abs(gz["value"] - 9.81 * truth["insertion_stage_mass_kg"]) < 0.05
    assert abs(coulomb["value"] / truth["arm_coulomb"][2] - 1) < 0.1
    assert prior.insertion.params == tuple(v["value"] for v in rep["insertion"]["parameters"].values())
    rng = np.random.default_rng(0)
    pos, e = rng.normal(size=(5, 2)), 0.05 * rng.normal(size=(5, 3))
    v, g = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    batch = prior.predict_arrays(pos, e, v, g)
    one = np.array([prior.predict_one(pos[i].tolist(), e[i].tolist(), v[i].tolist(), g[i].tolist())
                    for i in range(5)])
    assert np.allclose(batch, one, atol=1e-12)
    # physics sign: a large wrist-pitch effort slackens a cable and compresses the shaft further
    hi = prior.predict_arrays([[0, 0]], [[0.1, 0, 0]], [[0, 0, 0]], [[0, 0, 0]])[0, 2]
    lo = prior.predict_arrays([[0, 0]], [[0.0, 0, 0]], [[0, 0, 0]], [[0, 0, 0]])[0, 2]
    assert hi < lo - 5.0


def test_bad_input_and_not_converged(tmp_path):
    prior = InternalForcePrior()
    with pytest.raises(IdentificationInputError, match="positions"):
        prior.predict_arrays(np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3)))
    with pytest.raises(IdentificationInputError, match="samples but positions"):
        prior.predict_arrays(np.zeros((4, 2)), np.zeros((3, 3)), np.zeros((4, 3)), np.zeros((4, 3)))
    bad = np.zeros((4, 3))
    bad[2, 1] = np.nan
    with pytest.raises(IdentificationInputError, match="non-finite"):
        prior.predict_arrays(np.zeros((4, 2)), bad, np.zeros((4, 3)), np.zeros((4, 3)))
    with pytest.raises(IdentificationInputError, match="no recordings"):
        InternalForcePrior.fit([])
    with pytest.raises(NotConvergedError):
        prior.save(tmp_path / "x.json")
    assert not (tmp_path / "x.json").exists()
    with pytest.raises(IdentificationInputError, match="metadata"):
        fit_prior_cli(tmp_path, tmp_path / "y.json")


@pytest.mark.slow
def test_free_fit_on_the_calibrated_bench_beats_a_constant(tmp_path):
    """Regression: on the default (calibrated) bench the wrist efforts carry disc friction and a
    disturbance the cables do not; the fit then raises the slack threshold and carries the rest
    level in bias_fz. With bias_fz bounded at +-5 N that split was capped, the bound was hit and
    the Free fit's fz was worse than a constant on its own training data (RMS 1.04 N against a
    0.73 N std at scale 0.03, seed 1)."""
    from psmforce.sim import simulate

    simulate(protocol="automated", scale=0.02, seed=1, out=str(tmp_path / "d"))
    rep = fit_prior_cli(tmp_path / "d", tmp_path / "prior.json", identify=False)  # curve fit
    prior = InternalForcePrior.load(tmp_path / "prior.json")
    assert rep["converged"] and "bias_fz" not in rep["bounds_hit"]
    train = prior.info["train_metrics"]["fz"]
    assert train["r2"] > 0.5  # a constant at the training mean has R^2 = 0
    assert rep["test_free_metrics"]["fz"]["r2"] > 0.5 and not rep["poor_fit"]
