"""A cache of independent tasks: how ``psmforce reproduce`` runs and resumes.

A task is a pair (function, parameters): a top-level function ``fn(params: dict) -> dict``
registered under a name and a version (:func:`task`), and JSON parameters that say everything
the result depends on. Its result is cached as ``CACHE/<name>-<key>.json``, where ``key`` hashes
the task's name, its version and the parameters but those that only say where a run's files live
(:data:`LOCATION_PARAMS`): run the tasks again after an interruption, or in the run folder moved
elsewhere or finished on another machine, and every finished task is read back, not recomputed;
change a parameter, or bump a task's version when what it computes changes, and only the tasks it
reaches run again. Where the function lives is not part of the key, so code can move between
modules without orphaning a run's results; results cached under a task's earlier keys (its
function's qualified name, before tasks were registered, or a key that held the run folder's
path) are adopted when their parameters match (:func:`run_grid`). A result is written atomically
(temporary file, then rename), so an interrupted task leaves nothing that reads as done.

A cached result is trusted only if it verifies (:func:`read_result`): its ``format`` and integer
``format_version`` (:data:`RESULT_VERSION`), the integrity envelope over the task, parameters,
seconds and result (:mod:`psmforce.core.integrity`), and the task and parameters it was computed
for equal to the ones asked (location aside). Anything else (an edited number, a file from an
older version without the envelope, a truncated or foreign file) is logged by name and recomputed,
never returned, so no table is rendered from it.

Executors: in-process, one task after another (the default; no extra dependency), or Ray
(``ray_address``: ``"auto"``, ``"local"`` for a fresh local instance, or a cluster address; the
optional extra ``psmforce[cluster]``), which runs the same functions on the same parameters and
writes the same cache, so a run may be started on a laptop and finished on a cluster.
"""
from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import logging
import os
import shutil
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

from psmforce.core.integrity import check_version, seal, verify
from psmforce.core.files import atomic_path

RESULT_FORMAT = "psmforce-task-result"
RESULT_VERSION = 1
"""1: the first cached results with the integrity envelope (older files carry none: recomputed)."""

LOCATION_PARAMS = ("run_dir", "finish_on")
"""Parameters that say where a run's files are and where its remaining tasks compute, not what a
task computes: a task's key and its cached result's check leave them out. The cache lives in the
run folder, so a key that held the folder's path tied every result to that path, and a moved run
recomputed everything. A task's result must not depend on them otherwise (it names files inside
the run folder relative to it; a training on a ``finish_on`` device records the device of each
epoch, :func:`psmforce.experiments.reproduce.reproduce`)."""

TaskSpec = tuple[Callable[[dict], dict], dict]


class GridError(RuntimeError):
    """Tasks that cannot run as asked (bad executor, unserialisable parameters, an unregistered
    function, a failed task)."""


@dataclasses.dataclass(frozen=True)
class Task:
    """What names a task in its cache: ``name`` (unique among registered tasks), ``version``
    (bump it when what the task computes from the same parameters changes) and ``formerly``, the
    identities its results were cached under before (``"module:qualname"`` of the function from
    the days the key held it), which are read back as this task's."""
    name: str
    version: int
    formerly: tuple[str, ...] = ()

    @property
    def identity(self) -> str:
        return f"{self.name}@{self.version}"

    def accepts(self, identity: str) -> bool:
        return identity == self.identity or identity in self.formerly


_REGISTERED: dict[str, str] = {}
"""Task name -> ``module:qualname`` of the function registered under it."""


def task(name: str, version: int = 1, formerly: Sequence[str] = ()) -> Callable:
    """Register a top-level function as the task ``name`` (:class:`Task`)."""
    if not name.isidentifier() or not isinstance(version, int) or version < 1:
        raise GridError(f"a task needs an identifier name and a version >= 1, got {name!r}, "
                        f"{version!r}")

    def register(fn: Callable[[dict], dict]) -> Callable[[dict], dict]:
        where = _qualname(fn)
        if _REGISTERED.setdefault(name, where) != where:
            raise GridError(f"task name '{name}' is taken by {_REGISTERED[name]}")
        fn.task = Task(name, version, tuple(formerly))
        return fn

    return register


def _task(fn: Callable) -> Task:
    registered = getattr(fn, "task", None)
    if not isinstance(registered, Task):
        raise GridError(f"{_qualname(fn)} is not a registered task: decorate it with "
                        f"@task(name, version)")
    return registered


