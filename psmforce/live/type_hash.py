"""ROS 2 type hashes (RIHS01) of the messages the live node uses, from their definitions.

ROS 2 Jazzy identifies a message type by a hash of its description (REP 2011, "RIHS01"): the
SHA-256 of a JSON document holding the type's fields and, sorted by name, every type it
references, each field as ``{"name", "type": {"type_id", "capacity", "string_capacity",
"nested_type_name"}}`` (default values left out), written with ``", "`` and ``": "`` as
separators. Its middleware carries the hash in each endpoint's USER_DATA QoS as
``typehash=RIHS01_<hex>;`` and its tools warn about endpoints without one. :func:`user_data`
gives those bytes; :mod:`psmforce.live.dds` sets them on every reader and writer the node and
the simulated robot create.

:data:`DEFINITIONS` are the ROS 2 message definitions (fields in order, as in the ``.msg``
files of ``builtin_interfaces``, ``std_msgs``, ``geometry_msgs``, ``sensor_msgs`` and
``diagnostic_msgs``); the hashes
are computed here, and ``tests/live/test_type_hash.py`` checks each against ``rosbags``' own.
"""

from __future__ import annotations

import hashlib
import json

DEFINITIONS: dict[str, tuple[tuple[str, str], ...]] = {
    "builtin_interfaces/msg/Time": (("sec", "int32"), ("nanosec", "uint32")),
    "std_msgs/msg/Header": (("stamp", "builtin_interfaces/msg/Time"), ("frame_id", "string")),
    "std_msgs/msg/UInt32": (("data", "uint32"),),
    "std_msgs/msg/Empty": (("structure_needs_at_least_one_member", "uint8"),),
    "geometry_msgs/msg/Vector3": (("x", "float64"), ("y", "float64"), ("z", "float64")),
    "geometry_msgs/msg/Vector3Stamped": (("header", "std_msgs/msg/Header"),
                                         ("vector", "geometry_msgs/msg/Vector3")),
    "geometry_msgs/msg/Wrench": (("force", "geometry_msgs/msg/Vector3"),
                                 ("torque", "geometry_msgs/msg/Vector3")),
    "geometry_msgs/msg/WrenchStamped": (("header", "std_msgs/msg/Header"),
                                        ("wrench", "geometry_msgs/msg/Wrench")),
    "diagnostic_msgs/msg/KeyValue": (("key", "string"), ("value", "string")),
    "diagnostic_msgs/msg/DiagnosticStatus": (("level", "byte"), ("name", "string"),
                                             ("message", "string"), ("hardware_id", "string"),
                                             ("values", "diagnostic_msgs/msg/KeyValue[]")),
    "diagnostic_msgs/msg/DiagnosticArray": (("header", "std_msgs/msg/Header"),
                                            ("status", "diagnostic_msgs/msg/DiagnosticStatus[]")),
    "sensor_msgs/msg/JointState": (("header", "std_msgs/msg/Header"), ("name", "string[]"),
                                   ("position", "float64[]"), ("velocity", "float64[]"),
                                   ("effort", "float64[]")),
}
"""Each message type's fields, in order: ``(name, type)``; ``[]`` marks an unbounded sequence.
(An empty ``.msg`` gets the one ``uint8`` member ROS 2 adds.)"""

_TYPE_IDS = {"nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6,
             "uint32": 7, "int64": 8, "uint64": 9, "float32": 10, "float64": 11, "char": 13,
             "bool": 15, "byte": 16, "string": 17}
"""``type_description_interfaces/msg/FieldType`` ids of the element types used here."""
_UNBOUNDED_SEQUENCE = 144
"""Added to an element's id for an unbounded sequence of it (FieldType's numbering)."""


def _field(name: str, kind: str) -> dict:
    sequence = kind.endswith("[]")
    element = kind[:-2] if sequence else kind
    nested = element if "/" in element else ""
    type_id = _TYPE_IDS["nested" if nested else element] + (_UNBOUNDED_SEQUENCE if sequence
                                                             else 0)
    return {"name": name, "type": {"type_id": type_id, "capacity": 0, "string_capacity": 0,
                                   "nested_type_name": nested}}


def _description(type_name: str) -> dict:
    return {"type_name": type_name,
            "fields": [_field(name, kind) for name, kind in DEFINITIONS[type_name]]}


def _referenced(type_name: str, found: set[str]) -> set[str]:
    for _, kind in DEFINITIONS[type_name]:
        element = kind.removesuffix("[]")
        if "/" in element and element not in found:
            found.add(element)
            _referenced(element, found)
    return found


def rihs01(type_name: str) -> str:
    """The ROS 2 type hash of ``type_name`` (a key of :data:`DEFINITIONS`):
    ``RIHS01_`` + 64 hex digits."""
    if type_name not in DEFINITIONS:
        raise KeyError(f"no definition of {type_name!r}; known: {sorted(DEFINITIONS)}")
    document = {"type_description": _description(type_name),
                "referenced_type_descriptions": [_description(t) for t in
                                                 sorted(_referenced(type_name, set()))]}
    text = json.dumps(document, separators=(", ", ": "), ensure_ascii=True, allow_nan=False)
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def user_data(type_name: str) -> bytes:
    """The USER_DATA a ROS 2 (Jazzy) endpoint of ``type_name`` carries."""
    return f"typehash={rihs01(type_name)};".encode("ascii")
