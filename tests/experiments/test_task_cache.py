"""The task cache: stable keys from registered names, resume after an interruption, atomic
results, results of earlier keys adopted, Ray = in-process."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from psmforce.experiments.task_cache import (GridError, cache_path, read_result, run_grid, task,
                                             task_key)

_QUALNAME = f"{__name__}:_counted_task"   # how keys named the task below before registration
CALLS: list[dict] = []  # parameters of every in-process call of the task functions below
FAIL_AT: set[int] = set()  # values of ``i`` at which ``_counted_task`` raises


class _Interrupted(Exception):
    """Stands for whatever stops a run (Ctrl-C, a killed job, a crashed task)."""


@task("test_stats")
def _stats_task(params: dict) -> dict:
    """Deterministic numpy work from a seed, free of BLAS, so any thread count gives the same bits."""
    x = np.random.default_rng(params["seed"]).standard_normal(params["n"])
    return {"seed": params["seed"], "sum": float(np.sum(x)), "max": float(np.max(x)),
            "q90": float(np.quantile(x, 0.9)), "sorted_head": np.sort(x)[:3].tolist()}


@task("test_counted", formerly=(_QUALNAME,))
def _counted_task(params: dict) -> dict:
    CALLS.append(params)
    if params["i"] in FAIL_AT:
        raise _Interrupted(f"task {params['i']} stopped")
    return _stats_task(params)


@task("test_failing")
def _failing_task(params: dict) -> dict:
    raise ValueError(f"bad seed {params['seed']}")


@pytest.fixture(autouse=True)
def _fresh_counters():
    CALLS.clear()
    FAIL_AT.clear()
    yield
    CALLS.clear()
    FAIL_AT.clear()


def _grid(n_tasks: int) -> list:
    return [(_counted_task, {"i": i, "seed": 100 + i, "n": 257}) for i in range(n_tasks)]


def _files(cache: Path) -> set[str]:
    return {p.name for p in cache.iterdir()}


GOLDEN_KEY = "c006d35edf5a7c97"  # sha256 of {"fn": "test_stats@1", "params": ...}, sorted keys


def test_task_key_is_stable_and_changes_with_every_parameter():
    params = {"seed": 3, "lr": 1e-3, "protocol": "rigid", "layers": [2, 4], "opt": {"wd": 0.0}}
    key = task_key(_stats_task, params)
    # A golden value: changing how keys are made would orphan every cache already on disk.
    assert key == GOLDEN_KEY
    assert task_key(_stats_task, dict(reversed(list(params.items())))) == key  # order-free
    changed = {"seed": 4, "lr": 2e-3, "protocol": "soft", "layers": [2, 5], "opt": {"wd": 0.1}}
    keys = {task_key(_stats_task, {**params, k: v}) for k, v in changed.items()}
    keys |= {task_key(_stats_task, {**params, "seed": 3.0}),  # 3 and 3.0 are different runs
             task_key(_stats_task, {**params, "extra": None}),
             task_key(_counted_task, params)}  # another task
    assert len(keys) == 8 and key not in keys
    assert len(key) == 16 and int(key, 16) >= 0
    assert cache_path(Path("c"), _counted_task, params).name == (
        f"test_counted-{task_key(_counted_task, params)}.json")


@pytest.mark.parametrize("bad", [{1, 2}, Path("x"), np.int64(3), object()])
def test_non_json_parameters_raise_grid_error_before_anything_runs(tmp_path, bad):
    with pytest.raises(GridError, match="JSON"):
        task_key(_stats_task, {"seed": bad})
    with pytest.raises(GridError, match="JSON"):
        run_grid([(_counted_task, {"i": 0, "seed": 1, "n": 4}),
                  (_counted_task, {"i": 1, "seed": bad, "n": 4})], tmp_path, log=lambda s: None)
    assert CALLS == [] and _files(tmp_path) == set()


def test_resume_runs_only_unfinished_tasks_and_matches_a_fresh_run(tmp_path):
    tasks = _grid(5)
    cache = tmp_path / "cache"
    FAIL_AT.add(2)
    with pytest.raises(_Interrupted):
        run_grid(tasks, cache, log=lambda s: None)
    assert [c["i"] for c in CALLS] == [0, 1, 2]
    # Exactly the two finished tasks' results: nothing for the third, no partial file.
    assert _files(cache) == {cache_path(cache, fn, p).name for fn, p in tasks[:2]}

    FAIL_AT.clear()
    CALLS.clear()
    lines: list[str] = []
    resumed = run_grid(tasks, cache, log=lines.append)
    assert [c["i"] for c in CALLS] == [2, 3, 4]
    assert lines[0] == "grid: 5 tasks, 2 cached, 3 to run"
    assert _files(cache) == {cache_path(cache, fn, p).name for fn, p in tasks}

    CALLS.clear()
    fresh = run_grid(tasks, tmp_path / "fresh", log=lambda s: None)
    assert resumed == fresh == [_stats_task(p) for _, p in tasks]

    CALLS.clear()
    assert run_grid(tasks, cache, log=lines.append) == fresh
    assert CALLS == [] and lines[-1] == "grid: 5 tasks, 5 cached, 0 to run"


def test_record_holds_task_params_and_result(tmp_path):
    (fn, p), = _grid(1)
    [result] = run_grid([(fn, p)], tmp_path, log=lambda s: None)
    record = json.loads(cache_path(tmp_path, fn, p).read_text())
    assert record["task"] == "test_counted@1"
    assert record["params"] == p and record["result"] == result and record["seconds"] >= 0


def test_interrupted_write_leaves_nothing_that_reads_as_done(tmp_path, monkeypatch):
    tasks = _grid(2)
    real_replace, real_unlink = Path.replace, Path.unlink

    def killed_before_rename(self, target):
        raise _Interrupted("killed between write and rename")

    # A killed process runs no clean-up either: the temporary file stays.
    monkeypatch.setattr(Path, "replace", killed_before_rename)
    monkeypatch.setattr(Path, "unlink", lambda self, missing_ok=False: None)
    with pytest.raises(_Interrupted):
        run_grid(tasks, tmp_path, log=lambda s: None)
    monkeypatch.setattr(Path, "replace", real_replace)
    monkeypatch.setattr(Path, "unlink", real_unlink)
    # The result reached only the temporary file, which is not a result.
    parts = [n for n in _files(tmp_path) if n.endswith(".part")]
    assert len(parts) == 1 and parts[0].startswith(".")
    assert not any(n.endswith(".json") for n in _files(tmp_path))

    # A stray temporary file, even one holding a well-formed record, does not count as done.
    fn, p = tasks[1]
    stray = tmp_path / f".{cache_path(tmp_path, fn, p).name}.12345.part"
    stray.write_text(json.dumps({"task": "x", "params": p, "seconds": 0, "result": {"bogus": 1}}))
    CALLS.clear()
    lines: list[str] = []
    results = run_grid(tasks, tmp_path, log=lines.append)
    assert lines[0] == "grid: 2 tasks, 0 cached, 2 to run"
    assert [c["i"] for c in CALLS] == [0, 1]
    assert results == [_stats_task(p) for _, p in tasks]


def _located(n_tasks: int, run_dir: str) -> list:
    return [(fn, {**p, "run_dir": run_dir}) for fn, p in _grid(n_tasks)]


def test_a_moved_run_reads_its_results_back(tmp_path):
    """The run folder's path is where the files are, not what a task computes: out of the key."""
    here, there = _located(3, "/lab/run"), _located(3, "/mnt/moved/run")
    assert [task_key(fn, p) for fn, p in here] == [task_key(fn, p) for fn, p in there]
    assert task_key(*here[0]) == task_key(*_grid(1)[0])   # keys of runs without one unchanged
    first = run_grid(here, tmp_path, log=lambda s: None)
    CALLS.clear()
    lines: list[str] = []
    assert run_grid(there, tmp_path, log=lines.append) == first
    assert CALLS == [] and lines == ["grid: 3 tasks, 3 cached, 0 to run"]
    # the check still holds every other parameter to the file's
    fn, p = there[0]
    with pytest.raises(GridError, match="other parameters"):
        read_result(cache_path(tmp_path, fn, p), fn, {**p, "n": 258})


