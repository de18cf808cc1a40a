"""Table cells the pages share."""

from psmforce.estimators.evaluation.tables import spread_text


def spread_cell(d: dict, digits: int = 2) -> str:
    """``{mean, std}`` as a table cell, ``mean ± std``; the mean alone where ``std`` holds no
    spread (None: one seed; :func:`psmforce.estimators.evaluation.tables.spread_text`)."""
    return spread_text(d, digits)


def miss_rule(run: dict, others: list | None = None) -> str:
    """What a MISS is in ``run`` (a ``compare_selection`` row) and the ``others`` of its table:
    its JSON records the offsets' resolution since they were judged by it; before, every
    parameter was judged relatively."""
    rule = "more than 10 % from the truth (or a truth of 0)"
    res = run.get("offset_resolution")
    if res:
        rule += (f", an offset (`bias_*`) more than its resolution ({res['N']:g} N, "
                 f"{res['Nm']:g} Nm) from it")
    if run.get("truth_as_held"):
        rule += ("; where a cross-talk term is held off the bench's, the bias of its channel is "
                 "judged against the truth as the law holds it (the bench's offset plus the held "
                 "cross-talk's share of the rest axial force, shown as \"as held\")")
    rows = run.get("parameters", {})
    if any("projected_truth" in row for r in [run, *(others or [])]
           for row in r.get("parameters", {}).values()):  # prior_recovery.projected_truth
        rule += ("; the capstan, where the pins are held at 0, against the bench's law "
                 "projected onto the law as the run held it, on its training trials (where no "
                 "run records the projection, the idlers' and the pins' sum and the idlers' "
                 "share), and the form of the blade cables' path tension that the reading holds "
                 "at 0 against 0")
    elif "pin_friction" in rows:  # runs of the law with its own pins
        rule += ("; the capstan, where the pins are held at 0, against the idlers' and the "
                 "pins' sum (its growth terms against the idlers' share), and the form of the "
                 "blade cables' path tension that the reading holds at 0 against 0")
    return rule


def as_held(row: dict) -> str:
    """`` (X as held)`` for an identified parameter judged against an effective truth
    (``experiments.prior_recovery.judge``), else nothing."""
    eff = row.get("effective_truth")
    return "" if eff is None or row["status"] != "identified" else f" ({eff:.4g} as held)"


def relative_error(row: dict) -> float | None:
    """|fitted / truth - 1|: for an identified parameter judged against an effective truth,
    against it (what the miss rule judges); else the stored relative error (None without a
    non-zero truth)."""
    eff = row.get("effective_truth")
    if eff is None or row["status"] != "identified":
        return row["relative_error"]
    return None if eff == 0 else abs(row["fitted"] / eff - 1.0)


def rescored_note(result: dict) -> str:
    """``, misses judged again by `COMMAND` (the fits untouched)`` for a study JSON rescored by
    ``experiments.prior_recovery.rescore``, else nothing."""
    r = result.get("rescored")
    return "" if not r else f"; misses judged again by `{r['command']}` (the fits untouched)"


def with_pins(run: dict) -> str:
    """The pulley pins' share of the bench's wrist friction, named where a recovery run's truth
    holds it (runs with the prior's capstan growth terms: ``default_bench_truth``)."""
    return " plus the pulley pins'" if "capstan_pitch_gain" in run.get("parameters", {}) else ""


def sag_sentence(run: dict) -> str:
    """How a case's final fit sagged the wrist (``prior_selection.fit_identified``'s ``sag``
    record); empty for a run written before the fit read its own values back."""
    sag = run.get("sag")
    if sag is None:
        return ""
    passes = len(sag["passes"]) - 1
    last = sag["passes"][-1]["change"]
    taken = ("the design's, which the fit's own values already give" if passes == 0 else
             f"the design's, then the fit's own values, {passes} pass"
             f"{'' if passes == 1 else 'es'}")
    return (f" The wrist's sag: {taken}; the sag the final fit took and the one it gives "
            f"differ by {100 * last:.2g} % at most "
            + ("(converged)." if sag["converged"] else "(**not converged**).")
            + f" Its capstan in the sag {sag['compliance']['capstan_mu']:.3g}.")
