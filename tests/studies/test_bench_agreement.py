"""studies/bench_agreement.py: two machines' task caches compared seed by seed, and a cache that
is not one refused in one line."""

import json

import pytest

from studies import bench_agreement


def _cache(folder, sha: dict, floor_rmse: dict, rows=1000):
    folder.mkdir(parents=True)
    sim = {"name": "2.3", "changes": {}}
    for seed in sha:
        (folder / f"simulate-{seed}.json").write_text(json.dumps({
            "task": "simulate@1", "params": {"seed": seed, "scale": 0.25, "sim": sim},
            "result": {"trials": 12, "rows": rows, "sha256": sha[seed], "seconds": 1.0}}))
        (folder / f"floor-{seed}.json").write_text(json.dumps({
            "task": "floor@1", "params": {"seed": seed},
            "result": {"automated": {"paper": {"Fx": {"rmse_n": floor_rmse[seed],
                                                      "nrmse_pct": 1.0}}}}}))
    return folder


def test_bit_identical_rounded_and_different_benches_are_told_apart(tmp_path):
    a = _cache(tmp_path / "a", {1: "x", 2: "y"}, {1: 0.1, 2: 0.2})
    b = _cache(tmp_path / "b", {1: "x", 2: "z", 3: "w"}, {1: 0.1, 2: 0.2 * (1 + 1e-15),
                                                            3: 0.3})
    result = bench_agreement.agreement(a, b, "cpu", "cuda")
    assert result["seeds"] == [1, 2]                      # seed 3 is in one cache only
    assert result["per_seed"]["1"] == {"sha256_equal": True, "layout_equal": True,
                                       "floor_largest_relative_difference": 0.0}
    assert result["per_seed"]["2"]["sha256_equal"] is False
    assert result["per_seed"]["2"]["floor_largest_relative_difference"] == pytest.approx(
        1e-15, rel=1e-3)
    text = bench_agreement.summary(result)
    assert "bit-identical files for 1 of 2 seeds" in text and "for 2 of 2" in text
    c = _cache(tmp_path / "c", {1: "x", 2: "y"}, {1: 0.1, 2: 0.2}, rows=999)
    assert bench_agreement.agreement(a, c, "a", "c")["per_seed"]["1"]["layout_equal"] is False


def test_a_folder_that_is_not_a_task_cache_is_refused_in_one_line(tmp_path, capsys):
    _cache(tmp_path / "a" / "work" / "cache", {1: "x"}, {1: 0.1})    # a reproduce run's folder
    a = tmp_path / "a"
    bad = tmp_path / "bad" / "work" / "cache"
    bad.mkdir(parents=True)
    (bad / "simulate-1.json").write_text('{"task": "train@1"}')
    out = tmp_path / "out.json"
    assert bench_agreement.main(["--a", str(a), "--b", str(tmp_path / "bad"), "--json",
                                 str(out)]) == 2
    err = capsys.readouterr().err
    assert "not a cached simulate task" in err and "Traceback" not in err
    assert not out.exists()
    empty = tmp_path / "empty"
    (empty / "work" / "cache").mkdir(parents=True)
    assert bench_agreement.main(["--a", str(a), "--b", str(empty), "--json", str(out)]) == 2
    assert "no bench seed in both" in capsys.readouterr().err and not out.exists()