def test_a_run_finished_on_another_device_reads_its_results_back(tmp_path):
    """``finish_on`` says where the remaining tasks compute (a GPU run finished on the CPU):
    out of the key, so what the first device finished is read back, not recomputed."""
    on_gpu = [(fn, {**p, "finish_on": None}) for fn, p in _grid(3)]
    first = run_grid(on_gpu[:2], tmp_path, log=lambda s: None)
    CALLS.clear()
    on_cpu = [(fn, {**p, "finish_on": "cpu"}) for fn, p in _grid(3)]
    lines: list[str] = []
    assert run_grid(on_cpu, tmp_path, log=lines.append)[:2] == first
    assert [c["i"] for c in CALLS] == [2] and lines[0] == "grid: 3 tasks, 2 cached, 1 to run"


def test_results_keyed_by_an_earlier_path_are_adopted_when_they_verify(tmp_path):
    """Keys once hashed the run folder's path: such files are linked under their current name
    (and kept, for a process of the earlier code); one that fails its check is recomputed."""
    old = _located(3, "/old/place/run")
    run_grid(old, tmp_path, log=lambda s: None)

    def path_keyed(fn, p):  # how keys were made when they held the path
        text = json.dumps({"fn": "test_counted@1", "params": p}, sort_keys=True)
        return tmp_path / f"counted_task-{hashlib.sha256(text.encode()).hexdigest()[:16]}.json"

    for fn, p in old:
        cache_path(tmp_path, fn, p).rename(path_keyed(fn, p))
    tampered = path_keyed(*old[2])
    tampered.write_text(tampered.read_text().replace('"sum": ', '"sum": 1'))
    CALLS.clear()
    lines: list[str] = []
    moved = _located(3, "/new/place/run")
    results = run_grid(moved, tmp_path, log=lines.append)
    assert lines[:2] == ["grid: 2 results cached under an earlier key read back",
                         "grid: 3 tasks, 2 cached, 1 to run"]
    assert [c["i"] for c in CALLS] == [2]
    assert results == [_stats_task(p) for _, p in moved]
    assert all(path_keyed(fn, p).exists() for fn, p in old)   # the earlier names are kept
    CALLS.clear()
    assert run_grid(moved, tmp_path, log=lambda s: None) == results and CALLS == []


