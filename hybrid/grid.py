"""A grid of independent, cached tasks: how ``psmforce reproduce`` runs and resumes.

A task is a pair (function, parameters): a top-level function ``fn(params: dict) -> dict``
(importable by name, so another process or machine can run it) and JSON parameters that say
everything the result depends on. Its result is cached as ``CACHE/<name>-<key>.json``, where
``key`` hashes the function's qualified name and the parameters but those that only say where a
run's files live (:data:`LOCATION_PARAMS`): run the grid again after an interruption, or in the
run folder moved elsewhere or finished on another machine, and every finished task is read back,
not recomputed; change a parameter and only the tasks it reaches run again. A result is written
atomically (temporary file, then rename), so an interrupted task leaves nothing that reads as
done.

A cached result is trusted only if it verifies (:func:`read_result`): its ``format`` and integer
``format_version`` (:data:`RESULT_VERSION`), the integrity envelope over the task, parameters,
seconds and result (:mod:`hybrid.integrity`), and the task and parameters it was computed for
equal to the ones asked (location aside). Anything else (an edited number, a file from an older
version without the envelope, a truncated or foreign file) is logged by name and recomputed, never
returned, so no table is rendered from it.

Executors: in-process, one task after another (the default; no extra dependency), or Ray
(``ray_address``: ``"auto"``, ``"local"`` for a fresh local instance, or a cluster address; the
optional extra ``psmforce[cluster]``), which runs the same functions on the same parameters and
writes the same cache, so a run may be started on a laptop and finished on a cluster.
"""

from __future__ import annotations

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

from hybrid.integrity import check_version, seal, verify
from psm_model.files import atomic_path

RESULT_FORMAT = "psmforce-task-result"
RESULT_VERSION = 1
"""1: the first cached results with the integrity envelope (older files carry none: recomputed)."""

LOCATION_PARAMS = ("run_dir", "finish_on")
"""Parameters that say where a run's files are and where its remaining tasks compute, not what a
task computes: a task's key and its cached result's check leave them out. The cache lives in the
run folder, so a key that held the folder's path tied every result to that path, and a moved run
recomputed everything. A task's result must not depend on them otherwise (it names files inside
the run folder relative to it; a training on a ``finish_on`` device records the device of each
epoch, :func:`hybrid.reproduce.reproduce`)."""

TaskSpec = tuple[Callable[[dict], dict], dict]


class GridError(RuntimeError):
    """A grid that cannot run as asked (bad executor, unserialisable parameters, failed task)."""


def _qualname(fn: Callable) -> str:
    return f"{fn.__module__}:{fn.__qualname__}"


def _identity(params: dict) -> dict:
    """What a task computes from: its parameters without :data:`LOCATION_PARAMS`."""
    return {k: v for k, v in params.items() if k not in LOCATION_PARAMS}


def _key(qualname: str, params: dict) -> str:
    try:
        text = json.dumps({"fn": qualname, "params": _identity(params)}, sort_keys=True)
    except TypeError as err:
        raise GridError(f"task parameters must be JSON: {err}") from None
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def task_key(fn: Callable, params: dict) -> str:
    """Stable 16-hex-digit key of a task: its function's qualified name and its parameters
    (:data:`LOCATION_PARAMS` aside)."""
    return _key(_qualname(fn), params)


def cache_path(cache: Path, fn: Callable, params: dict) -> Path:
    return Path(cache) / f"{fn.__name__.lstrip('_')}-{task_key(fn, params)}.json"


