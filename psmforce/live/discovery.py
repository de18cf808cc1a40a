"""How the live node joins DDS as a ROS 2 node started in the same environment would.

The domain: ``domain_id``, else ``ROS_DOMAIN_ID``, else 0, as ROS 2 does (:func:`domain`); the
discovery range: ``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_STATIC_PEERS`` and
``ROS_LOCALHOST_ONLY`` read as ROS 2 Jazzy reads them (:func:`discovery`), turned into Cyclone
DDS settings for the participant (:func:`participant`).
"""

from __future__ import annotations

import os


def domain(domain_id: int | None = None) -> int:
    """``domain_id``, else the ``ROS_DOMAIN_ID`` environment variable, else 0; refused in one
    line outside [0, 232], the domains ROS 2 allows."""
    if domain_id is None:
        value = os.environ.get("ROS_DOMAIN_ID", "").strip()
        if value and not value.isdigit():
            raise ValueError(f"ROS_DOMAIN_ID must be an integer, got {value!r}")
        domain_id = int(value or 0)
    if isinstance(domain_id, bool) or not isinstance(domain_id, int) \
            or not 0 <= domain_id <= 232:
        raise ValueError(f"the DDS domain must be an integer in [0, 232], got {domain_id!r}")
    return domain_id


DISCOVERY_RANGES = ("SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT")
"""The values of ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (ROS 2 Jazzy)."""


def discovery() -> tuple[str, list[str]]:
    """The discovery range and static peers, read as ROS 2 (Jazzy) reads them:
    ``ROS_AUTOMATIC_DISCOVERY_RANGE`` (default SUBNET), ``ROS_STATIC_PEERS`` (``;``-separated
    addresses), and the older ``ROS_LOCALHOST_ONLY=1``, which means LOCALHOST and takes
    precedence, as in Jazzy. A value outside these is refused in one line."""
    value = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper() or "SUBNET"
    if value not in DISCOVERY_RANGES:
        raise ValueError(f"ROS_AUTOMATIC_DISCOVERY_RANGE must be one of {DISCOVERY_RANGES}, "
                         f"got {value!r}")
    localhost_only = os.environ.get("ROS_LOCALHOST_ONLY", "").strip()
    if localhost_only not in ("", "0", "1"):
        raise ValueError(f"ROS_LOCALHOST_ONLY must be 0 or 1, got {localhost_only!r}")
    if localhost_only == "1":
        value = "LOCALHOST"
    peers = [p.strip() for p in os.environ.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    return value, peers


def _discovery_config(value: str, peers: list[str]) -> str | None:
    """Cyclone DDS settings for a discovery range (None: its defaults, the subnet). LOCALHOST:
    the loopback interface, no multicast, the local participants found by their well-known
    ports; OFF: the loopback interface, no multicast, no well-known port, so only the static
    peers can find the node or be found by it."""
    if value in ("SUBNET", "SYSTEM_DEFAULT") and not peers:
        return None
    listed = "".join(f'<Peer address="{p}"/>' for p in
                     (["localhost"] if value == "LOCALHOST" else []) + peers)
    local = value in ("LOCALHOST", "OFF")
    return ("<CycloneDDS><Domain>"
            + ("<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
               "<AllowMulticast>false</AllowMulticast></General>" if local else "")
            + ("<Discovery><ParticipantIndex>none</ParticipantIndex>" if value == "OFF" else
               "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
               "<MaxAutoParticipantIndex>120</MaxAutoParticipantIndex>")
            + (f"<Peers>{listed}</Peers>" if listed else "")
            + "</Discovery></Domain></CycloneDDS>")


def participant(domain_id: int | None = None):
    """A DDS participant on :func:`domain` with the discovery range of :func:`discovery`, as a
    ROS 2 node started in the same environment would have. A ``CYCLONEDDS_URI`` the user set
    still applies after these settings, as with ROS 2's Cyclone DDS middleware."""
    from cyclonedds.domain import Domain, DomainParticipant
    number = domain(domain_id)
    config = _discovery_config(*discovery())
    kept = None
    if config is not None:
        user = os.environ.get("CYCLONEDDS_URI", "").strip()
        kept = Domain(number, config + ("," + user if user else ""))
    joined = DomainParticipant(number)
    joined._psmforce_domain = kept  # the configured domain lives as long as the participant
    return joined
