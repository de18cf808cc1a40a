"""Table cells the pages share."""


def spread_cell(d: dict, digits: int = 2) -> str:
    """``{mean, std}`` as a table cell, ``mean ± std``."""
    return f"{d['mean']:.{digits}f} ± {d['std']:.{digits}f}"
