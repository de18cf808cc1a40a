"""Writing a recording as a ROS 2 bag (MCAP) on the dVRK CRTK topics: the inverse of
:mod:`.reading`, for the simulated bench (``psmforce simulate --format mcap``); and joint
setpoints on the CRTK servo topics (:func:`write_setpoint_bag`, ``psmforce excitation``).

What goes into the bag is what :mod:`.reading` reads, by the same definitions: topic names from
:func:`~psmforce.io.bags.reading.default_topics`, message types and columns from
:mod:`.reading` (:func:`~psmforce.io.bags.reading.stream_columns`), ROS 2 Humble message
definitions stored in the bag.

* ``js``: sensor_msgs/JointState on ``/{arm}/measured_js``, the six chain joints under the
  dVRK >= 2024 names, dVRK order; ``jaw``: sensor_msgs/JointState on ``/{arm}/jaw/measured_js``,
  one joint named ``jaw``. Position, velocity, effort as in the recording (SI, dVRK joint space).
* ``hex10``: geometry_msgs/WrenchStamped on ``/hex10/measured_cf`` (``fx .. tz``, HEX10 frame,
  ``frame_id`` ``hex10``); ``ati``: the same on ``/ati/measured_cf`` (``ati_raw_fx .. _tz``: the
  Nano17's own reading in its own frame, ``frame_id`` ``ati``), written when the recording has
  those columns. The targets ``ati_f*`` are not published: ``convert --r-ati-psm`` derives them.
* Not written: the spatial Jacobian (optional for ``convert``; the estimators do not read it), the
  ``hex10_overload`` flag and the ``sim_*`` truth columns (no dVRK topic carries them).

Time. Every message's header stamp is ``start_ns`` plus the sample's ``time``: the bench samples
all channels on one clock, so every stream carries the recording's own sample instants and
``convert`` at the recording's rate lands on them (the converted CSV equals the simulator's CSV
to its 7 significant digits). Each message is logged (bag receive time) later than its stamp by
its stream's transport latency (:data:`RECEIVE_LATENCY_NS`), and messages are written in receive
order, interleaved as a recorder running on the bench would store them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from rosbags.rosbag2 import StoragePlugin, Writer

from psmforce.core.files import staging_folder
from psmforce.io.bags.messages import (JOINT_STATE, ROS2_TYPESTORE, WRENCH, WRENCH_STAMPED,
                                     stream_columns)
from psmforce.io.bags.reading import BagError, resolve_topics
from psmforce.robot.conventions import CHAIN_JOINTS, JAW_JOINT
from psmforce.io.recording import ATI_RAW, TIME

RECEIVE_LATENCY_NS = {"js": 400_000, "jaw": 400_000, "hex10": 900_000, "ati": 1_300_000}
"""Bag receive time minus header stamp per stream, ns (illustrative transport latencies; the
converter reads header stamps, so they only set the order messages are stored in)."""

FRAME_IDS = {"js": "", "jaw": "", "hex10": "hex10", "ati": "ati"}
"""``header.frame_id`` per stream: the wrenches are expressed in their sensor's own frame."""

_TYPES = {"js": JOINT_STATE, "jaw": JOINT_STATE, "hex10": WRENCH_STAMPED, "ati": WRENCH_STAMPED}


def bag_streams(frame: pd.DataFrame) -> tuple[str, ...]:
    """The streams :func:`write_bag` writes for ``frame``: js, jaw, hex10, and ati when the
    recording holds the ATI's raw reading."""
    return ("js", "jaw", "hex10") + (("ati",) if set(ATI_RAW) <= set(frame.columns) else ())


def write_bag(frame: pd.DataFrame, path: str | Path, *, start_ns: int,
              arm: str = "PSM1") -> dict[str, str]:
    """Write one recording as a ROS 2 MCAP bag folder ``path`` (``path/metadata.yaml`` and
    ``path/{path.name}.mcap``), streams and time stamps as in the module docstring.

    ``frame``: a recording (:mod:`psmforce.io.recording` columns; ``time`` strictly increasing,
    seconds). ``start_ns``: the absolute time stamp (ns since the epoch) of ``time`` = 0.
    ``arm``: namespace of the arm topics. Written into a new staging folder beside ``path``
    (:func:`psmforce.core.files.staging_folder`) and renamed into place: ``path`` exists only
    when complete. Returns the topic of each stream written.
    Raises :class:`~psmforce.io.bags.BagError` naming ``path`` (nothing written).
    """
    path = Path(path)
    _check_target(path, start_ns)
    streams = bag_streams(frame)
    needed = (TIME,) + tuple(c for s in streams for c in stream_columns(s))
    missing = [c for c in needed if c not in frame.columns]
    if missing:
        raise BagError(f"{path}: the recording lacks columns {missing}")
    stamps = int(start_ns) + np.rint(frame[TIME].to_numpy(dtype=float) * 1e9).astype(np.int64)
    if len(stamps) < 2 or np.any(np.diff(stamps) <= 0):
        raise BagError(f"{path}: time must hold at least two strictly increasing samples "
                       f"(ns resolution)")
    topics = {s: t for s, t in resolve_topics(arm, None)[0].items() if s in streams}
    _write_mcap(path, [(topics[s], _TYPES[s], stamps + RECEIVE_LATENCY_NS[s],
                        _serialize(s, frame, stamps)) for s in streams])
    return topics