def _qualname(fn: Callable) -> str:
    return f"{fn.__module__}:{fn.__qualname__}"


def _identity(params: dict) -> dict:
    """What a task computes from: its parameters without :data:`LOCATION_PARAMS`."""
    return {k: v for k, v in params.items() if k not in LOCATION_PARAMS}


def _key(identity: str, params: dict) -> str:
    try:
        text = json.dumps({"fn": identity, "params": _identity(params)}, sort_keys=True)
    except TypeError as err:
        raise GridError(f"task parameters must be JSON: {err}") from None
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def task_key(fn: Callable, params: dict) -> str:
    """Stable 16-hex-digit key of a task: its registered name and version and its parameters
    (:data:`LOCATION_PARAMS` aside)."""
    return _key(_task(fn).identity, params)


def cache_path(cache: Path, fn: Callable, params: dict) -> Path:
    return Path(cache) / f"{_task(fn).name}-{task_key(fn, params)}.json"


def read_result(path: Path, fn: Callable, params: dict) -> dict:
    """The verified result cached at ``path`` for the task ``fn`` with ``params``, else
    :class:`GridError` naming the file and why (module docstring)."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise GridError(f"{path}: unreadable cached result ({type(err).__name__})") from None
    if not isinstance(record, dict) or record.get("format") != RESULT_FORMAT:
        raise GridError(f"{path}: not a {RESULT_FORMAT} file (written before results were "
                        f"sealed, or foreign)")
    check_version(record.get("format_version"), (RESULT_VERSION,), str(path), "cached result",
                  GridError)
    verify(record, str(path), "cached result", GridError)
    stored = record.get("params")
    if (not isinstance(record.get("task"), str) or not _task(fn).accepts(record["task"])
            or not isinstance(stored, dict)
            or _identity(stored) != _identity(json.loads(json.dumps(params)))):
        raise GridError(f"{path}: cached for another task or other parameters")
    return record["result"]


def _cached(path: Path, fn: Callable, params: dict, log: Callable[[str], None] | None = None
            ) -> dict | None:
    """The verified cached result, or None (a file that fails is logged and will be redone)."""
    if not path.exists():
        return None
    try:
        return read_result(path, fn, params)
    except GridError as err:
        (log or (lambda text: print(text, file=sys.stderr)))(
            f"grid: recomputing, the cached result fails its check: {err}")
        return None


def cached_result(cache: str | Path, fn: Callable, params: dict) -> dict | None:
    """The verified cached result of the task (``fn``, ``params``) in ``cache``, or None when
    there is none or it fails its check (:func:`read_result`)."""
    return _cached(cache_path(Path(cache), fn, params), fn, params, lambda _: None)


def run_task(where: str, params: dict, cache: str) -> dict:
    """Run one task, found by its function's ``module:qualname``, and cache its result (what a
    worker runs); a cached result is returned only if it verifies (:func:`read_result`)."""
    module, name = where.split(":")
    fn = getattr(importlib.import_module(module), name)
    path = cache_path(Path(cache), fn, params)
    cached = _cached(path, fn, params)
    if cached is not None:
        return cached
    t0 = time.perf_counter()
    result = fn(params)
    record = seal({"format": RESULT_FORMAT, "format_version": RESULT_VERSION,
                   "task": _task(fn).identity, "params": params,
                   "seconds": time.perf_counter() - t0, "result": result})
    with atomic_path(path) as tmp:  # Ray workers may race on one key: each its own sibling
        tmp.write_text(json.dumps(record, indent=1) + "\n")
    return record["result"]


def run_grid(tasks: Sequence[TaskSpec], cache: str | Path, *, ray_address: str | None = None,
             log: Callable[[str], None] = print, adopt: bool = True) -> list[dict]:
    """Results of ``tasks`` in order, each read from ``cache`` when done before (under its key,
    or, with ``adopt``, under an earlier one: :func:`adopt_earlier_keys`), else computed
    (in-process, or on Ray when ``ray_address`` is given) and cached."""
    cache = Path(cache)
    for fn, _ in tasks:
        _task(fn)  # refused before anything runs
    cache.mkdir(parents=True, exist_ok=True)
    if adopt:
        adopt_earlier_keys(cache, tasks, log)
    todo = [(i, fn, p) for i, (fn, p) in enumerate(tasks)
            if _cached(cache_path(cache, fn, p), fn, p, log) is None]
    log(f"grid: {len(tasks)} tasks, {len(tasks) - len(todo)} cached, {len(todo)} to run"
        + (f" on Ray ({ray_address})" if ray_address and todo else ""))
    if todo and ray_address:
        _run_on_ray(todo, cache, ray_address, log)
    for n, (i, fn, p) in enumerate(todo):
        if not ray_address:
            t0 = time.perf_counter()
            run_task(_qualname(fn), p, str(cache))
            log(f"  [{n + 1}/{len(todo)}] {_task(fn).name} {_short(p)}: "
                f"{time.perf_counter() - t0:.0f} s")
    return [read_result(cache_path(cache, fn, p), fn, p) for fn, p in tasks]


def adopt_earlier_keys(cache: Path, tasks: Sequence[TaskSpec], log) -> None:
    """Give a current name to the results of ``tasks`` cached under an earlier key: one that
    hashed the function's qualified name (:attr:`Task.formerly`) or the run folder's path
    (:data:`LOCATION_PARAMS`), so runs made then resume. Such a file is linked (or copied) under
    its key, and kept: a process of the earlier code may still read it. Only a file whose result
    verifies for the task is adopted; the rest are left to be recomputed as before."""
    wanted = {cache_path(cache, fn, p).name: (fn, p) for fn, p in tasks}
    missing = {name: spec for name, spec in wanted.items() if not (cache / name).exists()}
    if not missing:
        return
    by_identity = {}
    for name, (fn, p) in missing.items():
        params = json.dumps(_identity(json.loads(json.dumps(p))), sort_keys=True)
        for identity in (_task(fn).identity, *_task(fn).formerly):
            by_identity[(identity, params)] = name
    adopted = 0
    for path in sorted(cache.glob("*.json")):
        if path.name in wanted:
            continue
        try:
            record = json.loads(path.read_text())
            name = by_identity.get((record["task"],
                                    json.dumps(_identity(record["params"]), sort_keys=True)))
            if name is None or name not in missing:
                continue
            fn, p = missing[name]
            read_result(path, fn, p)
        except (OSError, ValueError, TypeError, KeyError, AttributeError, GridError):
            continue  # not a result of these tasks, or one that fails its check: not adopted
        try:
            os.link(path, cache / name)
        except OSError:  # a file system without hard links
            with atomic_path(cache / name) as tmp:
                shutil.copyfile(path, tmp)
        del missing[name]
        adopted += 1
    if adopted:
        log(f"grid: {adopted} results cached under an earlier key read back")


def _short(params: dict) -> str:
    return " ".join(f"{k}={v}" for k, v in params.items()
                    if isinstance(v, (int, float, str)) and k not in LOCATION_PARAMS)


def _local_ray() -> dict:
    """``ray.init`` arguments for a fresh instance on this machine (``"local"``, which Ray takes to
    mean a new instance even where one started by ``ray start`` runs: ``None`` would join that).
    Its workers run this interpreter here, so they get the driver's import path: any task function
    the in-process executor can import (a script's, a test's), they can too. Results travel
    through the cache files, not the object store, so a small store spares the machine's memory."""
    return {"object_store_memory": 100 * 2**20,
            "runtime_env": {"env_vars": {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}}}


def _run_on_ray(todo, cache: Path, address: str, log) -> None:
    """Run ``todo`` on Ray, joining an instance already started in this process, else starting or
    joining ``address`` for the call only; Ray's own start-up chatter is kept below warnings, the
    grid's log says what runs."""
    try:
        import ray
    except ImportError:
        raise GridError("--ray needs Ray: pip install 'psmforce[cluster]'") from None
    started = not ray.is_initialized()
    if started:
        ray.init(address=address, include_dashboard=False, log_to_driver=False,
                 logging_level=logging.WARNING,
                 **(_local_ray() if address == "local" else {}))
    try:
        remote = ray.remote(run_task)
        pending = {remote.remote(_qualname(fn), p, str(cache.resolve())): (fn, p)
                   for _, fn, p in todo}
        done = 0
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            fn, p = pending.pop(ready[0])
            try:
                ray.get(ready[0])
            except Exception as err:  # a worker's failure names its task
                raise GridError(f"task {_task(fn).name} {_short(p)} failed on Ray: {err}") from None
            done += 1
            log(f"  [{done}/{len(todo)}] {_task(fn).name} {_short(p)} (Ray)")
    finally:
        if started:
            ray.shutdown()
