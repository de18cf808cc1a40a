"""The ATI-free page's cross-talk block (reports/ati_free_page.py): each row's error with the
term fitted over the same row with it held, paired by seed, and refused for studies that do not
pair."""

import pytest

from reports.ati_free_page import crosstalk_effect_table

SETTINGS = {"scale": 0.05, "free_minutes": 1.5, "excitation_minutes": 1.5, "excitation_seed": 0,
            "masses": [0.05], "hold_s": 10.0, "calibration_epochs": 500, "quick": False}


def _study(errors_by_seed: dict, crosstalk: bool) -> dict:
    return {"settings": {**SETTINGS, "prior_crosstalk": crosstalk},
            "records": {s: {"ati_full": {"nrmse_pct": {m: {"Fx": e, "Fy": 2 * e, "Fz": 3.0}
                                                        for m in ("causal", "paper")}}}
                        for s, e in errors_by_seed.items()}}


def test_the_ratio_is_paired_by_seed_and_its_verdict_named():
    held = _study({"201": 1.0, "202": 2.0, "203": 4.0}, crosstalk=False)
    fitted = _study({"201": 0.5, "202": 1.0, "203": 2.1, "204": 9.0}, crosstalk=True)
    text = crosstalk_effect_table(held, fitted)
    assert "(201, 202, 203)" in text                     # the seed only one study ran is left out
    row = next(line for line in text.splitlines() if line.startswith("| (e) ATI: full data"))
    assert row.count("0.51x [") == 4 and row.count("1.00x") == 2   # Fx, Fy halved; Fz equal
    assert "(e) ATI: full data, causal Fx" in text.split("the term helps): ")[1].split("\n")[0]


def test_studies_that_do_not_pair_are_refused():
    held = _study({"201": 1.0, "202": 2.0}, crosstalk=False)
    fitted = _study({"201": 0.5, "202": 1.0}, crosstalk=True)
    fitted["settings"]["scale"] = 0.1
    with pytest.raises(ValueError, match=r"\['scale'\]"):
        crosstalk_effect_table(held, fitted)
    with pytest.raises(ValueError, match="does not fit the cross-talk"):
        crosstalk_effect_table(held, _study({"201": 1.0}, crosstalk=False))


def test_the_fresh_seeds_goals_mark_a_miss_per_seed():
    from reports.ati_free_page import _fresh_seed_goals
    from studies.ati_free import FRESH_SEEDS, GOALS

    def score(fx):
        return {"nrmse_pct": {m: {"Fx": fx, "Fy": 1.0, "Fz": 1.0} for m in ("causal", "paper")}}

    first, second = (str(s) for s in FRESH_SEEDS)
    worse = GOALS["free+self+weights"] + 0.1
    result = {"records": {"201": {}, first: {"free+self+weights": score(worse),
                                             "ati_same_minutes": score(1.0),
                                             "ati_full": score(1.0)},
                          second: {"free+self+weights": score(1.0),
                                   "ati_same_minutes": score(1.0), "ati_full": score(1.0)}}}
    lines = _fresh_seed_goals(result)
    row = next(line for line in lines if line.startswith("| (c) ATI-free: + known weights | (d)"))
    assert f"{worse:.2f}x (paper Fx) **miss**" in row or f"{worse:.2f}x (causal Fx) **miss**" in row
    assert row.count("**miss**") == 1 and "| 1.00x" in row
    assert _fresh_seed_goals({"records": {"201": {}}}) == []   # a study run before fresh seeds


def _gains(needed, left):
    return {"load_path": {"excitation": {
        "needed": needed, "not_identifiable_without": ["cable_radius", "capstan_roll_gain"],
        "greedy": [{"not_identifiable": ["cable_radius", "capstan_roll_gain"]},
                   {"not_identifiable": left}], "not_identifiable_with_all": left}}}


def test_the_load_path_sentence_says_how_many_holds_or_what_stays_out_of_reach():
    from reports.ati_free_page import load_path_sentence
    reached = load_path_sentence(_gains(2, []))
    assert "the first 2 holds" in reached and "`cable_radius`, `capstan_roll_gain` unid" in reached
    short = load_path_sentence(_gains(None, ["capstan_roll_gain"]))
    assert short.endswith("with all 2 holds given, still not identifiable: `capstan_roll_gain`.")
    assert "no hold is needed" in load_path_sentence(
        {"load_path": {"excitation": {"needed": 0, "not_identifiable_without": [], "greedy": [],
                                      "not_identifiable_with_all": []}}})


