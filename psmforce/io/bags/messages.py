"""ROS messages -> recording columns: the one decoding that ``convert``, ``replay`` and ``serve``
share, and the one set of message definitions they use.

Definitions: :data:`ROS2_TYPESTORE`, the ROS 2 Humble message definitions of ``rosbags`` (these
types have not changed since): the bags' fallback definitions, what :mod:`.writing` and
``replay`` store in the bags they write, and the field layout of the DDS types ``serve`` speaks.

Streams (the names of :data:`STREAMS`; message type -> recording columns,
:mod:`psmforce.io.recording`):

* ``js``: sensor_msgs/JointState of the arm -> ``{joint}_position``, ``_velocity``, ``_effort`` of
  the six chain joints (dVRK order, :data:`psmforce.robot.conventions.CHAIN_JOINTS`);
* ``jaw``: sensor_msgs/JointState of the jaw -> ``jaw_position``, ``_velocity``, ``_effort``;
* ``hex10`` / ``ati``: geometry_msgs/WrenchStamped (or Wrench) -> ``fx .. tz`` /
  ``ati_raw_fx .. _tz`` (N, Nm, in the sensor's frame);
* ``jacobian``: std_msgs/Float64MultiArray (6x6, row-major) -> ``spatial_jacobian_{r}{c}``.

Joints are matched by NAME, never by position: the dVRK >= 2024 names and the older ``outer_*``
names of the chain joints; a ``jaw`` entry in the arm message (dVRK 1.x published seven joints
there) is ignored; any other name, a missing, repeated joint or an array whose length is not the
number of names is a :class:`MessageError`. Values are taken as the dVRK publishes them (SI).

Messages are read by attribute (``msg.name``, ``msg.wrench.force.x``, ``msg.header.stamp.sec``), so
the ``rosbags`` classes, the ``cyclonedds`` classes of the live node and anything with the same
fields decode alike. :func:`sample_from_messages` turns the latest arm, jaw and HEX10 messages into
the sample :meth:`psmforce.estimators.runtime.streaming.StreamingEstimator.step` reads;
:class:`SampleArray` gives the same values as an array in an estimator's column order, without
the mapping (the live node's path, once per message).
"""

from __future__ import annotations

import numpy as np
from rosbags.typesys import Stores, get_typestore

from psmforce.robot.conventions import CHAIN_JOINTS, JAW_JOINT
from psmforce.io.recording import ATI_RAW, HEX10, TIME, joint_column

ROS2_TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
"""ROS 2 Humble message definitions (module docstring)."""

JOINT_STATE = "sensor_msgs/msg/JointState"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
WRENCH = "geometry_msgs/msg/Wrench"
MULTI_ARRAY = "std_msgs/msg/Float64MultiArray"

STREAMS = ("js", "jaw", "hex10", "ati", "jacobian")
"""Stream names, the keys of the topic overrides of ``convert``, ``replay`` and ``serve``."""

ACCEPTED_TYPES = {
    "js": (JOINT_STATE,), "jaw": (JOINT_STATE,),
    "hex10": (WRENCH_STAMPED, WRENCH), "ati": (WRENCH_STAMPED, WRENCH),
    "jacobian": (MULTI_ARRAY,),
}
"""The message types each stream may carry."""

JACOBIAN_COLUMNS = tuple(f"spatial_jacobian_{r}{c}" for r in range(6) for c in range(6))
"""Row-major 6x6 spatial Jacobian as the dVRK publishes it (row r, column c)."""

JOINT_FIELDS = ("position", "velocity", "effort")
"""The sensor_msgs/JointState arrays read, each giving the recording column of that quantity."""

_ARM_NAMES = {**{j: j for j in CHAIN_JOINTS}, **{f"outer_{j}": j for j in CHAIN_JOINTS}}
_IGNORED_ARM_NAMES = {JAW_JOINT}
_JAW_NAMES = {JAW_JOINT: JAW_JOINT}


class MessageError(ValueError):
    """A message that does not decode into its stream's columns; the text says why."""


