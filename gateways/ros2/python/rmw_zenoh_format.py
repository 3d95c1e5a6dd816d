"""rmw_zenoh's wire as its design document states it (ros2/rmw_zenoh, docs/design.md, Jazzy
and later), written here independently of the Rust gateway, to check what it sends.

- topic keys ``<domain>/<fully qualified name without the leading '/'>/<DDS type>/<hash>``;
- liveliness tokens ``@ros2_lv/<domain>/<zid>/<nid>/<nid>/NN/<enclave>/<ns>/<name>`` (nodes)
  and ``.../<nid>/<eid>/<MP|MS|SS|SC>/<enclave>/<ns>/<name>/<topic>/<type>/<hash>/<qos>``
  (endpoints), names mangled (``/`` → ``%``);
- the QoS text of ``qos_to_keyexpr`` and how rmw_zenoh reads it back (``keyexpr_to_qos``);
- the attachment: ``int64`` sequence number, ``int64`` source timestamp (ns since the UNIX
  epoch), one byte GID length (16), 16 GID bytes;
- GIDs: XXH3-128 of the entity's liveliness token, low 64 bits then high, little-endian.
"""

import struct

import xxhash

ADMIN_SPACE = "@ros2_lv"
ENTITY_KINDS = {"NN", "MP", "MS", "SS", "SC"}
# rmw_zenoh's defaults (qos.cpp): reliable, volatile, keep last 42, infinite, automatic.
DEFAULT_QOS = {"reliability": 1, "durability": 2, "history": 1, "depth": 42}


def dds_to_ros(dds_name):
    """``geometry_msgs::msg::dds_::PoseStamped_`` → ``geometry_msgs/msg/PoseStamped``."""
    pkg, kind, dds, last = dds_name.split("::")
    assert dds == "dds_" and last.endswith("_"), dds_name
    return f"{pkg}/{kind}/{last[:-1]}"


def ros_to_dds(ros_name):
    pkg, kind, name = ros_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def demangle(s):
    return s.replace("%", "/")


def parse_qos(text):
    """rmw_zenoh's keyexpr_to_qos: empty fields take the defaults."""
    parts = text.split(":")
    assert len(parts) >= 6, text
    history = parts[2].split(",")
    deadline, lifespan, liveliness = (p.split(",") for p in parts[3:6])
    assert len(history) >= 2 and len(deadline) >= 2 and len(lifespan) >= 2, text
    assert len(liveliness) >= 3, text

    def num(s, default):
        if s == "":
            return default
        assert s.isdigit(), (s, text)
        return int(s)

    qos = {
        "reliability": num(parts[0], DEFAULT_QOS["reliability"]),
        "durability": num(parts[1], DEFAULT_QOS["durability"]),
        "history": num(history[0], DEFAULT_QOS["history"]),
        "depth": num(history[1], DEFAULT_QOS["depth"]),
    }
    assert qos["reliability"] in (0, 1, 2, 3), text
    assert qos["durability"] in (0, 1, 2, 3), text
    assert qos["history"] in (0, 1, 2, 3), text
    for s in deadline + lifespan + liveliness[1:]:
        num(s, 0)
    return qos


def parse_token(key):
    """A liveliness token as rmw_zenoh's ``Entity::make(keyexpr)`` reads it."""
    parts = key.split("/")
    assert len(parts) >= 9, key
    assert all(parts), f"empty part in {key}"
    assert parts[0] == ADMIN_SPACE, key
    kind = parts[5]
    assert kind in ENTITY_KINDS, key
    token = {
        "domain": int(parts[1]),
        "zid": parts[2],
        "nid": parts[3],
        "eid": parts[4],
        "kind": kind,
        "enclave": demangle(parts[6]),
        "namespace": demangle(parts[7]),
        "node": demangle(parts[8]),
    }
    if kind == "NN":
        assert len(parts) == 9 and parts[3] == parts[4], key
        return token
    assert len(parts) == 13, key
    token.update(
        topic=demangle(parts[9]),
        type=demangle(parts[10]),
        hash=demangle(parts[11]),
        qos=parse_qos(parts[12]),
    )
    return token


def topic_key(domain, topic, dds_type, type_hash):
    return f"{domain}/{topic.strip('/')}/{dds_type}/{type_hash}"


def decode_attachment(raw):
    assert raw is not None, "no attachment"
    assert len(raw) == 33, f"attachment of {len(raw)} bytes"
    seq, stamp, gid_len = struct.unpack_from("<qqB", raw)
    assert gid_len == 16, gid_len
    return seq, stamp, bytes(raw[17:])


def encode_attachment(seq, stamp_ns, gid):
    return struct.pack("<qqB", seq, stamp_ns, 16) + bytes(gid)


def gid_of(token):
    h = xxhash.xxh3_128_intdigest(token.encode())
    return struct.pack("<QQ", h & (2**64 - 1), h >> 64)
