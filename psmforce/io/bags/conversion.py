"""``convert_bag``: one dVRK bag -> one recording CSV, plus a report of what was found.

Reading rules (topics, types, joint names, time stamps): :mod:`psmforce.io.bags.reading`.
Synchronisation rules (sorting, duplicates, gaps, linear interpolation): :mod:`.resampling`.

Rows inside a gap of any stream are DROPPED by default (``on_gap="drop"``): the file then holds only
measured-and-interpolated data, and ``time`` jumps over the gap (so anything that windows the
recording must split where ``diff(time)`` exceeds one period). ``on_gap="flag"`` keeps those rows,
interpolated across the gap, and adds a column ``in_gap`` (1 inside a gap, else 0).

Ground truth: ``ati_raw_*`` are the ATI topic's force and moment as published, in the ATI frame. The
targets ``ati_fx, ati_fy, ati_fz`` (external force ON THE TOOL in the HEX10 frame, paper eq. 4) are
:func:`psmforce.robot.frames.ati_force_in_hex10` of the resampled ATI force and joint positions. It
needs the ATI's mounting rotation ``r_ati_psm`` (R_ati_PSM, 3x3: the PSM base axes expressed in the
ATI frame; a calibration input) and ``ati_sign``: -1 (default, as the simulator) when the topic
carries the sensor's own reading, i.e. the force the tool applies on the ATI; +1 when it already
carries the force on the tool. Giving ``r_ati_psm`` makes the ATI stream required; without it the
targets are left out and the report says so.
"""

from __future__ import annotations

import math
import numbers
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.io.bags.reading import STREAMS, BagError, read_streams, resolve_topics
from psmforce.io.bags.resampling import clean, gap_threshold_s, output_clock, resample
from psmforce.robot.frames import ati_force_in_hex10
from psmforce.robot.kinematics import PSM, KinematicsInputError
from psmforce.io.recording import (ATI_RAW, JOINT_POSITIONS, MAX_RATE_HZ, TARGETS, TIME,
                                   write_recording)

GAP_COLUMN = "in_gap"


def convert_bag(bag_path: str | Path, out_csv: str | Path, *, rate_hz: float = 100.0,
                arm: str = "PSM1", topics: dict[str, str | None] | None = None,
                r_ati_psm: np.ndarray | None = None, ati_sign: float = -1.0,
                psm: PSM | None = None, gap_periods: float = 3.0, on_gap: str = "drop") -> dict:
    """Convert a ROS 2 (sqlite3 or MCAP) or ROS 1 bag of the dVRK bench to a recording CSV.

    ``bag_path``: a ROS 2 bag folder (with metadata.yaml), a ``.mcap`` / ``.db3`` file, or a ROS 1
    ``.bag`` file. ``out_csv``: the recording to write (atomically; nothing is written on error).
    ``rate_hz``: output clock. ``arm``: namespace of the default topics. ``topics``: overrides per
    stream (``js``, ``jaw``, ``hex10``, ``ati``, ``jacobian``; ``None`` switches ``ati`` or
    ``jacobian`` off). ``r_ati_psm``, ``ati_sign``: ATI calibration for the targets (module
    docstring); ``psm``: the PSM model for eq. 4 (default ``PSM()``). ``gap_periods``: gap
    threshold in periods (:mod:`.resampling`). ``on_gap``: ``"drop"`` or ``"flag"`` (above).

    Returns the report (JSON-serialisable dict; :func:`summary_line` condenses it). Raises
    :class:`~psmforce.io.bags.BagError` (a ``ValueError``) naming the bag and the problem.
    """
    bag_path, out_csv = Path(bag_path), Path(out_csv)
    rate_hz = _check_options(bag_path, out_csv, rate_hz, gap_periods, on_gap)
    _check_ati_calibration(r_ati_psm, ati_sign, psm)
    topic_of, required = resolve_topics(arm, topics)
    if r_ati_psm is not None:
        if "ati" not in topic_of:
            raise BagError("r_ati_psm is given but the ati stream is switched off")
        required.add("ati")
    raw, skipped, kind = read_streams(bag_path, topic_of, required)
    streams = {name: clean(raw[name], str(bag_path)) for name in STREAMS if name in raw}
    start_ns, times = output_clock(list(streams.values()), rate_hz, str(bag_path))

    columns: dict[str, np.ndarray] = {TIME: times}
    in_gap = np.zeros(len(times), dtype=bool)
    stream_reports: dict[str, dict] = {}
    for name, stream in streams.items():
        threshold = gap_threshold_s(stream, rate_hz, gap_periods)
        values, inside, gaps = resample(stream, start_ns, times, threshold)
        columns.update(zip(stream.raw.columns, values.T))
        in_gap |= inside
        stream_reports[name] = _stream_report(stream, start_ns, threshold, gaps, int(inside.sum()))
    for name, reason in skipped.items():
        stream_reports[name] = {"topic": topic_of[name], "skipped": reason}
    for name in STREAMS:
        stream_reports.setdefault(name, {"topic": None, "skipped": "switched off"})

    targets_note = _add_targets(columns, r_ati_psm, ati_sign, psm)
    frame = pd.DataFrame(columns)
    if on_gap == "drop":
        frame = frame.loc[~in_gap].reset_index(drop=True)
        if frame.empty:
            raise BagError(f"{bag_path}: every output sample lies inside a gap; nothing to write")
    else:
        frame[GAP_COLUMN] = in_gap.astype(np.int8)
    write_recording(frame, out_csv)
    return {
        "bag": str(bag_path), "bag_kind": kind, "out": str(out_csv), "rate_hz": rate_hz,
        "rows": len(frame), "start_time_s": start_ns / 1e9,
        "duration_s": float(times[-1]), "on_gap": on_gap, "gap_periods": gap_periods,
        "rows_in_gaps": int(in_gap.sum()), "targets": targets_note, "streams": stream_reports,
    }