def stream_columns(name: str) -> tuple[str, ...]:
    """The recording columns stream ``name`` (:data:`STREAMS`) carries, in decoding order."""
    if name in ("js", "jaw"):
        joints = CHAIN_JOINTS if name == "js" else (JAW_JOINT,)
        return tuple(joint_column(j, field) for field in JOINT_FIELDS for j in joints)
    return {"hex10": HEX10, "ati": ATI_RAW, "jacobian": JACOBIAN_COLUMNS}[name]


def stamp_ns(message) -> int | None:
    """The header stamp of ``message`` in ns since the epoch; None for a message without a
    header (Wrench, Float64MultiArray). A zero stamp (unset) is returned as 0."""
    header = getattr(message, "header", None)
    if header is None:
        return None
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def joint_index(names, stream: str) -> np.ndarray:
    """Where each joint of ``stream`` (``"js"``: the chain joints in dVRK order, ``"jaw"``)
    sits in a JointState's ``names``; :class:`MessageError` for unknown, missing or repeated
    names (module docstring)."""
    names = tuple(names)
    aliases = _ARM_NAMES if stream == "js" else _JAW_NAMES
    ignored = _IGNORED_ARM_NAMES if stream == "js" else set()
    joints = CHAIN_JOINTS if stream == "js" else (JAW_JOINT,)
    unknown = [n for n in names if n not in aliases and n not in ignored]
    if unknown:
        raise MessageError(f"unknown joint names {unknown}; expected {sorted(aliases)}")
    ours = [aliases.get(n) for n in names]
    missing = [j for j in joints if j not in ours]
    if missing:
        raise MessageError(f"joints {missing} missing (names in message: {list(names)})")
    repeated = sorted({j for j in ours if j is not None and ours.count(j) > 1})
    if repeated:
        raise MessageError(f"joints {repeated} appear more than once in {list(names)}")
    return np.array([ours.index(j) for j in joints])


class JointStateDecoder:
    """sensor_msgs/JointState -> the (3 J,) values of :func:`stream_columns` of ``stream``
    (``"js"`` or ``"jaw"``), by joint name; the index of each name list is kept for the next
    message that carries the same names."""

    def __init__(self, stream: str):
        if stream not in ("js", "jaw"):
            raise MessageError(f"a JointState stream is 'js' or 'jaw', got {stream!r}")
        self.stream = stream
        self.columns = stream_columns(stream)
        self._index: dict[tuple[str, ...], np.ndarray] = {}

    def __call__(self, message) -> np.ndarray:
        names, arrays = self.arrays(message)
        return np.concatenate(arrays)[self.index(names)]

    def index(self, names: tuple[str, ...]) -> np.ndarray:
        """Where each value of :attr:`columns` sits in a message with joints ``names``, its
        position, velocity and effort arrays laid end to end (one gather per message instead
        of one per array); :class:`MessageError` for names :func:`joint_index` refuses."""
        index = self._index.get(names)
        if index is None:
            joints = joint_index(names, self.stream)
            index = self._index[names] = np.concatenate(
                [joints + k * len(names) for k in range(len(JOINT_FIELDS))])
        return index

    def arrays(self, message) -> tuple[tuple[str, ...], list[np.ndarray]]:
        """The joint names of ``message`` and its position, velocity and effort (float
        arrays, as sent); :class:`MessageError` for names :meth:`index` refuses or an array
        without one value per name."""
        names = tuple(message.name)
        self.index(names)  # the names are checked first, as they index the arrays
        arrays = []
        for field in JOINT_FIELDS:
            values = np.asarray(getattr(message, field), dtype=float)
            if len(values) != len(names):
                raise MessageError(f"{field} has {len(values)} values for {len(names)} joint "
                                   f"names {list(names)}")
            arrays.append(values)
        return names, arrays


def wrench_values(message) -> np.ndarray:
    """geometry_msgs/WrenchStamped or Wrench -> (6,) ``fx fy fz tx ty tz`` (N, Nm)."""
    wrench = getattr(message, "wrench", message)
    f, t = wrench.force, wrench.torque
    return np.array([f.x, f.y, f.z, t.x, t.y, t.z], dtype=float)


