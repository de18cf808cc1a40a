"""The design of experiments for the prior (psmforce.identification.prior_design): a parameter
nothing informs is named as such, per reading, and a matrix of another reading is refused."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.identification import prior_design as pd_


def _information(reading: str, blind: str | None = None) -> np.ndarray:
    """A well-informed diagonal information (each parameter's standard error a millionth of
    its bounds' span), with ``blind`` given none."""
    names = pd_.designed(reading)
    info = np.diag(1.0 / (1e-6 * pd_._span(reading)) ** 2)
    if blind is not None:
        info[names.index(blind)] = info[:, names.index(blind)] = 0.0
    return info


@pytest.mark.parametrize("reading, blind", [("efforts", "twist_gain"),
                                            ("load_path", "capstan_pitch_gain")])
def test_a_parameter_without_information_is_not_identifiable_and_has_no_finite_error(reading,
                                                                                    blind):
    assert pd_.not_identifiable(_information(reading), reading=reading) == {}
    info = _information(reading, blind)
    assert pd_.not_identifiable(info, reading=reading) == {
        blind: "no information (nothing in the data depends on it)"}
    se = pd_.standard_errors(info, reading)
    assert np.isinf(se[pd_.designed(reading).index(blind)]) and np.isfinite(se).sum() == len(se) - 1
    assert pd_.summary(info, reading=reading)["standard_errors"][blind] is None


def test_the_load_path_informs_every_parameter_and_the_efforts_hold_the_capstan_and_crosstalk():
    efforts, load_path = set(pd_.designed("efforts")), set(pd_.designed("load_path"))
    assert pd_.DESIGNED == pd_.designed("efforts")
    assert {"capstan_mu", "capstan_pitch_gain", "crosstalk_fx", "pin_friction",
            "pitch_path_pretension"} <= load_path - efforts
    assert efforts - load_path == {"pitch_path_tension"}  # one form of the path tension each


def test_each_reading_is_evaluated_at_the_law_it_fits():
    """The design values with the reading's holds: the blade cables' path tension in one form
    only (both at their design value would count it twice)."""
    from psmforce.identification.prior import NAMES
    for reading, held in (("efforts", "pitch_path_pretension"), ("load_path",
                                                                  "pitch_path_tension")):
        p = dict(zip(NAMES, pd_.design_params(reading)))
        assert p[held] == 0.0 and (p["pitch_path_tension"] + p["pitch_path_pretension"]) > 0


def test_a_matrix_of_another_reading_is_refused_naming_it():
    with pytest.raises(ValueError, match="load_path reading"):
        pd_.log_det(_information("efforts"), "load_path")