def test_the_sag_sentence_says_whether_the_fits_own_sag_converged():
    from reports.cells import sag_sentence as _sag_sentence
    assert _sag_sentence({}) == ""   # written before the fit read its values back
    sag = {"passes": [{"change": 0.4}, {"change": 0.003}], "converged": True,
           "compliance": {"capstan_mu": 0.31}}
    text = _sag_sentence({"sag": sag})
    assert "1 pass;" in text and "0.3 %" in text and "(converged)" in text and "0.31" in text
    sag = {**sag, "passes": [{"change": 0.4}, {"change": 0.2}, {"change": 0.05}],
           "converged": False}
    assert "2 passes" in _sag_sentence({"sag": sag}) and "**not converged**" in _sag_sentence(
        {"sag": sag})
    none = {"passes": [{"change": 0.002}], "converged": True, "compliance": {"capstan_mu": 0.0}}
    assert "the design's, which the fit's own values already give;" in _sag_sentence(
        {"sag": none})


def test_the_orientation_sentence_names_what_that_jackknife_held():
    from reports.ati_free_page import _orientation_sentence
    assert _orientation_sentence({}) == ""  # written before the jackknife existed
    params = {"cable_radius": {"status": "fixed", "reason": "at its bound; rests on the "
                               "orientations the loads hang in: 0.0013 +- 0.0002 m"},
              "bias_fx": {"status": "fixed", "reason": "varies between groups of trials"},
              "pretension_total": {"status": "identified", "reason": None}}
    text = _orientation_sentence({"orientation_jackknife_groups": 8, "parameters": params})
    assert text == " The jackknife over the 8 orientations held: cable_radius."
    assert _orientation_sentence({"orientation_jackknife_groups": 16, "parameters": {
        "bias_fx": params["bias_fx"]}}).endswith("held: nothing.")


def _identification(seed_runs: dict, crosstalk: str = "reading") -> dict:
    """An ATI-free identification study's JSON: (seed, case) -> {name: (status, reason)}."""
    settings = {"scale": 0.05, "free_minutes": 1.5, "excitation_minutes": 1.5,
                "excitation_seed": 0, "hold_s": 10.0, "crosstalk": crosstalk, "json": "x.json"}
    runs = [{"seed": seed, "case": case, "misses": [n for n, (s, _) in p.items() if s == "miss"],
             "parameters": {n: {"status": "identified" if s == "miss" else s, "reason": r}
                            for n, (s, r) in p.items()}}
            for (seed, case), p in seed_runs.items()]
    return {"command": "python studies/ati_free_identification.py", "simulator_version": "2.1",
            "design_seed": 201, "settings": settings, "runs": runs}


def test_the_held_values_check_is_read_against_the_same_rows_as_held():
    from reports.ati_free_page import held_values_check_table
    key = (433, "8 poses")
    as_held = _identification({key: {"radius": ("miss", None), "pretension": ("identified", None),
                                     "mass": ("fixed", "slack")},
                               (9, "other"): {"radius": ("identified", None)}})
    checked = _identification({key: {"radius": ("fixed", "rests on held design values: ..."),
                                     "pretension": ("identified", None),
                                     "mass": ("fixed", "slack")},
                               (8, "unpaired"): {"radius": ("miss", None)}})
    text = held_values_check_table(checked, as_held)
    row = next(line for line in text.splitlines() if line.startswith("| 433 |"))
    assert row == "| 433 | 8 poses | radius → none | 1 → 1 | radius |"
    assert "| 8 |" not in text and "| 9 |" not in text   # rows only one of the two ran
    assert "misses 1 as held, 0 checked" in text
    with pytest.raises(ValueError, match="crosstalk"):
        held_values_check_table(checked, _identification({key: {}}, crosstalk="full"))


