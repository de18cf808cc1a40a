"""Python's cyclic garbage collector at the node's safe points, not in the middle of an answer.

CPython collects whenever allocations of tracked objects outnumber deallocations by its first
threshold (700 by default), wherever in the code that happens: in a live node, in the middle of
an answer. A collection of the young generation costs a good share of an answer's time; one of
the oldest walks everything the process has loaded (the model, its libraries: hundreds of
thousands of objects) and costs many answers' (``benchmarks/busy_poll_ab.py`` measures the node
with and without this).

:class:`SafePoints`, for the duration of a ``with`` block: on entering it collects everything
once and freezes what survives (:func:`gc.freeze`: the model, the libraries, the node, alive
as long as the process; no later collection walks them) and turns the automatic collector off;
:meth:`SafePoints.collect`, called where the node chooses (its answers written, the deferred
network step done), makes the automatic collector's test there instead of at every allocation:
when the tracked allocations net of deallocations since the last collection exceed the first
threshold, it collects the generation CPython would (:func:`gc.get_threshold`,
:func:`gc.get_count`). What an answer allocates and frees again before the safe point triggers
nothing; cycles that accumulate are collected as they were, at another moment. On leaving, the
frozen objects are unfrozen and the collector is switched back on if it was on. A first
threshold of 0 (the collector switched off with :func:`gc.set_threshold`) is honoured.
"""

from __future__ import annotations

import gc


class SafePoints:
    """Collect garbage only at :meth:`collect` within a ``with`` block (module docstring).

    ``collections``: the collections run at safe points, per generation (0 young, 2 oldest).
    """

    def __init__(self):
        self.collections = [0, 0, 0]
        self._was_enabled: bool | None = None

    @property
    def active(self) -> bool:
        return self._was_enabled is not None

    def __enter__(self) -> SafePoints:
        if self.active:
            raise RuntimeError("SafePoints is already active: one with block at a time")
        self._was_enabled = gc.isenabled()
        gc.disable()
        gc.collect()
        gc.freeze()
        return self

    def collect(self) -> int | None:
        """Run the collection that is due, if any (module docstring); returns its generation,
        None when none is due or outside the ``with`` block."""
        if not self.active:
            return None
        counts, thresholds = gc.get_count(), gc.get_threshold()
        if thresholds[0] == 0 or counts[0] <= thresholds[0]:
            return None
        # the oldest generation whose count has passed its threshold, as CPython chooses
        generation = 0
        if counts[1] > thresholds[1]:
            generation = 2 if counts[2] > thresholds[2] else 1
        gc.collect(generation)
        self.collections[generation] += 1
        return generation

    def __exit__(self, *exc) -> None:
        gc.unfreeze()
        if self._was_enabled:
            gc.enable()
        self._was_enabled = None
