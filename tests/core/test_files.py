"""psmforce.core.files: a file is replaced whole or left as it was, no temporary stays behind, and
nothing the user has is taken for a temporary, written through or replaced."""

import os

import pytest

from psmforce.core.files import (OutputError, atomic_path, check_output, staging_folder,
                                 write_bytes_atomic, write_text_atomic)


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


def test_temporary_names_are_hidden_unique_and_keep_the_suffix_when_asked(tmp_path):
    with atomic_path(tmp_path / "fig.png", keep_suffix=True) as tmp:
        assert tmp.name.startswith(".fig.png.") and tmp.name.endswith(".part.png")
        tmp.write_bytes(b"png")  # matplotlib picks the format by suffix
    with atomic_path(tmp_path / "task.json") as a, atomic_path(tmp_path / "task.json") as b:
        assert a != b and a.exists() and b.exists()   # two writers, two siblings
        a.write_text("{}")
        b.write_text("[]")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "task.json"]
    assert (tmp_path / "task.json").read_text() == "{}"   # the last complete write wins


# Issue 46, class 1: the user's files are never taken for a temporary, written through or replaced.

def test_a_file_named_like_the_old_temporary_survives_a_write(tmp_path):
    """``calibrate ck.pt.part --out ck.pt`` once deleted its input: the temporary was the fixed
    sibling ``NAME.part``."""
    theirs = tmp_path / "ck.pt.part"
    theirs.write_bytes(b"the user's checkpoint")
    write_bytes_atomic(tmp_path / "ck.pt", b"new")
    assert theirs.read_bytes() == b"the user's checkpoint"
    assert (tmp_path / "ck.pt").read_bytes() == b"new"


def test_a_link_planted_under_a_temporary_name_is_not_written_through(tmp_path):
    """A leftover link named as the temporary once was made a write land in the file it points to."""
    precious = tmp_path / "prior.json"
    precious.write_text("the user's prior")
    for name in ("out.json.part", ".out.json.part", f".out.json.{os.getpid()}.part"):
        (tmp_path / name).symlink_to(precious)
    write_text_atomic(tmp_path / "out.json", "result")
    assert precious.read_text() == "the user's prior"
    assert (tmp_path / "out.json").read_text() == "result"


@pytest.mark.parametrize("kind", ["symlink", "fifo", "folder"])
def test_a_target_that_is_not_a_regular_file_is_refused_and_left_as_it_was(tmp_path, kind):
    target, other = tmp_path / "out.json", tmp_path / "elsewhere.json"
    other.write_text("kept")
    if kind == "symlink":
        target.symlink_to(other)
    elif kind == "fifo":
        os.mkfifo(target)
    else:
        target.mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(OutputError, match=f"{target}: exists and is a "):
        write_text_atomic(target, "result")
    assert sorted(p.name for p in tmp_path.iterdir()) == before   # no temporary left either
    assert other.read_text() == "kept"
    assert {"symlink": target.is_symlink, "fifo": target.is_fifo, "folder": target.is_dir}[kind]()


def test_standard_output_as_a_device_is_refused():
    with pytest.raises(OutputError, match="character device"):
        check_output("/dev/null")


def test_a_staging_folder_is_new_and_goes_whatever_it_holds(tmp_path):
    (tmp_path / "run.mcap.part").mkdir()   # left by an earlier writer, or the user's: untouched
    with staging_folder(tmp_path / "run.mcap") as staging:
        assert staging.is_dir() and not any(staging.iterdir())
        (staging / "run.mcap").write_bytes(b"bag")
    assert not staging.exists() and (tmp_path / "run.mcap.part").is_dir()


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


# Issue 46, class 6: two commands, one output folder: the second is refused while the first writes.

def test_a_held_folder_refuses_a_second_holder_and_is_free_again_after(tmp_path):
    from psmforce.core.files import LOCK_NAME, folder_is_empty, locked_folder
    out = tmp_path / "out"
    with locked_folder(out):
        assert folder_is_empty(out) and (out / LOCK_NAME).exists()
        with pytest.raises(OutputError, match=f"{out}: another command is writing this folder"):
            with locked_folder(out):
                pass
        (out / "result.json").write_text("{}")
    assert sorted(p.name for p in out.iterdir()) == ["result.json"]   # the lock went with it
    with locked_folder(out):   # free again
        pass


def test_a_held_folder_made_for_nothing_is_not_left_behind(tmp_path):
    from psmforce.core.files import locked_folder
    with pytest.raises(RuntimeError):
        with locked_folder(tmp_path / "new"):
            raise RuntimeError("the command was refused")
    assert not (tmp_path / "new").exists()
    (tmp_path / "kept").mkdir()
    with locked_folder(tmp_path / "kept"):
        pass
    assert (tmp_path / "kept").is_dir()   # the user's folder, even empty, stays


def test_a_lock_held_by_another_process_refuses_simulate_and_writes_nothing(tmp_path):
    import subprocess
    import sys
    from psmforce.sim import simulate
    out = tmp_path / "sim"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom psmforce.core.files import locked_folder\n"
         f"with locked_folder({str(out)!r}):\n    print('held', flush=True)\n"
         "    sys.stdin.read()\n"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(OutputError, match="another command is writing this folder"):
            simulate("automated", scale=0.005, seed=1, out=out)
        assert [p.name for p in out.iterdir()] == [".psmforce.lock"]
    finally:
        holder.communicate("", timeout=30)
    assert not out.exists()   # the holder made it and wrote nothing: gone with its lock
    simulate("automated", scale=0.005, seed=1, out=out)
    assert (out / "metadata.json").is_file() and not (out / ".psmforce.lock").exists()


def test_an_output_has_the_permissions_a_plain_write_gives_or_those_it_replaces(tmp_path):
    """mkstemp creates the temporary sibling 0o600; renamed as it is, every output was hidden
    from the user's group (fuzz.json came out -rw-------)."""
    import os
    import stat
    mask = os.umask(0o027)
    try:
        with atomic_path(tmp_path / "new.json") as tmp:
            tmp.write_text("{}")
        assert stat.S_IMODE((tmp_path / "new.json").stat().st_mode) == 0o640
        (tmp_path / "kept.json").write_text("{}")
        os.chmod(tmp_path / "kept.json", 0o604)
        with atomic_path(tmp_path / "kept.json") as tmp:
            tmp.write_text("[]")
        assert stat.S_IMODE((tmp_path / "kept.json").stat().st_mode) == 0o604
    finally:
        os.umask(mask)
