"""studies/ati_free.py's pure parts: which data each arm reads, the pairing against the ATI
references, the goal check and the prior against the bench's truth."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from studies.ati_free import (ATI_FREE, AXES, GOALS, IDENTIFIED_ARM,  # noqa: E402
                              NETWORK_OFF_ARM, NETWORK_PRIOR_ARM, NO_FINETUNE_ARM,
                              PRIOR_ONLY_ARM,
                              PAIRED_ARM, PER_MOUNT_ARM, REFERENCES, arms, goal_misses,
                              paired_table, prior_against_truth, rows, same_minutes, summary)


def test_arms_add_the_excitation_then_the_weights():
    got = arms(1.5, 2.0)
    assert list(got) == list(ATI_FREE)
    assert [a["minutes"] for a in got.values()] == [1.5, 3.5, 3.5, 3.5]
    assert [a["known_loads"] for a in got.values()] == [None, None, "weights", "paired"]
    names = rows()
    assert {"network_alone:free", "physics_alone:free+self+weights",
            "network_alone:" + PAIRED_ARM, *REFERENCES} <= set(names)


def test_each_row_is_held_to_the_ati_calibration_of_its_own_minutes():
    """(c') records more minutes of weights than (c): it is paired with (d'), the ATI on its
    minutes, never with (d), and (c) never with (d'); (e) takes every row."""
    assert same_minutes(PAIRED_ARM) == same_minutes("physics_alone:" + PAIRED_ARM) \
        == "ati_same_minutes_paired"
    assert same_minutes("free+self+weights") == same_minutes("free") == "ati_same_minutes"
    records = {s: {n: _score(2.0, 1.0, 3.0) for n in rows()} for s in (201, 202)}
    by_ref = {ref: set(paired_table(records, ref)) for ref in REFERENCES}
    assert PAIRED_ARM in by_ref["ati_same_minutes_paired"] and PAIRED_ARM in by_ref["ati_full"]
    assert PAIRED_ARM not in by_ref["ati_same_minutes"]
    assert "free+self+weights" not in by_ref["ati_same_minutes_paired"]
    assert by_ref["ati_same_minutes_paired"] == {
        PAIRED_ARM, "network_alone:" + PAIRED_ARM, "physics_alone:" + PAIRED_ARM,
        IDENTIFIED_ARM, "physics_alone:" + IDENTIFIED_ARM,   # (c'') has (c')'s recordings
        NETWORK_OFF_ARM, NO_FINETUNE_ARM, PRIOR_ONLY_ARM, NETWORK_PRIOR_ARM}
    assert "ati_same_minutes_paired" not in by_ref["ati_same_minutes"]
    assert {"ati_full", "source"} <= by_ref["ati_same_minutes"]
    assert set(by_ref["ati_full"]) == set(rows()) - {"ati_full"}
    # the goal check of (d') judges (c') and (c''), at (c)'s goal
    assert set(goal_misses(paired_table(records, "ati_same_minutes_paired"))) == {
        PAIRED_ARM, IDENTIFIED_ARM, NETWORK_OFF_ARM, NO_FINETUNE_ARM, PRIOR_ONLY_ARM,
        NETWORK_PRIOR_ARM}
    assert GOALS[PAIRED_ARM] == GOALS[IDENTIFIED_ARM] == GOALS["free+self+weights"] \
        == GOALS[NETWORK_OFF_ARM] == GOALS[NO_FINETUNE_ARM] == GOALS[NETWORK_PRIOR_ARM]


def _score(fx, fy, fz):
    return {"nrmse_pct": {m: dict(zip(AXES, (fx, fy, fz))) for m in ("causal", "paper")}}


def test_pairing_is_per_seed_and_against_the_reference():
    records = {201: {"free+self+weights": _score(2.0, 1.0, 3.0),
                     "ati_same_minutes": _score(1.0, 1.0, 3.0)},
               202: {"free+self+weights": _score(2.0, 2.0, 3.0),
                     "ati_same_minutes": _score(1.0, 1.0, 3.0)},
               203: {"free+self+weights": _score(2.0, 1.0, 3.0),   # no free+self on 203
                     "ati_same_minutes": _score(1.0, 1.0, 3.0), "free+self": _score(1, 1, 1)}}
    paired = paired_table(records, "ati_same_minutes")
    assert set(paired) == {"free+self+weights"}       # a row missing on a seed is left out
    fx = paired["free+self+weights"]["causal"]["Fx"]
    assert fx["ratios"] == (2.0, 2.0, 2.0) and fx["mean_ratio"] == pytest.approx(2.0)
    fy = paired["free+self+weights"]["paper"]["Fy"]
    assert fy["ratios"] == (1.0, 2.0, 1.0) and fy["verdict"] == "tie" and fy["n"] == 3
    check = goal_misses(paired)
    assert check["free+self+weights"]["met"] is False
    # Fy's geometric mean, 2 ** (1 / 3) = 1.26, is within the 1.3x goal
    assert {(m["metric"], m["axis"]) for m in check["free+self+weights"]["misses"]} == {
        ("causal", "Fx"), ("paper", "Fx")}
    table = summary(records)
    assert table["free+self+weights"]["causal"]["Fx"][0] == pytest.approx(2.0)
    assert table["free+self"]["n"] == 1 and table["free+self"]["causal"]["Fx"][1] is None


def test_prior_against_truth_names_held_and_unmatched_parameters():
    after = {"pretension_total": 6.3, "bias_fz": 0.01, "direction_tension": 0.2,
             "cable_radius": 0.002, "bias_tx": 0.001, "bias_ty": 1e-4, "pitch_path_tension": 0.1}
    truth = {"pretension_total": 6.0, "bias_fz": 0.05, "direction_tension": None,
             "cable_radius": 0.0012, "bias_tx": 0.0, "bias_ty": 0.0, "pitch_path_tension": 0.0}
    got = prior_against_truth(after, truth, held={"cable_radius": 0.002})
    assert got["pretension_total"]["relative_error"] == pytest.approx(0.05)
    assert got["pretension_total"]["within"] is True and got["bias_fz"]["within"] is False
    assert got["direction_tension"]["status"] == "no counterpart"
    assert got["cable_radius"]["status"] == "held" and got["cable_radius"]["within"] is None
    assert got["bias_tx"]["relative_error"] is None
    assert got["bias_tx"]["absolute_error"] == pytest.approx(0.001)
    # an offset is judged against the sensor's resolution (0.2 mNm), even where its truth is 0;
    # a constant whose truth is 0 has no relative accuracy and is not judged
    assert got["bias_tx"]["within"] is False and got["bias_ty"]["within"] is True
    assert got["pitch_path_tension"]["within"] is None


def test_the_page_renders_every_row_the_goals_and_the_prior():
    from reports.ati_free_page import ati_free_tables
    names = rows()
    records = {s: {n: _score(1.0 + k / 10, 2.0, 3.0 + s - 201) for k, n in enumerate(names)}
               for s in (201, 202)}
    prior = prior_against_truth({"pretension_total": 6.3, "cable_radius": 0.002},
                                {"pretension_total": 6.0, "cable_radius": 0.0012},
                                {"cable_radius": 0.002})
    paired = {ref: paired_table(records, ref) for ref in REFERENCES}
    result = {"label": "converged", "settings": {"scale": 0.05}, "start": "s", "test": "t",
              "metrics": "m", "summary": summary(records), "paired": paired,
              "goal_check": {ref: goal_misses(p) for ref, p in paired.items()},
              "records": {str(s): r for s, r in records.items()},
              "runs": {str(s): {a: {"prior_against_truth": prior}
                                for a in (*ATI_FREE, PER_MOUNT_ARM)} for s in records},
              "convergence": {"seed 201: free": True, "seed 202: free": False}}
    text = ati_free_tables(result)
    # the scores, the two pairings and its two prior parameters
    assert text.count("| (c) ATI-free: + known weights |") == 5
    assert text.count("| (b') as (b), the prior refitted per mount only |") == 5
    assert "physics alone, (a)'s prior" in text and "| `cable_radius` | 0.0012 | held, held" in text
    assert "| `pretension_total` | 6 | fitted, fitted | 0.05, 0.05 | 2 of 2 |" in text
    assert "**missed**: causal Fx 1." in text or "**met**" in text
    assert "not converged: seed 202: free." in text


def test_a_term_the_reading_holds_is_named_so_and_not_judged():
    after = {"crosstalk_fy": 0.0, "capstan_mu": 0.0, "crosstalk_fx": 0.005}
    truth = {"crosstalk_fy": 0.02, "capstan_mu": 0.3, "crosstalk_fx": 0.0058}
    got = prior_against_truth(after, truth, held={}, by_reading=("crosstalk_fy", "capstan_mu"))
    assert got["crosstalk_fy"]["status"] == got["capstan_mu"]["status"] == "held by the reading"
    assert got["crosstalk_fy"]["within"] is None
    assert got["crosstalk_fx"]["status"] == "fitted" and got["crosstalk_fx"]["within"] is False


def test_a_term_carried_from_the_load_path_is_named_so_and_judged():
    """(c'')'s prior holds what the instrument's identification identified at its value:
    "load path", and judged against the truth as a fitted term is."""
    after = {"pretension_total": 6.3, "crosstalk_fy": 0.03, "bias_fx": 0.1}
    truth = {"pretension_total": 6.0, "crosstalk_fy": 0.02, "bias_fx": 0.1}
    got = prior_against_truth(after, truth, held={}, carried={"pretension_total": 6.3,
                                                              "crosstalk_fy": 0.03})
    assert got["pretension_total"]["status"] == got["crosstalk_fy"]["status"] == "load path"
    assert got["pretension_total"]["within"] is True and got["crosstalk_fy"]["within"] is False
    assert got["bias_fx"]["status"] == "fitted"


def test_the_network_is_kept_out_of_exactly_the_lateral_axes_whose_crosstalk_was_carried():
    """Per axis, the physics alone's error where the axial cross-talk into that axis was carried
    into the prior, the hybrid's elsewhere (Fz always the hybrid's), both metrics alike."""
    from studies.ati_free import network_off_carried

    def score(fx, fy, fz):
        return {"nrmse_pct": {m: {"Fx": fx, "Fy": fy, "Fz": fz} for m in ("causal", "paper")}}
    hybrid, physics = score(1.0, 2.0, 3.0), score(10.0, 20.0, 30.0)
    got = network_off_carried(hybrid, physics, {"crosstalk_fy": 0.01, "crosstalk_tz": 1e-4})
    assert got["nrmse_pct"]["paper"] == {"Fx": 1.0, "Fy": 20.0, "Fz": 3.0}
    assert got["physics_axes"] == ["Fy"]
    both = network_off_carried(hybrid, physics, ["crosstalk_fx", "crosstalk_fy"])
    assert both["nrmse_pct"]["causal"] == {"Fx": 10.0, "Fy": 20.0, "Fz": 3.0}
    assert network_off_carried(hybrid, physics, {})["nrmse_pct"] == hybrid["nrmse_pct"]


def test_each_claim_is_judged_on_the_seeds_declared_for_it():
    """The network-prior row's fresh seeds, then the self-loading rows', were each declared for
    its row alone, after every seed any earlier claim was judged on (each of those a design seed for
    it)."""
    from studies.ati_free import (FRESH_SEEDS_BY_CLAIM, NETWORK_PRIOR_FRESH_SEEDS,
                                  SELF_LEAST_ARM, SELF_LOADING_ARM, SELF_LOADING_FRESH_SEEDS,
                                  SELF_OFFSETS_ARM)
    order = [PRIOR_ONLY_ARM, NETWORK_PRIOR_ARM, SELF_LOADING_ARM, SELF_OFFSETS_ARM,
             SELF_LEAST_ARM]
    assert FRESH_SEEDS_BY_CLAIM[NETWORK_PRIOR_ARM] == NETWORK_PRIOR_FRESH_SEEDS
    assert FRESH_SEEDS_BY_CLAIM[SELF_LOADING_ARM] == SELF_LOADING_FRESH_SEEDS
    assert FRESH_SEEDS_BY_CLAIM[PRIOR_ONLY_ARM] != NETWORK_PRIOR_FRESH_SEEDS
    for k, claim in enumerate(order[1:], 1):
        earlier = {s for c, seeds in FRESH_SEEDS_BY_CLAIM.items()
                   if c not in order[k:] for s in seeds}
        assert max(earlier) < min(FRESH_SEEDS_BY_CLAIM[claim]), claim
