"""Whether two machines built the same benches: the published comparison's trainings of one scale
ran partly on this machine's CPU and partly on a lent GPU whose numpy and scipy differ from
``constraints.txt`` (issue 45), each machine simulating the declared seeds' benches itself.

For each bench seed both ``reproduce`` runs' task caches hold (each run given as the folder
``reproduce`` was given, ``studies/comparison.py``'s ``--work VERSION/scale_S``): whether the
bench files are bit-identical (the SHA-256 the simulate task keeps), whether their layout is
(trials, rows, minutes per split), and the largest relative difference between the floor's
errors each machine computed (every figure of the ``floor`` task: the same scoring of each
bench's signals).

    python studies/bench_agreement.py --a runs/comparison/2.3/scale_0.25 --label-a cpu \\
        --b <the GPU run's copy> --label-b cuda --json results/benchmarks/bench_agreement.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from studies.records import read_json  # noqa: E402


def _by_seed(cache: Path, task: str) -> dict[int, dict]:
    """``{seed: cached task file}`` of the ``task`` results in ``cache`` (read as user input)."""
    out = {}
    for path in sorted(cache.glob(f"{task}-*.json")):
        kept = read_json(path, "cached task result")
        if not isinstance(kept, dict) or not str(kept.get("task", "")).startswith(f"{task}@"):
            raise ValueError(f"{path}: not a cached {task} task")
        seed = kept.get("params", {}).get("seed")
        if seed in out:
            raise ValueError(f"{cache}: two {task} results for seed {seed}; one run per cache")
        out[seed] = kept
    return out


def _numbers(tree, path: str = "") -> dict[str, float]:
    """Every number in ``tree`` by its path (``/automated/paper/Fx/rmse_n``)."""
    if isinstance(tree, dict):
        out: dict[str, float] = {}
        for key, sub in tree.items():
            out.update(_numbers(sub, f"{path}/{key}"))
        return out
    if isinstance(tree, (int, float)) and not isinstance(tree, bool):
        return {path: float(tree)}
    return {}


def _largest_relative_difference(a: dict, b: dict, where: str) -> float:
    na, nb = _numbers(a), _numbers(b)
    if set(na) != set(nb):
        raise ValueError(f"{where}: the two floors hold different figures")
    return max((abs(na[k] - nb[k]) / max(abs(na[k]), abs(nb[k])) for k in na
                if na[k] != nb[k]), default=0.0)


def agreement(cache_a: Path, cache_b: Path, label_a: str, label_b: str) -> dict:
    """Per seed both caches hold, how the two machines' benches and floors compare."""
    sims = [_by_seed(c, "simulate") for c in (cache_a, cache_b)]
    floors = [_by_seed(c, "floor") for c in (cache_a, cache_b)]
    seeds = sorted(set(sims[0]) & set(sims[1]) & set(floors[0]) & set(floors[1]))
    if not seeds:
        raise ValueError(f"{cache_a} and {cache_b}: no bench seed in both")
    per_seed = {}
    for s in seeds:
        a, b = (sim[s] for sim in sims)
        if a["params"]["sim"] != b["params"]["sim"] or a["params"]["scale"] != b["params"]["scale"]:
            raise ValueError(f"seed {s}: the two benches were asked for different simulators "
                             f"or scales")
        layout = {k: v for k, v in a["result"].items() if k not in ("sha256", "seconds")}
        per_seed[str(s)] = {
            "sha256_equal": a["result"]["sha256"] == b["result"]["sha256"],
            "layout_equal": layout == {k: v for k, v in b["result"].items()
                                       if k not in ("sha256", "seconds")},
            "floor_largest_relative_difference": _largest_relative_difference(
                floors[0][s]["result"], floors[1][s]["result"], f"seed {s}")}
    first = sims[0][seeds[0]]["params"]
    return {"machines": [label_a, label_b], "simulator": first["sim"]["name"],
            "scale": first["scale"], "seeds": seeds, "per_seed": per_seed}


def summary(result: dict) -> str:
    """The ``bench-agreement`` block of ``docs/results.md``: one sentence."""
    per = result["per_seed"].values()
    a, b = result["machines"]
    largest = max(p["floor_largest_relative_difference"] for p in per)
    return (f"\nSimulator {result['simulator']}, scale {result['scale']:g}, seeds "
            f"{', '.join(map(str, result['seeds']))}, benches built on {a} and on {b}: "
            f"bit-identical files for {sum(p['sha256_equal'] for p in per)} of {len(per)} "
            f"seeds; the same trials, rows and minutes per split for "
            f"{sum(p['layout_equal'] for p in per)} of {len(per)}; the floor's errors computed "
            f"on each differ by at most {largest:.1e} of their value.\n")


def _cache(run: Path) -> Path:
    """The task cache of the ``reproduce`` run in folder ``run``."""
    return run / "work" / "cache"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a", type=Path, required=True, help="one reproduce run's folder")
    ap.add_argument("--b", type=Path, required=True, help="the other reproduce run's folder")
    ap.add_argument("--label-a", default="a")
    ap.add_argument("--label-b", default="b")
    ap.add_argument("--json", type=Path, required=True)
    args = ap.parse_args(argv)
    try:
        result = agreement(_cache(args.a), _cache(args.b), args.label_a, args.label_b)
        result["command"] = (f"python studies/bench_agreement.py --a {shown_path(args.a)} "
                             f"--label-a {args.label_a} --b {shown_path(args.b)} --label-b "
                             f"{args.label_b} --json {shown_path(args.json)}")
        write_json(args.json, result)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    except (KeyError, TypeError) as err:
        print(f"error: a cached task lacks what it should hold ({err!r}); is it a reproduce "
              f"cache?", file=sys.stderr)
        return 2
    print(summary(result).strip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
