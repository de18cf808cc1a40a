"""ROS 2 over plain DDS (``cyclonedds``, the optional extra ``psmforce[ros]``): topic and type
names, the message types as DDS structures, and the quality of service.

ROS 2 maps a topic ``/PSM1/measured_js`` onto the DDS topic ``rt/PSM1/measured_js``
(:func:`dds_topic`) and a type ``sensor_msgs/msg/JointState`` onto the DDS type
``sensor_msgs::msg::dds_::JointState_`` (:func:`dds_type_name`), serialised as CDR. The
structures below carry those names and the ROS 2 fields in order, so a node built on them is
seen by ``ros2 topic echo`` on a machine running ROS 2 on a DDS middleware in the same
``ROS_DOMAIN_ID``; their bytes equal ``rosbags``' and :mod:`psmforce.live.cdr`'s
(``tests/live/test_live_cdr.py``). They decode with :mod:`psmforce.io.bags.messages` like the
``rosbags`` classes (same attribute names).

QoS (:func:`qos`): reliable and volatile, what the dVRK's ROS 2 publishers use (rclcpp's default
profile). Writers keep the last :data:`DEPTH` samples. Bursts: readers keep all samples, up to
:data:`READER_LIMIT`, so a burst the node cannot answer at once waits in the reader instead of
falling out of a keep-last history (a controller that bursts 10x after a hiccup lost a third of
its messages that way); with reliable QoS a reader that is full holds its publisher back rather
than drop a sample, and the limit bounds how far the node can fall behind. Readers and writers are set apart:
``best_effort=True`` gives a best-effort reader, which also matches best-effort (sensor-data QoS)
publishers, or a best-effort writer, which only best-effort subscribers match.
:class:`EndpointWatch` says, in one line each, when a peer's QoS cannot match or an input topic
has no publisher.

No ``from __future__ import annotations`` here: ``cyclonedds`` reads the field types at run time.
"""

from dataclasses import dataclass, field

import cyclonedds.idl.types as t
from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import DDSException, InstanceState, Policy, Qos, SampleState, ViewState
from cyclonedds.idl import IdlStruct
from cyclonedds.util import duration

from psmforce.live.type_hash import user_data

DEPTH = 1000
"""History a writer keeps (messages): one second at 1 kHz."""
READER_LIMIT = 20_000
"""Most samples a reader holds unread: 2 s of a 10 kHz burst; the bound on how far the node
can fall behind."""


def dds_topic(ros_topic: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/PSM1/measured_js`` -> ``rt/PSM1/measured_js``."""
    return "rt/" + ros_topic.lstrip("/")


def dds_type_name(ros_type: str) -> str:
    """The DDS type of a ROS 2 message type: ``sensor_msgs/msg/JointState`` ->
    ``sensor_msgs::msg::dds_::JointState_``."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def qos(best_effort: bool = False, ros_type: str | None = None, *,
        reader: bool = False) -> Qos:
    """Reader and writer QoS (module docstring); with ``ros_type``, the endpoint also carries
    that type's ROS 2 hash in its USER_DATA, as a Jazzy endpoint does
    (:func:`psmforce.live.type_hash.user_data`). A ``reader`` keeps every sample up to
    :data:`READER_LIMIT` (module docstring, Bursts)."""
    reliability = (Policy.Reliability.BestEffort if best_effort
                   else Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)))
    history = ([Policy.History.KeepAll,
                Policy.ResourceLimits(max_samples=READER_LIMIT, max_instances=1,
                                      max_samples_per_instance=READER_LIMIT)]
               if reader else [Policy.History.KeepLast(DEPTH)])
    policies = [reliability, Policy.Durability.Volatile, *history]
    if ros_type is not None:
        policies.append(Policy.Userdata(user_data(ros_type)))
    return Qos(*policies)


@dataclass
class Time(IdlStruct, typename=dds_type_name("builtin_interfaces/msg/Time")):
    sec: t.int32 = 0
    nanosec: t.uint32 = 0


@dataclass
class Header(IdlStruct, typename=dds_type_name("std_msgs/msg/Header")):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Vector3(IdlStruct, typename=dds_type_name("geometry_msgs/msg/Vector3")):
    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Wrench(IdlStruct, typename=dds_type_name("geometry_msgs/msg/Wrench")):
    force: Vector3 = field(default_factory=Vector3)
    torque: Vector3 = field(default_factory=Vector3)


@dataclass
class WrenchStamped(IdlStruct, typename=dds_type_name("geometry_msgs/msg/WrenchStamped")):
    header: Header = field(default_factory=Header)
    wrench: Wrench = field(default_factory=Wrench)


@dataclass
class Vector3Stamped(IdlStruct, typename=dds_type_name("geometry_msgs/msg/Vector3Stamped")):
    header: Header = field(default_factory=Header)
    vector: Vector3 = field(default_factory=Vector3)


@dataclass
class UInt32(IdlStruct, typename=dds_type_name("std_msgs/msg/UInt32")):
    data: t.uint32 = 0


@dataclass
class Empty(IdlStruct, typename=dds_type_name("std_msgs/msg/Empty")):
    structure_needs_at_least_one_field: t.uint8 = 0


@dataclass
class JointState(IdlStruct, typename=dds_type_name("sensor_msgs/msg/JointState")):
    header: Header = field(default_factory=Header)
    name: t.sequence[str] = field(default_factory=list)
    position: t.sequence[t.float64] = field(default_factory=list)
    velocity: t.sequence[t.float64] = field(default_factory=list)
    effort: t.sequence[t.float64] = field(default_factory=list)