def jacobian_values(message) -> np.ndarray:
    """std_msgs/Float64MultiArray (6x6) -> (36,) row-major values."""
    sizes = [int(d.size) for d in message.layout.dim]
    if sizes and sizes != [6, 6]:
        raise MessageError(f"Jacobian layout is {sizes}; expected 6x6")
    data = np.asarray(message.data, dtype=float)[int(message.layout.data_offset):]
    if len(data) != 36:
        raise MessageError(f"Jacobian has {len(data)} values; expected 36 (6x6)")
    return data


_JS, _JAW = JointStateDecoder("js"), JointStateDecoder("jaw")
SAMPLE_COLUMNS = (TIME,) + stream_columns("js") + stream_columns("jaw") + HEX10
"""The keys of :func:`sample_from_messages`' sample."""


def _stream_values(js, jaw, hex10) -> np.ndarray:
    """The values of :data:`SAMPLE_COLUMNS` after ``time``, from the three messages."""
    return np.concatenate([_JS(js), _JAW(jaw), wrench_values(hex10)])


def sample_from_messages(js, jaw, hex10, *, time_s: float | None = None) -> dict[str, float]:
    """The estimator's sample from the latest arm JointState ``js``, jaw JointState ``jaw`` and
    HEX10 WrenchStamped ``hex10``: every column they carry (:data:`SAMPLE_COLUMNS`), plus
    ``time`` (s): ``time_s`` when given, else the HEX10 message's header stamp. Raises
    :class:`MessageError` for a message that does not decode."""
    values = _stream_values(js, jaw, hex10)
    if time_s is None:
        stamp = stamp_ns(hex10)
        if stamp is None:
            raise MessageError("a HEX10 Wrench without a header: give time_s")
        time_s = stamp * 1e-9
    return dict(zip(SAMPLE_COLUMNS, [float(time_s), *values.tolist()]))


class SampleArray:
    """The values of :func:`sample_from_messages` (time aside) as one float64 array in the order
    of ``columns`` (an estimator's raw columns, each one of :data:`SAMPLE_COLUMNS`): what
    ``StreamingEstimator.step`` reads as an array sample, built without a mapping per message.
    A column the messages do not carry is refused here (:class:`MessageError`), once, not at
    every message."""

    def __init__(self, columns):
        carried = SAMPLE_COLUMNS[1:]
        missing = [c for c in columns if c not in carried]
        if missing:
            raise MessageError(f"columns {missing} are not in the arm, jaw and HEX10 messages")
        self.columns = tuple(columns)
        self._index = np.array([carried.index(c) for c in columns])
        self._gather: dict[tuple[tuple[str, ...], tuple[str, ...]], np.ndarray] = {}
        """By (arm joint names, jaw joint names): where each of :attr:`columns` sits in the
        messages' arrays laid end to end (arm position, velocity, effort, the jaw's, the
        wrench), so that a sample is one concatenation and one gather."""

    def __call__(self, js, jaw, hex10) -> np.ndarray:
        """The sample of the latest ``js``, ``jaw`` and ``hex10`` messages (a new array);
        raises :class:`MessageError` as :func:`sample_from_messages` does."""
        js_names, js_arrays = _JS.arrays(js)
        jaw_names, jaw_arrays = _JAW.arrays(jaw)
        wrench = wrench_values(hex10)
        gather = self._gather.get((js_names, jaw_names))
        if gather is None:
            n_js, n_jaw = len(JOINT_FIELDS) * len(js_names), len(JOINT_FIELDS) * len(jaw_names)
            carried = np.concatenate([_JS.index(js_names), n_js + _JAW.index(jaw_names),
                                      n_js + n_jaw + np.arange(len(wrench))])
            gather = self._gather[(js_names, jaw_names)] = carried[self._index]
        return np.concatenate((*js_arrays, *jaw_arrays, wrench))[gather]
