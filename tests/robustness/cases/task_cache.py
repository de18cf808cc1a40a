"""Bad input against cached task results: an edited one is recomputed, never returned."""

from __future__ import annotations

import contextlib
import io
import json

from tests.robustness.harness import Attempt, Case, _grid_task, _resealed


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []

    # --- cached task results: an edited one is recomputed, never returned ---------------------
    def cache_case(name, damage):
        def prepare(s, d):
            from psmforce.experiments.task_cache import cache_path, run_grid
            cache = d / "cache"
            tasks = [(_grid_task, {"x": x}) for x in (1, 2)]
            with contextlib.redirect_stdout(io.StringIO()):
                run_grid(tasks, cache, log=lambda text: None)
            path = cache_path(cache, _grid_task, {"x": 2})
            damage(path)

            def run():
                logged = []
                return run_grid(tasks, cache, log=logged.append), logged

            def check(result):
                results, logged = result
                redone = any("recomputing" in line for line in logged)
                return (results == [{"y": 2}, {"y": 4}] and redone,
                        f"results {results}, recomputed {redone}")
            return Attempt(call=run, check=check, outputs=(str(path),))  # the cache's own file
        found.append(Case("api run_grid: cache", name, "HANDLED", prepare))

    def edit_record(change):
        def damage(path):
            record = json.loads(path.read_text())
            change(record)
            path.write_text(json.dumps(record))
        return damage

    cache_case("a result number edited", edit_record(lambda r: r["result"].update(y=400)))
    cache_case("parameters edited", edit_record(lambda r: r["params"].update(x=7)))
    cache_case("written before the envelope", edit_record(lambda r: [
        r.pop(k) for k in ("sha256", "format", "format_version")]))
    cache_case("format_version '1'", edit_record(lambda r: r.update(format_version="1")))
    cache_case("truncated", lambda path: path.write_text(path.read_text()[:40]))
    cache_case("edited and resealed for another task", lambda path: path.write_text(json.dumps(
        _resealed(json.loads(path.read_text()), task="fuzz:_other")) + "\n"))
    return found
