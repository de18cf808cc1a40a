"""The paired comparison: ratio, interval and a verdict that cannot say "ahead" inside a tie."""

import math

import numpy as np
import pytest
from scipy import stats

from psmforce.experiments.paired import (PairedError, mean_sd, paired_by_axis,
                                         paired_ratio, paired_record, verdict)


def test_verdict_refuses_ahead_when_the_interval_includes_one():
    assert verdict(0.5, 0.9) == "ahead"
    assert verdict(1.1, 1.4) == "behind"
    assert verdict(0.5, 1.01) == "tie"
    assert verdict(0.99, 1.5) == "tie"
    assert verdict(float("nan"), float("nan")) == "tie"


def test_a_lower_mean_with_seeds_that_disagree_is_a_tie():
    # a is lower on average, and the spread rule's means say so, but one seed reverses it
    a, b = [0.40, 0.45, 0.90], [0.80, 0.85, 0.70]
    r = paired_ratio(a, b)
    assert r.mean_ratio < 1 and r.low < 1 < r.high and r.verdict == "tie"


def test_consistent_ratios_are_ahead_and_the_interval_is_students():
    a, b = [0.40, 0.52, 0.44, 0.47], [0.80, 0.95, 0.90, 0.88]
    r = paired_ratio(a, b)
    logs = np.log(np.array(a) / np.array(b))
    half = stats.t.ppf(0.975, 3) * logs.std(ddof=1) / 2.0
    assert r.mean_ratio == pytest.approx(math.exp(logs.mean()))
    assert (r.low, r.high) == pytest.approx((math.exp(logs.mean() - half),
                                             math.exp(logs.mean() + half)))
    assert r.high < 1 and r.verdict == "ahead"
    assert paired_ratio(b, a).verdict == "behind"
    assert paired_ratio(b, a).mean_ratio == pytest.approx(1 / r.mean_ratio)


def test_one_seed_gives_no_interval_and_a_tie():
    r = paired_ratio([0.1], [1.0])
    assert math.isnan(r.low) and r.verdict == "tie" and "one seed" in r.text()


def test_bootstrap_is_seeded_and_inside_the_range_of_the_seeds():
    a, b = [0.4, 0.5, 0.45, 0.6, 0.42], [0.8, 0.7, 0.9, 0.75, 0.85]
    r1, r2 = (paired_ratio(a, b, method="bootstrap", seed=3) for _ in range(2))
    assert r1 == r2
    ratios = np.array(a) / np.array(b)
    assert ratios.min() <= r1.low <= r1.mean_ratio <= r1.high <= ratios.max()


@pytest.mark.parametrize("a,b,match", [
    ([0.1, 0.2], [0.1], "same seeds"),
    ([0.1, -0.2], [0.1, 0.2], "positive and finite"),
    ([0.1, float("nan")], [0.1, 0.2], "positive and finite"),
    ([], [], "one error per seed"),
])
def test_bad_errors_are_refused_by_name(a, b, match):
    with pytest.raises(PairedError, match=match):
        paired_ratio(a, b)


def test_unknown_method_and_confidence_are_refused():
    with pytest.raises(PairedError, match="method"):
        paired_ratio([1, 2], [1, 2], method="z")
    with pytest.raises(PairedError, match="confidence"):
        paired_ratio([1, 2], [1, 2], confidence=1.0)


def test_spread_is_the_sample_standard_deviation():
    s = mean_sd([1.0, 2.0, 3.0])
    assert s["sd"] == pytest.approx(1.0) and s["n"] == 3
    assert math.isnan(mean_sd([1.0])["sd"])


def test_by_axis_pairs_each_axis_on_its_own():
    a = [{"Fx": 0.5, "Fz": 2.0}, {"Fx": 0.6, "Fz": 2.2}, {"Fx": 0.55, "Fz": 1.9}]
    b = [{"Fx": 1.0, "Fz": 2.0}, {"Fx": 1.1, "Fz": 2.1}, {"Fx": 1.05, "Fz": 2.0}]
    out = paired_by_axis(a, b, ("Fx", "Fz"))
    assert out["Fx"].verdict == "ahead" and out["Fz"].verdict == "tie"


def test_the_record_is_the_ratio_with_the_text_a_page_prints():
    a = [{"Fx": 0.5}, {"Fx": 0.6}, {"Fx": 0.55}]
    b = [{"Fx": 1.0}, {"Fx": 1.1}, {"Fx": 1.05}]
    ratio = paired_by_axis(a, b, ("Fx",))["Fx"]
    record = paired_record(a, b, ("Fx",))["Fx"]
    assert record == ratio.to_dict() | {"text": ratio.text()}
    assert "ahead" in record["text"] and record["verdict"] == "ahead"