def _check_target(path: Path, start_ns) -> None:
    if os.path.lexists(path):  # a link too, dangling or not: never replaced
        raise BagError(f"{path}: exists already; a bag is written only into a new folder")
    if not path.parent.is_dir():
        raise BagError(f"{path}: the output folder {path.parent} does not exist")
    if isinstance(start_ns, bool) or not isinstance(start_ns, (int, np.integer)) or start_ns <= 0:
        raise BagError(f"{path}: start_ns must be a positive integer (ns since the epoch), "
                       f"got {start_ns!r}")


def _write_mcap(path: Path, streams: list[tuple[str, str, np.ndarray, list[bytes]]]) -> None:
    """Write ``streams`` (topic, message type, log times ns, CDR payloads) into a staging
    folder, messages in receive order (every stream's log times merged, stable: earlier
    streams first at equal times), and rename it onto ``path``."""
    log_ns = np.concatenate([s[2] for s in streams])
    which = np.concatenate([np.full(len(s[2]), k) for k, s in enumerate(streams)])
    row = np.concatenate([np.arange(len(s[2])) for s in streams])
    order = np.argsort(log_ns, kind="stable")
    with staging_folder(path) as staging:
        with Writer(staging / path.name, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            connections = [writer.add_connection(topic, msgtype, typestore=ROS2_TYPESTORE)
                           for topic, msgtype, _, _ in streams]
            for k in order:
                writer.write(connections[which[k]], int(log_ns[k]), streams[which[k]][3][row[k]])
        if os.path.lexists(path):  # appeared while the bag was written: not replaced
            raise BagError(f"{path}: appeared while the bag was written; left as it is")
        (staging / path.name).rename(path)


def setpoint_topics(arm: str = "PSM1") -> dict[str, str]:
    """The dVRK 2.x (CRTK) servo topics a joint setpoint goes to: the six chain joints on
    ``/{arm}/servo_jp``, the jaw on ``/{arm}/jaw/servo_jp`` (sensor_msgs/JointState)."""
    return {"js": f"/{arm}/servo_jp", "jaw": f"/{arm}/jaw/servo_jp"}


def write_setpoint_bag(q: np.ndarray, dt: float, path: str | Path, *, start_ns: int,
                       arm: str = "PSM1") -> dict[str, str]:
    """Joint setpoints ``q`` (N, 7; dVRK order, rad and m) every ``dt`` s as a ROS 2 MCAP bag
    folder ``path`` on :func:`setpoint_topics`: sensor_msgs/JointState with positions only
    (velocity and effort empty, as CRTK's servo_jp takes them), header stamps ``start_ns`` +
    k dt, logged at their stamps; written whole or not at all (:func:`write_bag`'s rules).
    Returns the topic of each stream."""
    path = Path(path)
    _check_target(path, start_ns)
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 7 or len(q) < 2 or not np.isfinite(q).all() or not dt > 0:
        raise BagError(f"{path}: setpoints must be finite (N >= 2, 7) with dt > 0")
    try:
        from psmforce.io.bags.names import check_namespace
        topics = setpoint_topics(check_namespace(arm))
    except ValueError as err:
        raise BagError(str(err)) from None
    stamps = int(start_ns) + np.rint(np.arange(len(q)) * dt * 1e9).astype(np.int64)
    types = ROS2_TYPESTORE.types
    time_type, header_type = types["builtin_interfaces/msg/Time"], types["std_msgs/msg/Header"]
    joint_state, empty = types[JOINT_STATE], np.zeros(0)
    streams = []
    for stream, names, cols in (("js", list(CHAIN_JOINTS), slice(0, 6)), ("jaw", [JAW_JOINT], slice(6, 7))):
        payloads = [ROS2_TYPESTORE.serialize_cdr(joint_state(
            header=header_type(stamp=time_type(sec=int(t // 1_000_000_000),
                                               nanosec=int(t % 1_000_000_000)), frame_id=""),
            name=names, position=np.ascontiguousarray(p), velocity=empty, effort=empty), JOINT_STATE)
            for t, p in zip(stamps.tolist(), q[:, cols])]
        streams.append((topics[stream], JOINT_STATE, stamps, payloads))
    _write_mcap(path, streams)
    return topics


def _serialize(stream: str, frame: pd.DataFrame, stamps: np.ndarray) -> list[bytes]:
    """CDR payloads of one stream, one per row of ``frame``."""
    types = ROS2_TYPESTORE.types
    time_type, header_type = types["builtin_interfaces/msg/Time"], types["std_msgs/msg/Header"]
    values = frame[list(stream_columns(stream))].to_numpy(dtype=float)
    frame_id = FRAME_IDS[stream]
    headers = [header_type(stamp=time_type(sec=int(t // 1_000_000_000),
                                           nanosec=int(t % 1_000_000_000)), frame_id=frame_id)
               for t in stamps.tolist()]
    msgtype = _TYPES[stream]
    if msgtype == JOINT_STATE:
        joint_state = types[JOINT_STATE]
        names = list(CHAIN_JOINTS) if stream == "js" else [JAW_JOINT]
        position, velocity, effort = (np.ascontiguousarray(v) for v in np.split(values, 3, axis=1))
        messages = (joint_state(header=h, name=names, position=p, velocity=v, effort=e)
                    for h, p, v, e in zip(headers, position, velocity, effort))
    else:
        wrench_stamped, wrench = types[WRENCH_STAMPED], types[WRENCH]
        vector = types["geometry_msgs/msg/Vector3"]
        messages = (wrench_stamped(header=h, wrench=wrench(force=vector(x=f[0], y=f[1], z=f[2]),
                                                           torque=vector(x=f[3], y=f[4], z=f[5])))
                    for h, f in zip(headers, values.tolist()))
    return [ROS2_TYPESTORE.serialize_cdr(m, msgtype) for m in messages]