def test_the_sign_pair_jackknife_is_read_against_the_same_rows_by_orientation():
    """The pairs' table pairs rows by seed and case, names what the pairs' jackknife held and
    what it identifies that the orientations' did not, and refuses a baseline whose held values
    were checked (another fit)."""
    from reports.ati_free_page import sign_pair_jackknife_table
    key = (434, "16 paired poses")
    by_orientation = _identification({key: {
        "radius": ("fixed", "rests on the orientations the loads hang in: ..."),
        "pretension": ("identified", None), "bias": ("identified", None)}})
    pairs = _identification({key: {
        "radius": ("identified", None), "pretension": ("identified", None),
        "bias": ("fixed", "rests on the sign pairs of orientations the loads hang in: ...")}})
    text = sign_pair_jackknife_table(pairs, by_orientation)
    row = next(line for line in text.splitlines() if line.startswith("| 434 |"))
    assert row == ("| 434 | 16 paired poses | none → none | 2 → 2 (no longer: bias) "
                   "(now also: radius) | bias |")
    assert "misses 0 orientations, 0 sign pairs" in text
    assert "no design seed among them" in text  # the fixture's seeds are 434 only
    with_design = {**pairs, "settings": {**pairs["settings"], "seeds": [201, 434]}}
    assert "seed 201 is the design seed" in sign_pair_jackknife_table(with_design, by_orientation)
    checked = {**by_orientation, "settings": {**by_orientation["settings"],
                                              "held_values": "checked"}}
    with pytest.raises(ValueError, match="held_values"):
        sign_pair_jackknife_table(pairs, checked)


def test_both_guards_are_read_against_the_sign_pairs_alone():
    """Both guards' table names what the check held on top of the pairs, and refuses a
    baseline whose jackknife left orientations out alone (another fit)."""
    from reports.ati_free_page import both_guards_table
    key = (434, "16 paired poses")

    def run(held_values, radius):
        study = _identification({key: {"radius": radius, "pretension": ("identified", None)}})
        study["settings"].update(held_values=held_values, jackknife_unit="sign_pair")
        return study
    pairs = run("as-held", ("miss", None))
    both = run("checked", ("fixed", "rests on held design values: ..."))
    row = next(line for line in both_guards_table(both, pairs).splitlines()
               if line.startswith("| 434 |"))
    assert row == "| 434 | 16 paired poses | radius → none | 1 → 1 | radius |"
    by_orientation = {**pairs, "settings": {**pairs["settings"], "jackknife_unit": "orientation"}}
    with pytest.raises(ValueError, match="jackknife_unit"):
        both_guards_table(both, by_orientation)


def test_carrying_the_identification_is_paired_with_c_prime_by_seed():
    """(c'') over (c'), the hybrid and the physics alone, on the seeds that ran both; a seed
    without (c'') is left out, and a halved error is named as helping."""
    from reports.ati_free_page import identified_effect_table
    from studies.ati_free import IDENTIFIED_ARM, PAIRED_ARM

    def score(fy):
        return {"nrmse_pct": {m: {"Fx": 1.0, "Fy": fy, "Fz": 3.0} for m in ("causal", "paper")}}
    records = {s: {PAIRED_ARM: score(e), IDENTIFIED_ARM: score(e / 2),
                   "physics_alone:" + PAIRED_ARM: score(e),
                   "physics_alone:" + IDENTIFIED_ARM: score(e * 1.01), "ati_full": score(1.0)}
               for s, e in (("201", 4.0), ("206", 2.0), ("207", 3.0))}
    records["208"] = {PAIRED_ARM: score(1.0)}
    runs = {"201": {IDENTIFIED_ARM: {"prior": {"held_at_identified": {"crosstalk_fy": 0.02}}}}}
    text = identified_effect_table({"records": records, "runs": runs})
    assert "| 201 | `crosstalk_fy` | 1.00 / 4.00 | 1.00 / 2.00 | 1.00 / 4.00 | 1.00 / 4.04 | " \
        "1.00 / 1.00 |" in text
    assert "| 206 | nothing |" in text and "| 208 |" not in text
    paired_unit = identified_effect_table({"records": records, "runs": runs,
                                           "settings": {"jackknife_unit": "sign_pair"}})
    assert "jackknife over the weights' orientations by sign pair" in paired_unit
    assert "by sign pair" not in text
    assert "(201, 206, 207)" in text
    hybrid = next(line for line in text.splitlines() if line.startswith("| the calibrated"))
    assert hybrid.count("0.50x [") == 2 and hybrid.count("1.00x") == 4
    helps = text.split("(carrying helps): ")[1].split("\n")[0]
    assert helps == "the calibrated hybrid, causal Fy; the calibrated hybrid, paper Fy."
    assert "physics alone, causal Fy" in text.split("(carrying hurts): ")[1]


