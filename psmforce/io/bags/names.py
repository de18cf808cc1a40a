"""ROS 2 names: the arm namespace and the topics a user types, checked before they reach a bag
reader or the DDS middleware.

The rules are ROS 2's for a fully qualified topic name (``rmw_validate_full_topic_name``, and
the design article *Topic and Service name mapping to DDS*): tokens separated by ``/``, each
starting with a letter or an underscore and holding only ASCII letters, digits and
underscores; no empty token (``//``), no trailing ``/``, at most :data:`MAX_NAME_CHARS`
characters. A relative name (``measured_js``) is taken as absolute (``/measured_js``), as
``convert`` always has. Substitutions (``~``, ``{node}``) are a node's to expand and are refused
here: the name a user types is the name used. A name outside the rules is refused in one line
that says which rule, never handed on (cyclonedds would map it to a DDS topic no ROS 2 tool can
reach, or fail deep inside).
"""

from __future__ import annotations

import re

MAX_NAME_CHARS = 247
"""Longest topic name: the 255 characters of a DDS topic name, less ROS 2's ``rt`` prefix and
room for the ``/tool_force/hex10`` the node appends to its namespace."""

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def check_ros_name(name: object, what: str) -> str:
    """``name`` as an absolute ROS 2 name (a leading ``/`` added), or :class:`ValueError`
    naming ``what`` (``"--arm"``, ``"topic for stream 'js'"``) and the rule it breaks."""
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"{what} must be a non-empty ROS 2 name, got {name!r}")
    full = name if name.startswith("/") else "/" + name
    if len(full) > MAX_NAME_CHARS:
        raise ValueError(f"{what} {name[:40]!r}...: a ROS 2 name holds at most "
                         f"{MAX_NAME_CHARS} characters, this one {len(full)}")
    if full != "/" and full.endswith("/"):
        raise ValueError(f"{what} {name!r}: a ROS 2 name must not end with '/'")
    for token in full[1:].split("/"):
        if not token:
            raise ValueError(f"{what} {name!r}: a ROS 2 name has no empty token ('//')")
        if not _TOKEN.fullmatch(token):
            bad = next((c for c in token if not (c.isascii() and (c.isalnum() or c == "_"))),
                       None)
            rule = (f"character {bad!r} is not allowed (letters, digits and '_' only)"
                    if bad is not None else f"token {token!r} starts with a digit")
            raise ValueError(f"{what} {name!r}: not a ROS 2 name: {rule}")
    return full


def check_namespace(arm: object, what: str = "arm") -> str:
    """The arm's namespace without its slashes (``"PSM1"``), checked as :func:`check_ros_name`."""
    if isinstance(arm, str) and arm.strip("/") == "" and arm:
        raise ValueError(f"{what} must be a namespace such as 'PSM1', got {arm!r}")
    return check_ros_name(arm.strip("/") if isinstance(arm, str) else arm, what)[1:]