def summary_line(report: dict) -> str:
    """One line for humans: rows, clock, messages per stream, gaps and timing anomalies."""
    streams = {n: s for n, s in report["streams"].items() if "skipped" not in s}
    messages = ", ".join(f"{n} {s['messages']}" for n, s in streams.items())
    gaps = sum(len(s["gaps"]) for s in streams.values())
    out_of_order = sum(s["out_of_order"] for s in streams.values())
    duplicates = sum(s["duplicates"] for s in streams.values())
    bag_time = [n for n, s in streams.items() if s["time_source"] == "bag"]
    action = "dropped" if report["on_gap"] == "drop" else "flagged"
    gap_text = f"{gaps} gap(s), {report['rows_in_gaps']} row(s) {action}" if gaps else "no gaps"
    clock = "bag time for " + ", ".join(bag_time) if bag_time else "header stamps"
    skipped = [n for n, s in report["streams"].items() if "skipped" in s]
    return (f"{report['bag']} -> {report['out']}: {report['rows']} rows at "
            f"{report['rate_hz']:g} Hz over {report['duration_s']:.2f} s; messages: {messages}; "
            f"{gap_text}; {out_of_order} out-of-order, {duplicates} duplicate stamp(s); "
            f"time: {clock}{'; skipped: ' + ', '.join(skipped) if skipped else ''}; "
            f"targets: {report['targets']}")


def _check_options(bag_path: Path, out_csv: Path, rate_hz: float, gap_periods: float,
                   on_gap: str) -> float:
    if not bag_path.exists():
        raise BagError(f"{bag_path}: no such file or folder")
    if out_csv.is_dir():
        raise BagError(f"{out_csv}: is a folder; give the CSV file to write")
    if not out_csv.parent.is_dir():
        raise BagError(f"{out_csv}: the output folder {out_csv.parent} does not exist")
    if out_csv.resolve() == bag_path.resolve():
        raise BagError(f"{out_csv}: the output would overwrite the bag")
    if not (isinstance(rate_hz, numbers.Real) and math.isfinite(rate_hz)
            and 0 < rate_hz <= MAX_RATE_HZ):
        raise BagError(f"rate_hz must be in (0, {MAX_RATE_HZ:g}] Hz, got {rate_hz!r}")
    if not (isinstance(gap_periods, numbers.Real) and math.isfinite(gap_periods)
            and gap_periods >= 1):
        raise BagError(f"gap_periods must be a finite number >= 1, got {gap_periods!r}")
    if on_gap not in ("drop", "flag"):
        raise BagError(f"on_gap must be 'drop' or 'flag', got {on_gap!r}")
    return float(rate_hz)


def _check_ati_calibration(r_ati_psm, ati_sign: float, psm: PSM | None) -> None:
    """Fail before reading the bag: apply the calibration once to a zero force at q = 0."""
    if r_ati_psm is None:
        return
    try:
        ati_force_in_hex10(np.zeros(3), np.zeros(6), r_ati_psm, psm, sign=ati_sign)
    except KinematicsInputError as err:
        raise BagError(f"ATI calibration: {err}") from None


def _stream_report(stream, start_ns: int, threshold_s: float, gaps, rows_in_gaps: int) -> dict:
    raw = stream.raw
    return {
        "topic": raw.topic, "msgtype": raw.msgtype, "messages": len(raw.stamps_ns),
        "time_source": raw.time_source, "zero_header_stamps": raw.zero_header_stamps,
        "nominal_period_s": stream.nominal_period_s,
        "span_s": [(int(stream.stamps_ns[0]) - start_ns) / 1e9,
                   (int(stream.stamps_ns[-1]) - start_ns) / 1e9],
        "out_of_order": stream.out_of_order, "duplicates": stream.duplicates,
        "dropped_estimate": stream.dropped_estimate, "gap_threshold_s": threshold_s,
        "gaps": [{"start_s": a, "end_s": b, "duration_s": b - a} for a, b in gaps],
        "rows_in_gaps": rows_in_gaps,
    }


def _add_targets(columns: dict[str, np.ndarray], r_ati_psm, ati_sign: float,
                 psm: PSM | None) -> str:
    if ATI_RAW[0] not in columns:
        return "none (no ATI stream)"
    if r_ati_psm is None:
        return "none (r_ati_psm not given; ati_raw_* written)"
    q = np.column_stack([columns[c] for c in JOINT_POSITIONS[:6]])
    force = np.column_stack([columns[c] for c in ATI_RAW[:3]])
    targets = ati_force_in_hex10(force, q, r_ati_psm, psm, sign=ati_sign)
    columns.update(zip(TARGETS, targets.T))
    return f"ati_fx, ati_fy, ati_fz by paper eq. 4 (ati_sign {ati_sign:+g})"