def test_the_fresh_seeds_are_the_ones_the_run_declares():
    """A run that names its fresh seeds is read with them, not with the study's first ones."""
    from reports.ati_free_page import _fresh_seed_goals

    def score(fx):
        return {"nrmse_pct": {m: {"Fx": fx, "Fy": 1.0, "Fz": 1.0} for m in ("causal", "paper")}}
    rows = {"free+self+paired": score(1.0), "ati_same_minutes_paired": score(1.0),
            "ati_full": score(1.0)}
    result = {"fresh_seeds": [206], "records": {"204": rows, "206": rows}}
    lines = _fresh_seed_goals(result)
    assert "(206, declared" in lines[1] and "seed 204" not in "\n".join(lines)


def test_the_hold_rule_is_paired_with_the_10_percent_rule_by_seed():
    """(c'') under the rule "unresolved" against (c'') under the 10 % rule on the seeds both
    ran, fresh and design seeds paired apart; estimated values are marked where carried and
    each is judged against the bench's truth by its own uncertainty; a run that does not share
    the recordings, or is not the unresolved rule's, is refused. The network kept out of an axis
    whose cross-talk was carried takes the physics alone's error there and the hybrid's
    elsewhere (:func:`studies.ati_free.network_off_carried`)."""
    from reports.ati_free_page import hold_rule_table
    from studies.ati_free import IDENTIFIED_ARM, PAIRED_ARM

    def score(fy):
        return {"nrmse_pct": {m: {"Fx": 1.0, "Fy": fy, "Fz": 3.0} for m in ("causal", "paper")}}

    def rows(fy):
        return {IDENTIFIED_ARM: score(fy), "physics_alone:" + IDENTIFIED_ARM: score(2 * fy),
                PAIRED_ARM: score(1.0), "ati_same_minutes_paired": score(1.0),
                "ati_full": score(1.0)}

    def run(carried, estimated=None, truth=None):
        return {IDENTIFIED_ARM: {
            "prior": {"held_at_identified": carried},
            "instrument": {"estimated": estimated or {}},
            "prior_against_truth": {n: {"truth": t} for n, t in (truth or {}).items()}}}
    settings = {"scale": 0.05, "jackknife_unit": "orientation"}
    seeds = ("206", "209", "210", "211")
    old = {"settings": settings, "records": {k: rows(2.0) for k in seeds},
           "runs": {k: run({"crosstalk_tz": 1e-4}) for k in seeds}}
    estimated = {"crosstalk_fy": {"value": 0.0068, "uncertainty": 0.0015},
                 "capstan_mu": {"value": 0.18, "uncertainty": 0.01}}
    new = {"settings": {**settings, "hold_rule": "unresolved"},
           "records": {k: rows(1.0) for k in seeds},
           "runs": {k: run({"crosstalk_tz": 1e-4, "crosstalk_fy": 0.0068, "capstan_mu": 0.18},
                           estimated, {"crosstalk_fy": 0.0072, "capstan_mu": 0.2})
                    for k in seeds}}
    text = hold_rule_table(new, old)
    assert "| 209 (fresh) | crosstalk_tz | crosstalk_tz, *crosstalk_fy*, *capstan_mu* | " \
        "1.00 / 2.00 | 1.00 / 1.00 | 1.00 / 4.00 | 1.00 / 2.00 | 1.00 / 2.00 | 1.00 / 1.00 |" \
        in text
    assert "| 206 | crosstalk_tz |" in text
    # a name the unresolved run estimated is marked in its own column only
    old["runs"]["209"][IDENTIFIED_ARM]["prior"]["held_at_identified"] = {"crosstalk_fy": 0.007}
    assert "| 209 (fresh) | crosstalk_fy | crosstalk_tz, *crosstalk_fy*" in hold_rule_table(
        new, old)
    assert "| 209 | crosstalk_fy | 0.0068 ± 0.0015 | 0.0072 | 6% | yes |" in text
    assert "| 209 | capstan_mu | 0.18 ± 0.01 | 0.2 | 10% | **no** |" in text
    fresh = text.split("on the fresh seeds (209, 210, 211)")[1].split("design seeds")[0]
    assert fresh.count("0.50x") == 4 and "(helps): the calibrated hybrid, causal Fy" in fresh
    # the physics carries Fy (crosstalk_fy carried) and is worse there: the switch hurts
    assert "above 1 (hurts): the network off the carried axes, over the hybrid (both " \
        "unresolved), causal Fy" in fresh
    assert "| (c'') with the network kept out of the lateral axes the physics carries | (e) | " \
        "2.00x (paper Fy) **miss**" in text
    assert "on the design seeds (206)" in text
    with pytest.raises(ValueError, match="--hold-rule unresolved"):
        hold_rule_table(old, old)
    with pytest.raises(ValueError, match=r"settings \['scale'\] differ"):
        hold_rule_table(new, {**old, "settings": {**settings, "scale": 0.1}})


