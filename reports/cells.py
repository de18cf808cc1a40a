"""Table cells the pages share."""

from psmforce.estimators.evaluation.tables import spread_text


def spread_cell(d: dict, digits: int = 2) -> str:
    """``{mean, std}`` as a table cell, ``mean ± std``; the mean alone where ``std`` holds no
    spread (None: one seed; :func:`psmforce.estimators.evaluation.tables.spread_text`)."""
    return spread_text(d, digits)
