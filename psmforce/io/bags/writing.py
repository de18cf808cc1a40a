"""Writing a recording as a ROS 2 bag (MCAP) on the dVRK CRTK topics: the inverse of
:mod:`.reading`, for the simulated bench (``psmforce simulate --format mcap``).

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
    if os.path.lexists(path):  # a link too, dangling or not: never replaced
        raise BagError(f"{path}: exists already; a bag is written only into a new folder")
    if not path.parent.is_dir():
        raise BagError(f"{path}: the output folder {path.parent} does not exist")
    if isinstance(start_ns, bool) or not isinstance(start_ns, (int, np.integer)) or start_ns <= 0:
        raise BagError(f"{path}: start_ns must be a positive integer (ns since the epoch), "
                       f"got {start_ns!r}")
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
    payloads = {s: _serialize(s, frame, stamps) for s in streams}
    # receive order: every stream's log times, merged (stable: js before jaw at equal times)
    log_ns = np.concatenate([stamps + RECEIVE_LATENCY_NS[s] for s in streams])
    which = np.repeat(np.arange(len(streams)), len(stamps))
    row = np.tile(np.arange(len(stamps)), len(streams))
    order = np.argsort(log_ns, kind="stable")

    with staging_folder(path) as staging:
        with Writer(staging / path.name, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            connections = [writer.add_connection(topics[s], _TYPES[s], typestore=ROS2_TYPESTORE)
                           for s in streams]
            for k in order:
                writer.write(connections[which[k]], int(log_ns[k]),
                             payloads[streams[which[k]]][row[k]])
        if os.path.lexists(path):  # appeared while the bag was written: not replaced
            raise BagError(f"{path}: appeared while the bag was written; left as it is")
        (staging / path.name).rename(path)
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