def test_the_network_off_checkpoint_is_read_beside_what_it_is_composed_of():
    """(c'') as ``calibrate --network-off carried`` writes it: per seed the axes the prior alone
    answers (those whose cross-talk was carried), its errors beside (c''), the physics alone,
    (d') and (e); a checkpoint score that differs from the one composed of (c'') and its
    physics alone is marked; ratios and goals on the declared fresh seeds (212-214) apart from
    the others; the source network not finetuned, alone and with the network off the carried
    axes, where the run has it; a run without the rule or the row is refused."""
    from reports.ati_free_page import network_off_table
    from studies.ati_free import IDENTIFIED_ARM, NETWORK_OFF_ARM, NO_FINETUNE_ARM

    def score(fx, fy, fz=3.0):
        return {"nrmse_pct": {m: {"Fx": fx, "Fy": fy, "Fz": fz} for m in ("causal", "paper")}}

    def rows(off_fy):
        return {IDENTIFIED_ARM: score(1.0, 2.0), "physics_alone:" + IDENTIFIED_ARM:
                score(4.0, 1.0, 6.0), NETWORK_OFF_ARM: score(1.0, off_fy),
                "ati_same_minutes_paired": score(1.0, 1.0), "ati_full": score(1.0, 1.0, 2.0)}
    seeds = ("211", "212", "213", "214")
    result = {"settings": {"hold_rule": "unresolved"},
              "records": {k: rows(1.0) for k in seeds},
              "runs": {k: {IDENTIFIED_ARM: {"prior": {"held_at_identified": {
                  "crosstalk_fy": 0.007, "pretension_total": 6.0}}}} for k in seeds}}
    result["records"]["214"][NETWORK_OFF_ARM] = score(1.0, 1.5)   # not what it is made of
    text = network_off_table(result)
    assert "| 212 (fresh) | Fy | 1.00 / 1.00 / 3.00 | 1.00 / 2.00 / 3.00 | 4.00 / 1.00 / 6.00 " \
        "| 1.00 / 1.00 / 3.00 | 1.00 / 1.00 / 2.00 | yes |" in text
    assert "| 214 (fresh) | Fy |" in text and text.count("| **no** |") == 1
    assert "| 211 | Fy |" in text and "on the design seeds (211)" in text
    assert "not finetuned" not in text
    fresh = text.split("on the fresh seeds (212, 213, 214)")[1].split("design seeds")[0]
    # Fy: 1/2, 1/2, 1.5/2 over (c''); Fz: 3 over 2 against (e), behind it on every seed
    assert "| network off / (c'') | 1.00x [1.00, 1.00] | 0.57x [0.32, 1.02] |" in fresh
    assert "| network off / (e) | 1.00x [1.00, 1.00] | 1.14x [0.64, 2.05] | " \
        "1.50x [1.50, 1.50] |" in fresh
    assert "wholly above 1 (behind): network off / (e), causal Fz; network off / (e), paper " \
        "Fz." in fresh
    goals = text.split("the axes Fx, Fy.")[1].split("the three axes.")
    assert "writes it | (e) | 1.00x (paper Fy) | 1.00x (paper Fy) | 1.50x (paper Fy) " \
        "**miss** |" in goals[0]
    assert "writes it | (e) | 1.50x (paper Fz) **miss** |" in goals[1]
    # the source network not finetuned: Fz at (e)'s, Fy its own 3.0 where not carried by physics
    for k in seeds:
        result["records"][k][NO_FINETUNE_ARM] = score(1.0, 3.0, 2.0)
    text = network_off_table(result)
    assert "| 212 (fresh) | Fy | 1.00 / 1.00 / 3.00 | 1.00 / 3.00 / 2.00 | 1.00 / 1.00 / 2.00 |" \
        in text
    fresh = text.split("on the fresh seeds (212, 213, 214)")[1].split("design seeds")[0]
    assert "| not finetuned / (c'') | 1.00x [1.00, 1.00] | 1.50x [1.50, 1.50] | " \
        "0.67x [0.67, 0.67] |" in fresh
    assert "| not finetuned, network off / (e) | 1.00x [1.00, 1.00] | 1.00x [1.00, 1.00] | " \
        "1.00x [1.00, 1.00] |" in fresh
    goals = text.split("the three axes.")[1]
    assert "not finetuned, the network off the carried axes | (e) | 1.00x" in goals
    with pytest.raises(ValueError, match="--hold-rule unresolved"):
        network_off_table({**result, "settings": {}})
    with pytest.raises(ValueError, match="has no network_off"):
        network_off_table({**result, "records": {k: {IDENTIFIED_ARM: score(1, 1)}
                                                 for k in seeds}})


