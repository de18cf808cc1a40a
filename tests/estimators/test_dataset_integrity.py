"""Datasets are read whole or refused (issue 14, item 2): an interrupted simulate, an empty or
malformed trials list, loose recordings without an explicit index."""

from __future__ import annotations

import json

import pytest

import psmforce.sim.dataset as sim_dataset
from psmforce.estimators.data.dataset import DatasetError, index_recordings, load_dataset
from psmforce.io.recording import write_recording
from psmforce.sim import simulate
from psmforce.cli.main import main


def _one_line(capsys, command: str) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"psmforce {command}: error: "), lines
    return lines[0]


def test_an_interrupted_simulate_leaves_nothing_train_or_evaluate_accept(tmp_path, capsys,
                                                                         monkeypatch):
    written = []

    def interrupted(frame, path):  # the user presses Ctrl-C after the fifth recording
        if len(written) == 5:
            raise KeyboardInterrupt
        write_recording(frame, path)
        written.append(path)

    monkeypatch.setattr(sim_dataset, "write_recording", interrupted)
    bench = tmp_path / "bench"
    with pytest.raises(KeyboardInterrupt):
        simulate("automated", scale=0.01, seed=0, out=bench)
    assert len(list(bench.rglob("*.csv"))) == 5  # half a dataset on disk ...
    with pytest.raises(DatasetError, match="no metadata.json"):
        load_dataset(bench)  # ... that no reader takes
    ckpt = tmp_path / "fcn.pt"
    assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "1",
                 "--out", str(ckpt)]) == 2
    assert str(bench) in _one_line(capsys, "train") and not ckpt.exists()


@pytest.mark.parametrize("metadata, reason", [
    ({"trials": []}, "non-empty 'trials' list"),
    ({"seed": 1}, "non-empty 'trials' list"),
    ([{"path": "train/Free/t0.csv"}], "non-empty 'trials' list"),
    ({"trials": [{"condition": "Free", "split": "train"}]}, "trial entry 0 needs"),
    ({"trials": [{"path": "../t0.csv", "condition": "Free", "split": "train"}]}, "inside"),
    # issue 46, class 5: a trial listed twice trained at double weight; unknown names passed
    ({"trials": [{"path": "train/Free/t0.csv", "condition": "Free", "split": "train"}] * 2},
     "recording train/Free/t0.csv is listed 2 times"),
    ({"trials": [{"path": "train/Free/t0.csv", "condition": "Freee", "split": "train"}]},
     "unknown condition 'Freee'"),
    ({"trials": [{"path": "train/Free/t0.csv", "condition": "Free", "split": "tarin"}]},
     "unknown split 'tarin'"),
])
def test_malformed_metadata_is_refused_naming_the_file(tmp_path, metadata, reason):
    (tmp_path / "train" / "Free").mkdir(parents=True)
    (tmp_path / "metadata.json").write_text(json.dumps(metadata))
    with pytest.raises(DatasetError, match=reason) as err:
        load_dataset(tmp_path)
    assert str(tmp_path / "metadata.json") in str(err.value)


@pytest.mark.slow
def test_index_makes_loose_recordings_a_dataset_explicitly(tmp_path, capsys):
    bench = tmp_path / "bench"
    simulate("automated", scale=0.01, seed=0, out=bench)
    simulated = {(t.path, t.condition, t.split) for t in load_dataset(bench).trials}
    (bench / "metadata.json").unlink()  # now a folder of loose recordings, as a lab has them
    assert main(["index", str(bench)]) == 0
    assert f"{len(simulated)} recordings" in capsys.readouterr().out
    assert {(t.path, t.condition, t.split) for t in load_dataset(bench).trials} == simulated
    assert main(["index", str(bench)]) == 2  # never overwrites a dataset's metadata
    assert "already a dataset" in _one_line(capsys, "index")
    assert main(["index", str(tmp_path / "nothing")]) == 2
    assert "no such recording file or folder" in _one_line(capsys, "index")
    with pytest.raises(DatasetError, match="not one file"):
        index_recordings(next(bench.rglob("*.csv")))


def test_a_header_naming_a_column_twice_is_refused_not_renamed(tmp_path):
    """Issue 46, class 5: the CSV reader renamed the second ``fx`` to ``fx.1`` and the
    first copy, bogus, was trained on."""
    from psmforce.io.recording import HEX10, RecordingError, read_recording
    out = tmp_path / "bench"
    simulate("automated", scale=0.005, seed=0, out=out)
    path = next((out / "train" / "Free").glob("*.csv"))
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    lines[0] = ",".join(header + [HEX10[0]])
    path.write_text("\n".join(line if k == 0 else line + ",0" for k, line in enumerate(lines))
                    + "\n")
    with pytest.raises(RecordingError, match=f"column '{HEX10[0]}' appears more than once"):
        read_recording(path)
    with pytest.raises(RecordingError, match=str(path)):
        load_dataset(out)


def test_a_target_beyond_what_the_shaft_carries_is_refused(tmp_path):
    """Issue 46, class 5: an ATI target in the wrong unit trained without a word."""
    from psmforce.estimators.data.bounds import MAX_FORCE_N
    from psmforce.io.recording import read_recording
    out = tmp_path / "bench"
    simulate("automated", scale=0.005, seed=0, out=out)
    path = next((out / "train" / "Traction").glob("*.csv"))
    frame = read_recording(path)
    frame["ati_fz"] = frame["ati_fz"] * 1000.0 + 10 * MAX_FORCE_N  # mN, and then some
    write_recording(frame, path)
    with pytest.raises(DatasetError, match=f"{path}: target ati_fz = .* beyond the"):
        load_dataset(out, require_targets=True)
