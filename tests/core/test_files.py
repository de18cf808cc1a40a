"""psmforce.core.files: a file is replaced whole or left as it was, and no temporary stays behind."""

import os

import pytest

from psmforce.core.files import atomic_path, write_bytes_atomic, write_text_atomic


def test_a_failed_write_leaves_the_previous_file_and_no_part(tmp_path):
    target = tmp_path / "report.json"
    write_text_atomic(target, "old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half of the new")
            raise RuntimeError("interrupted")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


def test_a_complete_write_replaces_the_file(tmp_path):
    target = tmp_path / "model.onnx"
    write_bytes_atomic(target, b"\x00\x01")
    write_bytes_atomic(target, b"\x02")
    assert target.read_bytes() == b"\x02" and len(list(tmp_path.iterdir())) == 1


def test_temporary_names(tmp_path):
    with atomic_path(tmp_path / "fig.png", keep_suffix=True) as tmp:
        assert tmp.name == "fig.part.png"  # matplotlib picks the format by suffix
        tmp.write_bytes(b"png")
    with atomic_path(tmp_path / "task.json", per_process=True) as tmp:
        assert tmp.name == f".task.json.{os.getpid()}.part"
        tmp.write_text("{}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "task.json"]


def test_folder_digest_sees_every_byte_and_name_not_the_location(tmp_path):
    from psmforce.core.files import folder_sha256
    for name in ("a", "b"):
        (tmp_path / name / "train").mkdir(parents=True)
        (tmp_path / name / "metadata.json").write_text("{}")
        (tmp_path / name / "train" / "t.csv").write_text("fx\n0.1\n")
    assert folder_sha256(tmp_path / "a") == folder_sha256(tmp_path / "b")
    (tmp_path / "b" / "train" / "t.csv").write_text("fx\n0.1000001\n")
    assert folder_sha256(tmp_path / "a") != folder_sha256(tmp_path / "b")
    (tmp_path / "b" / "train" / "t.csv").write_text("fx\n0.1\n")
    (tmp_path / "b" / "train" / "t.csv").rename(tmp_path / "b" / "train" / "u.csv")
    assert folder_sha256(tmp_path / "a") != folder_sha256(tmp_path / "b")   # same bytes, renamed
