"""Table cells the pages share."""

from psmforce.estimators.evaluation.tables import spread_text


def spread_cell(d: dict, digits: int = 2) -> str:
    """``{mean, std}`` as a table cell, ``mean ± std``; the mean alone where ``std`` holds no
    spread (None: one seed; :func:`psmforce.estimators.evaluation.tables.spread_text`)."""
    return spread_text(d, digits)


def miss_rule(run: dict) -> str:
    """What a MISS is in ``run`` (a ``compare_selection`` row): its JSON records the offsets'
    resolution since they were judged by it; before, every parameter was judged relatively."""
    rule = "more than 10 % from the truth (or a truth of 0)"
    res = run.get("offset_resolution")
    if res:
        rule += (f", an offset (`bias_*`) more than its resolution ({res['N']:g} N, "
                 f"{res['Nm']:g} Nm) from it")
    return rule