def _unresolved_run(rows: dict, seeds) -> dict:
    """A ``--hold-rule unresolved`` run with ``rows`` on every seed, (c'')'s prior carrying
    the cross-talk into Fx."""
    from studies.ati_free import IDENTIFIED_ARM
    return {"settings": {"hold_rule": "unresolved"}, "records": {k: rows for k in seeds},
            "runs": {k: {IDENTIFIED_ARM: {"prior": {"held_at_identified": {
                "crosstalk_fx": 0.005}}}} for k in seeds}}


def score(fx, fy, fz):
    """One row's NRMSE, the same by both metrics."""
    return {"nrmse_pct": {m: {"Fx": fx, "Fy": fy, "Fz": fz} for m in ("causal", "paper")}}


def test_the_prior_only_calibration_is_judged_on_its_own_fresh_seeds():
    """``--no-finetune --network-off Fx Fy``: per seed beside the other (c'') rows; ratios and
    goals on its declared fresh seeds (215-217) apart from the design seeds."""
    from reports.ati_free_page import prior_only_table
    from studies.ati_free import (IDENTIFIED_ARM, NETWORK_OFF_ARM, NO_FINETUNE_ARM,
                                  PRIOR_ONLY_ARM)

    rows = {PRIOR_ONLY_ARM: score(1.0, 1.0, 2.4), NO_FINETUNE_ARM: score(3.0, 3.0, 2.4),
            NETWORK_OFF_ARM: score(1.0, 1.0, 3.0), IDENTIFIED_ARM: score(2.0, 2.0, 3.0),
            "physics_alone:" + IDENTIFIED_ARM: score(1.0, 1.0, 5.0),
            "ati_same_minutes_paired": score(1.0, 1.0, 2.0), "ati_full": score(1.0, 1.0, 2.0)}
    seeds = ("213", "215", "216", "217")
    result = _unresolved_run(rows, seeds)
    text = prior_only_table(result)
    assert "| 216 (fresh) | Fx | 1.00 / 1.00 / 2.40 | 3.00 / 3.00 / 2.40 |" in text
    fresh = text.split("on the fresh seeds (215, 216, 217)")[1].split("design seeds")[0]
    assert "| prior only / (e) | 1.00x [1.00, 1.00] | 1.00x [1.00, 1.00] | " \
        "1.20x [1.20, 1.20] |" in fresh
    assert "| prior only / (c'') | 0.50x [0.50, 0.50] |" in fresh
    goals = text.split("the three axes.")[1]
    assert "the prior alone on Fx and Fy | (e) | 1.20x (paper Fz) | 1.20x (paper Fz) | " \
        "1.20x (paper Fz) | <= 1.3x |" in goals
    assert "on the design seeds (213)" in text


