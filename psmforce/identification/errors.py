"""Errors raised by the identification package (all ValueError subclasses with precise messages)."""


class IdentificationInputError(ValueError):
    """Data that cannot be used for a fit or a prediction: NaN rows, wrong shapes, too short,
    not exciting; the message names the problem."""


class NotConvergedError(RuntimeError):
    """A fit whose solver did not report convergence; such a model is never saved as converged."""