@pytest.mark.slow
def test_ray_local_matches_in_process(tmp_path):
    pytest.importorskip("ray")
    tasks = [(_stats_task, {"seed": s, "n": 1000}) for s in (0, 1, 7, 42)]
    local = run_grid(tasks, tmp_path / "inproc", log=lambda s: None)
    lines: list[str] = []
    on_ray = run_grid(tasks, tmp_path / "ray", ray_address="local", log=lines.append)
    assert on_ray == local
    assert lines[0] == "grid: 4 tasks, 0 cached, 4 to run on Ray (local)"
    assert len(lines) == 5 and all(line.endswith("(Ray)") for line in lines[1:])
    # The same cache: file names and results agree, so a run can move between executors.
    assert _files(tmp_path / "ray") == _files(tmp_path / "inproc")
    for name in _files(tmp_path / "ray"):
        a, b = (json.loads((tmp_path / d / name).read_text()) for d in ("inproc", "ray"))
        assert a["result"] == b["result"] and a["params"] == b["params"]
    # Everything cached: Ray is not even started.
    assert run_grid(tasks, tmp_path / "ray", ray_address="local", log=lines.append) == local
    assert lines[-1] == "grid: 4 tasks, 4 cached, 0 to run"


@pytest.mark.slow
def test_ray_task_failure_raises_grid_error_naming_the_task(tmp_path):
    pytest.importorskip("ray")
    expected = r"(?s)task test_failing seed=5 failed on Ray: .*ValueError: bad seed 5"
    with pytest.raises(GridError, match=expected):
        run_grid([(_failing_task, {"seed": 5})], tmp_path, ray_address="local", log=lambda s: None)
    assert _files(tmp_path) == set()


def _qualname_keyed(cache: Path, p: dict, qualname: str = _QUALNAME) -> Path:
    """Where a result lay when keys hashed the function's qualified name (before registration)."""
    text = json.dumps({"fn": qualname, "params": p}, sort_keys=True)
    return cache / f"counted_task-{hashlib.sha256(text.encode()).hexdigest()[:16]}.json"


def test_results_keyed_by_the_functions_earlier_name_are_adopted(tmp_path):
    """The key once hashed the function's module and name, so moving code orphaned a run's
    results; a task names its earlier identity (``formerly``) and such results are read back
    without recomputing, verified as before (a tampered one is recomputed) and the old files kept."""
    from psmforce.core.integrity import seal
    tasks = _grid(3)
    for fn, p in tasks:
        record = seal({"format": "psmforce-task-result", "format_version": 1, "task": _QUALNAME,
                       "params": p, "seconds": 0.5, "result": _stats_task(p)})
        _qualname_keyed(tmp_path, p).write_text(json.dumps(record))
    tampered = _qualname_keyed(tmp_path, tasks[1][1])
    tampered.write_text(tampered.read_text().replace('"sum": ', '"sum": 1'))
    lines: list[str] = []
    assert run_grid(tasks, tmp_path, log=lines.append) == [_stats_task(p) for _, p in tasks]
    assert lines[:2] == ["grid: 2 results cached under an earlier key read back",
                         "grid: 3 tasks, 2 cached, 1 to run"]
    assert [c["i"] for c in CALLS] == [1]
    assert all(_qualname_keyed(tmp_path, p).exists() for _, p in tasks)
    # another task's earlier name is not this task's
    assert not _task_of(_stats_task).accepts(_QUALNAME)


def _task_of(fn):
    return fn.task


def test_a_version_bump_is_another_task_and_an_unregistered_function_is_refused(tmp_path):
    params = {"seed": 3, "n": 5}

    def _plain(p: dict) -> dict:
        return p

    with pytest.raises(GridError, match="not a registered task.*@task"):
        run_grid([(_plain, params)], tmp_path, log=lambda s: None)
    assert _files(tmp_path) == set()
    bumped = task("test_stats_v2", version=2)(lambda p: _stats_task(p))
    again = task("test_stats_v3", version=3)(lambda p: _stats_task(p))
    assert task_key(bumped, params) != task_key(again, params)
    with pytest.raises(GridError, match="taken by"):
        task("test_stats")(_plain)