def test_the_network_prior_calibration_is_judged_on_its_own_fresh_seeds():
    """``--network-prior trained``: per seed beside the prior only, the source as it was and
    the references; ratios and goals on its declared fresh seeds (218-220) apart from the
    seeds seen before it was chosen (prior only's fresh seeds among them)."""
    from reports.ati_free_page import network_prior_table
    from studies.ati_free import IDENTIFIED_ARM, NETWORK_PRIOR_ARM, PRIOR_ONLY_ARM

    rows = {NETWORK_PRIOR_ARM: score(1.0, 1.0, 2.2), PRIOR_ONLY_ARM: score(1.0, 1.0, 2.4),
            "source": score(3.0, 3.0, 2.2), IDENTIFIED_ARM: score(2.0, 2.0, 3.0),
            "ati_same_minutes_paired": score(1.0, 1.0, 2.0), "ati_full": score(1.0, 1.0, 2.0)}
    seeds = ("216", "218", "219", "220")
    result = _unresolved_run(rows, seeds)
    text = network_prior_table(result)
    assert "| 219 (fresh) | Fx | 1.00 / 1.00 / 2.20 | 1.00 / 1.00 / 2.40 | " \
        "3.00 / 3.00 / 2.20 |" in text
    assert "| 216 | Fx |" in text   # seen before the row was chosen: not fresh for it
    fresh = text.split("on the fresh seeds (218, 219, 220)")[1].split("design seeds")[0]
    assert "| trained prior / (e) | 1.00x [1.00, 1.00] | 1.00x [1.00, 1.00] | " \
        "1.10x [1.10, 1.10] |" in fresh
    assert "| trained prior / source as is | 0.33x [0.33, 0.33] |" in fresh
    goals = text.split("the three axes.")[1]
    assert "| (e) | 1.10x (paper Fz) | 1.10x (paper Fz) | 1.10x (paper Fz) | <= 1.3x |" in goals
    assert "on the design seeds (216)" in text


def test_the_self_loading_calibration_is_judged_on_its_own_fresh_seeds():
    """(b)'s recordings with the clenches' lateral forces (``SELF_LOADING_ARM``): per seed
    beside the source as it was, (d_b) and (e), with the cross-talk it carried against the drawn
    tool's; ratios and the 1.5x goal on its declared fresh seeds (221-223) apart from the design
    seeds; a study without the row is refused."""
    from reports.ati_free_page import self_loading_table
    from studies.ati_free import SELF_LOADING_ARM

    rows = {SELF_LOADING_ARM: score(1.0, 1.6, 2.2), "source": score(3.0, 3.0, 2.2),
            "ati_same_minutes_self": score(1.0, 1.0, 2.0), "ati_full": score(1.0, 1.0, 2.0)}
    seeds = ("218", "221", "222", "223")
    truth = {"crosstalk_fx": {"fitted": 0.0051, "truth": 0.005},
             "crosstalk_fy": {"fitted": 0.0, "truth": 0.004}}
    result = {"records": {k: rows for k in seeds},
              "runs": {k: {SELF_LOADING_ARM: {
                  "prior": {"held_at_identified": {"crosstalk_fx": 0.0051}},
                  "prior_against_truth": truth}} for k in seeds}}
    text = self_loading_table(result)
    assert "| 222 (fresh) | Fx | 1.00 / 1.60 / 2.20 | 3.00 / 3.00 / 2.20 | " \
        "1.00 / 1.00 / 2.00 | 1.00 / 1.00 / 2.00 | crosstalk_fx 0.0051 / 0.0050 |" in text
    assert "| 218 | Fx |" in text and "on the design seeds (218)" in text
    fresh = text.split("on the fresh seeds (221, 222, 223)")[1].split("design seeds")[0]
    assert "| (b'') / (e) | 1.00x [1.00, 1.00] | 1.60x [1.60, 1.60] | " \
        "1.10x [1.10, 1.10] |" in fresh
    goals = text.split("the axes Fx, Fy.")[1].split("the three axes.")[0]
    assert "| (d_b) | 1.60x (paper Fy) **miss** | 1.60x (paper Fy) **miss** | " \
        "1.60x (paper Fy) **miss** | <= 1.5x |" in goals
    with pytest.raises(ValueError, match="has no network_prior:identified:free\\+self row"):
        self_loading_table({**result, "records": {k: {"source": score(1, 1, 1)}
                                                  for k in seeds}})
