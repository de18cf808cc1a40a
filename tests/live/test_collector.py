"""psmforce.live.collector: garbage collected at safe points only, the collector restored."""

import gc
import weakref

import pytest

from psmforce.live.collector import SafePoints


class _Cycle:
    def __init__(self):
        self.me = self


@pytest.fixture
def thresholds():
    kept = gc.get_threshold()
    yield
    gc.set_threshold(*kept)


def _garbage_cycle() -> weakref.ref:
    cycle = _Cycle()
    return weakref.ref(cycle)   # the cycle's only way out: freed by a collection, not refcounts


def test_no_collection_between_safe_points_and_one_at_them(thresholds):
    gc.set_threshold(100, 10, 10)
    with SafePoints() as points:
        assert not gc.isenabled() and gc.get_freeze_count() > 0
        dead = _garbage_cycle()
        keep = [[] for _ in range(300)]   # tracked allocations past the first threshold
        assert gc.get_count()[0] > 100
        assert dead() is not None, "collected outside a safe point"
        assert points.collect() == 0
        assert dead() is None and points.collections == [1, 0, 0]
        assert points.collect() is None   # nothing due right after a collection
        del keep


def test_the_generation_follows_the_counts(thresholds):
    gc.set_threshold(10, 2, 1)
    with SafePoints() as points:
        generations, kept = [], []
        for _ in range(12):
            kept.append([[] for _ in range(20)])   # alive: the count only grows
            generations.append(points.collect())
        # gen 1 after more than 2 young collections, gen 2 after more than 1 of gen 1
        assert generations[:4] == [0, 0, 0, 1]
        assert 2 in generations and points.collections[2] == generations.count(2)


def test_a_first_threshold_of_zero_is_honoured(thresholds):
    gc.set_threshold(0)
    with SafePoints() as points:
        keep = [[] for _ in range(1000)]
        assert points.collect() is None and points.collections == [0, 0, 0]
        del keep


def test_the_collector_is_restored():
    enabled = gc.isenabled()
    points = SafePoints()
    with points:
        with pytest.raises(RuntimeError, match="already active"):
            points.__enter__()
    assert gc.isenabled() == enabled and gc.get_freeze_count() == 0
    assert points.collect() is None   # outside the block: nothing
    gc.disable()
    try:
        with SafePoints():
            pass
        assert not gc.isenabled()   # off before, off after
    finally:
        if enabled:
            gc.enable()
