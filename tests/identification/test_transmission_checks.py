"""Data checks on transmission recordings: each check flags what it names on a synthetic file,
passes a clean one, and a session leaves a flagged file out and names it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from psmforce.identification.transmission import checks
from psmforce.identification.transmission.recording import (TransmissionDataError,
                                                            TransmissionDataWarning,
                                                            check_session, read_transmission_file,
                                                            read_transmission_session)

MRDLAB = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "mrdlab"


def _clean(n: int = 4000, amplitude: float = 0.1) -> np.ndarray:
    """(n, 10) raw columns of a plausible file: a 0.5 Hz drive, a current that follows the
    command, noisy torques."""
    rng = np.random.default_rng(0)
    t = np.arange(n) / 1000.0
    motor = np.round(20000 * np.sin(2 * np.pi * 0.5 * t))
    command = amplitude * np.sin(2 * np.pi * 0.5 * t + 0.3)
    raw = np.zeros((n, 10))
    raw[:, 0] = t
    raw[:, 1] = np.round(-motor * 8192 / (4196 * 35))
    raw[:, 2] = np.round(300 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0, 3, n))
    raw[:, 3] = checks.CURRENT_PER_COMMAND_A * command + rng.normal(0, 0.002, n)
    raw[:, 4] = np.round(motor * 4000 / (4196 * 35) * 0.93)
    raw[:, 5] = np.round(-1500 + 500 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0, 3, n))
    raw[:, 7] = -command
    raw[:, 8] = motor
    return raw


def _kinds(raw) -> set[str]:
    return {f.check for f in checks.check_columns(raw)}


def test_a_clean_file_passes_every_check():
    assert checks.check_columns(_clean()) == []


@pytest.mark.parametrize("spoil, expected", [
    (lambda r: r.__setitem__((slice(1000, 1010), 7), -1.06), "drive_saturation"),
    (lambda r: r.__setitem__((slice(1000, 1010), 3), 2.5), "current_beyond_drive"),
    (lambda r: r.__setitem__((slice(2000, None), 8), r[2000:, 8] + np.arange(2000) * 450),
     "motor_overspeed"),
    (lambda r: r.__setitem__((slice(2000, None), 4), r[2000:, 4] + 40), "encoder_jump"),
    (lambda r: r.__setitem__((slice(500, 540), 5), r[:, 5].max() + 100), "torque_saturation"),
    (lambda r: r.__setitem__((slice(500, 501), 2), 32767), "torque_saturation"),
])
def test_each_check_flags_what_it_names(spoil, expected):
    raw = _clean()
    spoil(raw)
    assert expected in _kinds(raw)


def test_a_current_excursion_is_flagged_against_its_session():
    ranges = {f"s/{k}": 0.3 + 0.01 * k for k in range(6)}
    assert checks.session_findings(ranges) == {}
    ranges["s/07"] = 1.08
    found = checks.session_findings(ranges)
    assert list(found) == ["s/07"] and found["s/07"][0].check == "current_excursion"


def _write(folder: Path, name: str, raw: np.ndarray) -> Path:
    folder.mkdir(exist_ok=True)
    path = folder / name
    np.savetxt(path, raw, delimiter=",", fmt="%.6f", header="header line", comments="%")
    return path


def test_a_session_leaves_a_flagged_file_out_and_names_it(tmp_path):
    folder = tmp_path / "session"
    for name in ("000.TXT", "001.TXT", "002.TXT"):
        _write(folder, name, _clean())
    spoiled = _clean()
    spoiled[1000:1010, 7] = -1.06
    _write(folder, "013.TXT", spoiled)
    with pytest.warns(TransmissionDataWarning, match="session/013.*drive_saturation"):
        recs = read_transmission_session(folder)
    assert [r.name for r in recs] == ["session/000", "session/001", "session/002"]
    assert recs[0].stop_index == 0 and recs[0].frequency_index == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kept = read_transmission_session(folder, keep_flagged=True)
    assert len(kept) == 4 and kept[-1].findings[0].check == "drive_saturation"
    assert [r.name for r in check_session(folder) if r.findings] == ["session/013"]


def test_a_session_of_flagged_files_is_refused(tmp_path):
    spoiled = _clean()
    spoiled[100:110, 3] = 3.0
    for name in ("00.TXT", "01.TXT"):
        _write(tmp_path / "bad", name, spoiled)
    with pytest.raises(TransmissionDataError, match="every file fails a data check"):
        read_transmission_session(tmp_path / "bad")


def test_the_reader_drops_the_start_up_transient(tmp_path):
    raw = _clean()
    raw[:20, 5] = 0.0            # the acquisition's start-up: far from the level
    rec = read_transmission_file(_write(tmp_path / "s", "10.TXT", raw))
    assert rec.jaw_torque_nm[0] < -1000 * 0.000039811 and rec.frequency_index == 1
    assert rec.stop_index is None


@pytest.mark.skipif(not MRDLAB.is_dir(), reason="../shared/data/mrdlab is absent")
def test_the_real_runaway_file_is_flagged_and_the_rest_pass():
    recs = check_session(MRDLAB / "Tool_4_Maryland_L_4")
    flagged = {r.name.rsplit("/", 1)[1]: {f.check for f in r.findings} for r in recs if r.findings}
    assert flagged == {"07": {"drive_saturation", "motor_overspeed", "current_excursion"}}