@dataclass
class KeyValue(IdlStruct, typename=dds_type_name("diagnostic_msgs/msg/KeyValue")):
    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename=dds_type_name("diagnostic_msgs/msg/DiagnosticStatus")):
    level: t.byte = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: t.sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, typename=dds_type_name("diagnostic_msgs/msg/DiagnosticArray")):
    header: Header = field(default_factory=Header)
    status: t.sequence[DiagnosticStatus] = field(default_factory=list)


TYPES = {"builtin_interfaces/msg/Time": Time, "std_msgs/msg/Header": Header,
         "geometry_msgs/msg/Vector3": Vector3, "geometry_msgs/msg/Wrench": Wrench,
         "geometry_msgs/msg/WrenchStamped": WrenchStamped,
         "geometry_msgs/msg/Vector3Stamped": Vector3Stamped, "std_msgs/msg/UInt32": UInt32,
         "std_msgs/msg/Empty": Empty, "sensor_msgs/msg/JointState": JointState,
         "diagnostic_msgs/msg/KeyValue": KeyValue,
         "diagnostic_msgs/msg/DiagnosticStatus": DiagnosticStatus,
         "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray}
"""The DDS structure of each ROS 2 message type used."""


_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any
"""Read, unread, new, old, alive or not: every sample a reader holds (once, not per take: the
node takes from four readers per message)."""


def write_raw(writer, data: bytes) -> None:
    """Write CDR bytes (:mod:`psmforce.live.cdr`, encapsulation header included) as one sample
    of ``writer``'s type, as ``DataWriter.write`` writes a serialised structure."""
    if ddspy_write(writer._ref, data.ljust((len(data) + 3) & ~3, b"\0")) < 0:
        raise RuntimeError("a DDS write failed: the bytes are not a sample of the topic's type, "
                           "or the participant was closed")


def take_raw(reader, n: int) -> list:
    """Take up to ``n`` samples of ``reader`` as their CDR bytes (encapsulation header
    included; decoded by :mod:`psmforce.live.cdr`), each with its ``SampleInfo``: what
    ``DataReader.take`` does short of deserialising. Samples without data (a writer leaving)
    are dropped."""
    taken = ddspy_take(reader._ref, _ANY_STATE, n)
    if isinstance(taken, int):
        raise DDSException(taken, f"Occurred while taking data in {reader!r}")
    return [(data, info) for data, info in taken if info.valid_data]


def header(stamp_ns: int, frame_id: str) -> Header:
    """A header for a stamp in ns since the epoch."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Header(Time(sec, nanosec), frame_id)


POLICIES = {2: "DURABILITY", 4: "DEADLINE", 5: "LATENCY_BUDGET", 6: "OWNERSHIP",
            8: "LIVELINESS", 10: "PARTITION", 11: "RELIABILITY", 12: "DESTINATION_ORDER",
            13: "HISTORY", 14: "RESOURCE_LIMITS"}
"""DDS QoS policy ids (the DDS specification's numbering) named in the endpoint warnings."""

UNMATCHED_AFTER_S = 5.0
"""How long an input topic may have no publisher before the node says so."""


class EndpointWatch:
    """What a user would otherwise never learn: a publisher or subscriber whose QoS cannot
    match the node's, and an input topic no publisher has matched (another domain, another
    discovery range, a mistyped topic). :meth:`check` returns each problem once, as one line
    that says what to change; the node prints them as they appear."""

    def __init__(self, readers: dict, writers: dict, domain_id: int, started_s: float):
        self._readers, self._writers = readers, writers  # topic -> DataReader / DataWriter
        self._domain, self._started = domain_id, started_s
        self._said: set = set()

    def check(self, now_s: float) -> list[str]:
        lines = []
        for topic, reader in self._readers.items():
            status = reader.get_requested_incompatible_qos_status()
            if status.total_count and ("qos", topic) not in self._said:
                self._said.add(("qos", topic))
                policy = POLICIES.get(status.last_policy_id, f"policy {status.last_policy_id}")
                hint = (" (a best-effort publisher, such as sensor-data QoS: run with "
                        "--reader-qos best-effort)" if policy == "RELIABILITY" else "")
                lines.append(f"serve: a publisher of {topic} offers QoS this node's reader "
                             f"cannot match: {policy}{hint}")
            if now_s - self._started > UNMATCHED_AFTER_S and ("none", topic) not in self._said \
                    and not reader.get_subscription_matched_status().total_count:
                self._said.add(("none", topic))
                lines.append(f"serve: no publisher of {topic} matched in {UNMATCHED_AFTER_S:g} s "
                             f"on domain {self._domain}: check the topic (ros2 topic list), "
                             f"the domain (ROS_DOMAIN_ID, --domain-id) and the discovery range "
                             f"(ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_LOCALHOST_ONLY) on both sides")
        for topic, writer in self._writers.items():
            status = writer.get_offered_incompatible_qos_status()
            if status.total_count and ("qos", topic) not in self._said:
                self._said.add(("qos", topic))
                policy = POLICIES.get(status.last_policy_id, f"policy {status.last_policy_id}")
                hint = (" (a reliable subscriber: run with --writer-qos reliable)"
                        if policy == "RELIABILITY" else "")
                lines.append(f"serve: a subscriber of {topic} requests QoS this node's writer "
                             f"cannot offer: {policy}{hint}")
        return lines
