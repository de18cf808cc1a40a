"""studies/recipe_swap.py: finished cells kept in its JSON survive a fresh work folder, a cell
finished again replaces its copy, a cell read back is checked, and only cells on one bench
(scale, seeds, simulator version) are paired."""

import json

import pytest

from psmforce.experiments.seeds import RECIPE_SWAP_SEEDS
from psmforce.sim.versions import DEFAULT_VERSION
from reports.results_page import recipe_swap_tables
from studies import recipe_swap as study

SEEDS = list(RECIPE_SWAP_SEEDS)
SIM = DEFAULT_VERSION


def _cell(cell: str, fx: float, sim: str = SIM, scale: float = 0.05) -> dict:
    errors = [{"Fx": fx * (1 + 0.01 * k), "Fy": 2.0, "Fz": 3.0} for k in range(len(SEEDS))]
    return {"cell": cell, "model": cell.split(":")[0], "label": cell, "regime": cell.split(":")[1],
            "scale": scale, "seeds": SEEDS, "simulator_versions": [sim],
            "per_seed": {"causal": errors, "paper": errors},
            "converged": [True] * len(SEEDS), "stopped": ["3 epochs, patience"] * len(SEEDS)}


def test_cells_the_json_holds_are_kept_and_not_run_again(tmp_path, monkeypatch):
    out = tmp_path / "swap.json"
    first = tmp_path / "first"
    study.write_json(study.cell_path(first, SIM, "fcn:paper"), _cell("fcn:paper", 2.0))
    study.assemble(first, out)
    fresh = tmp_path / "fresh"   # another machine: only the JSON
    study.write_json(study.cell_path(fresh, SIM, "fcn:dense"), _cell("fcn:dense", 1.5))
    figures = study.assemble(fresh, out)
    assert list(figures["cells"]) == ["fcn:paper", "fcn:dense"]
    assert figures["comparisons"]["fcn: dense over paper"]["causal"]["Fx"]["verdict"] == "ahead"
    study.write_json(study.cell_path(fresh, SIM, "fcn:paper"), _cell("fcn:paper", 1.0))
    assert study.assemble(fresh, out)["cells"]["fcn:paper"]["per_seed"]["causal"][0]["Fx"] == 1.0
    ran = []
    monkeypatch.setattr(study, "run_cell",
                        lambda work, sim, scale, seeds, cell, *a: ran.append(cell))
    assert study.main(["--scale", "0.05", "--cells", "fcn:paper", "fcn:dense", "--work",
                       str(tmp_path / "third"), "--json", str(out)]) == 0
    assert ran == []                                     # both finished, in the JSON
    assert study.main(["--scale", "0.05", "--cells", "fcn:paper", "hybrid:paper", "--work",
                       str(tmp_path / "third"), "--json", str(out)]) == 0
    assert ran == ["hybrid:paper"]


def test_a_cell_read_back_is_checked_and_named(tmp_path, capsys):
    out = tmp_path / "swap.json"
    bad = _cell("fcn:paper", 2.0)
    del bad["per_seed"]
    out.write_text(json.dumps({"cells": {"fcn:paper": bad}}))
    with pytest.raises(ValueError, match=r"swap.json: cell fcn:paper: lacks per_seed"):
        study.assemble(tmp_path / "w", out)
    out.write_text('{"cells": ')
    assert study.main(["--render-only", "--work", str(tmp_path / "w"), "--json", str(out)]) == 2
    assert "swap.json: not JSON" in capsys.readouterr().err
    assert out.read_text() == '{"cells": '              # left as it was


def test_only_cells_on_one_bench_are_paired(tmp_path):
    out, work = tmp_path / "swap.json", tmp_path / "w"
    study.write_json(study.cell_path(work, SIM, "fcn:paper"), _cell("fcn:paper", 2.0))
    study.write_json(study.cell_path(work, SIM, "fcn:dense"), _cell("fcn:dense", 1.5, scale=0.1))
    figures = study.assemble(work, out)
    assert figures["comparisons"] == {}                  # scale 0.1 against scale 0.05
    assert figures["other_bench"] == ["fcn:dense"]
    assert "not paired with it: fcn:dense." in recipe_swap_tables(figures)
    study.write_json(study.cell_path(work, SIM, "fcn:dense"), _cell("fcn:dense", 1.5))
    figures = study.assemble(work, out)
    assert list(figures["comparisons"]) == ["fcn: dense over paper"]
    assert figures["other_bench"] == []
    assert "not paired" not in recipe_swap_tables(figures)


def test_a_json_of_another_simulator_version_is_refused_and_left_as_it_is(tmp_path, capsys,
                                                                         monkeypatch):
    out, work = tmp_path / "swap.json", tmp_path / "w"
    study.write_json(study.cell_path(work, SIM, "fcn:paper"), _cell("fcn:paper", 2.0))
    study.assemble(work, out)
    before = out.read_text()
    other = next(v for v in study.VERSIONS if v != SIM)
    ran = []
    monkeypatch.setattr(study, "run_cell", lambda *a: ran.append(a))
    assert study.main(["--version", other, "--work", str(work), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"holds cells on simulator {SIM}, not {other}" in err and "another --json" in err
    assert ran == [] and out.read_text() == before
    fresh = tmp_path / "other.json"                      # its own JSON: the cell runs there
    assert study.main(["--version", other, "--cells", "fcn:paper", "--work", str(work),
                       "--json", str(fresh)]) == 0
    assert [a[1] for a in ran] == [other]
    assert study.read_json(fresh, "x")["command"].startswith(
        f"python studies/recipe_swap.py --version {other} ")


def test_a_work_folder_of_the_layout_before_versions_is_named_not_run_again(tmp_path, capsys):
    (tmp_path / "w" / "scale_0.05").mkdir(parents=True)
    with pytest.raises(SystemExit):
        study.main(["--work", str(tmp_path / "w"), "--json", str(tmp_path / "swap.json")])
    assert f"move it, and {tmp_path / 'w' / 'cells'} with it, into " \
           f"{tmp_path / 'w' / SIM}/" in capsys.readouterr().err
    assert not (tmp_path / "swap.json").exists()