def read_result(path: Path, qualname: str, params: dict) -> dict:
    """The verified result cached at ``path`` for the task ``qualname`` with ``params``, else
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
    if (record.get("task") != qualname or not isinstance(stored, dict)
            or _identity(stored) != _identity(json.loads(json.dumps(params)))):
        raise GridError(f"{path}: cached for another task or other parameters")
    return record["result"]


def _cached(path: Path, qualname: str, params: dict, log: Callable[[str], None] | None = None
            ) -> dict | None:
    """The verified cached result, or None (a file that fails is logged and will be redone)."""
    if not path.exists():
        return None
    try:
        return read_result(path, qualname, params)
    except GridError as err:
        (log or (lambda text: print(text, file=sys.stderr)))(
            f"grid: recomputing, the cached result fails its check: {err}")
        return None


def cached_result(cache: str | Path, fn: Callable, params: dict) -> dict | None:
    """The verified cached result of the task (``fn``, ``params``) in ``cache``, or None when
    there is none or it fails its check (:func:`read_result`)."""
    return _cached(cache_path(Path(cache), fn, params), _qualname(fn), params, lambda _: None)


def run_task(qualname: str, params: dict, cache: str) -> dict:
    """Run one task by its function's qualified name and cache its result (what a worker runs);
    a cached result is returned only if it verifies (:func:`read_result`)."""
    module, name = qualname.split(":")
    fn = getattr(importlib.import_module(module), name)
    path = cache_path(Path(cache), fn, params)
    cached = _cached(path, qualname, params)
    if cached is not None:
        return cached
    t0 = time.perf_counter()
    result = fn(params)
    record = seal({"format": RESULT_FORMAT, "format_version": RESULT_VERSION, "task": qualname,
                   "params": params, "seconds": time.perf_counter() - t0, "result": result})
    with atomic_path(path, per_process=True) as tmp:  # Ray workers may race on one key
        tmp.write_text(json.dumps(record, indent=1) + "\n")
    return record["result"]


def run_grid(tasks: Sequence[TaskSpec], cache: str | Path, *, ray_address: str | None = None,
             log: Callable[[str], None] = print) -> list[dict]:
    """Results of ``tasks`` in order, each read from ``cache`` when done before, else computed
    (in-process, or on Ray when ``ray_address`` is given) and cached."""
    cache = Path(cache)
    cache.mkdir(parents=True, exist_ok=True)
    _adopt_location_keyed(cache, tasks, log)
    todo = [(i, fn, p) for i, (fn, p) in enumerate(tasks)
            if _cached(cache_path(cache, fn, p), _qualname(fn), p, log) is None]
    log(f"grid: {len(tasks)} tasks, {len(tasks) - len(todo)} cached, {len(todo)} to run"
        + (f" on Ray ({ray_address})" if ray_address and todo else ""))
    if todo and ray_address:
        _run_on_ray(todo, cache, ray_address, log)
    for n, (i, fn, p) in enumerate(todo):
        if not ray_address:
            t0 = time.perf_counter()
            run_task(_qualname(fn), p, str(cache))
            log(f"  [{n + 1}/{len(todo)}] {fn.__name__.lstrip('_')} {_short(p)}: "
                f"{time.perf_counter() - t0:.0f} s")
    return [read_result(cache_path(cache, fn, p), _qualname(fn), p) for fn, p in tasks]


def _adopt_location_keyed(cache: Path, tasks: Sequence[TaskSpec], log) -> None:
    """Give a current name to the results of ``tasks`` cached when keys still hashed the run
    folder's path (:data:`LOCATION_PARAMS`), so runs made then resume. Such a file is linked (or
    copied) under its key, and kept: a process of the earlier code may still read it. Only a file
    whose result verifies is adopted; the rest are left to be recomputed as before."""
    wanted = {cache_path(cache, fn, p).name for fn, p in tasks}
    missing = {name for name in wanted if not (cache / name).exists()}
    if not missing:
        return
    adopted = 0
    for path in sorted(cache.glob("*.json")):
        if path.name in wanted:
            continue
        try:
            record = json.loads(path.read_text())
            name = f"{path.stem.rsplit('-', 1)[0]}-{_key(record['task'], record['params'])}.json"
            if name not in missing:
                continue
            read_result(path, record["task"], record["params"])
        except (OSError, ValueError, TypeError, KeyError, GridError):
            continue  # not a result of these tasks, or one that fails its check: not adopted
        try:
            os.link(path, cache / name)
        except OSError:  # a file system without hard links
            with atomic_path(cache / name, per_process=True) as tmp:
                shutil.copyfile(path, tmp)
        missing.discard(name)
        adopted += 1
    if adopted:
        log(f"grid: {adopted} results cached under their run folder's earlier path read back")


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
                raise GridError(f"task {fn.__name__} {_short(p)} failed on Ray: {err}") from None
            done += 1
            log(f"  [{done}/{len(todo)}] {fn.__name__.lstrip('_')} {_short(p)} (Ray)")
    finally:
        if started:
            ray.shutdown()
