"""The wire types of the haptic loop and the planner as ctypes structures.

They are built from ``layout.json``, which the Rust crate ``ipc-types`` generates from the
compiler's own layout (``ipc_types::layout``), so they cannot drift from the Rust types;
:func:`check` verifies every size and offset against that file again after ctypes has
laid the structures out.

Units are SI (m, N, N*m, s, rad); timestamps are CLOCK_MONOTONIC nanoseconds; quaternions
are ``[x, y, z, w]``. Frames are documented on the Rust types (``ipc-types/src``).
"""

import ctypes
import json
from importlib import resources
from types import SimpleNamespace

_SCALARS = {
    "f64": ctypes.c_double,
    "u64": ctypes.c_uint64,
    "u32": ctypes.c_uint32,
    "u8": ctypes.c_uint8,
}


def _load():
    text = resources.files(__package__).joinpath("layout.json").read_text()
    return json.loads(text)


LAYOUT = _load()
"""The layout file as parsed JSON: ``structs``, ``codes``, ``constants``."""

CONSTANTS = {name: value for name, value in LAYOUT["constants"]}
"""Capacities and special values, e.g. ``PATH_CAPACITY``, ``NO_PARENT``."""


def _code_class(code):
    values = {name: value for name, value in code["values"]}
    names = {value: name.lower().replace("_", "-") for name, value in code["values"]}
    ns = SimpleNamespace(**values)
    ns.name_of = lambda value: names.get(value, "unknown")
    ns.__doc__ = f"Named values of the u32 code {code['name']}."
    return ns


CODES = {code["name"]: _code_class(code) for code in LAYOUT["codes"]}
"""Code newtypes by name; each has its constants as attributes and ``name_of(value)``."""

FaultCode = CODES["FaultCode"]
ContactCode = CODES["ContactCode"]
GuidanceMode = CODES["GuidanceMode"]
GuidanceFreshness = CODES["GuidanceFreshness"]
TreeKind = CODES["TreeKind"]
DriverStatus = CODES["DriverStatus"]
OutputCode = CODES["OutputCode"]


def _build():
    types = {}
    for s in LAYOUT["structs"]:
        fields = []
        for f in s["fields"]:
            if f["element"] in _SCALARS:
                base = _SCALARS[f["element"]]
            elif f["element"] == "code":
                base = ctypes.c_uint32
            else:
                base = types[f["type_name"]]
            ctype = base * f["count"] if f["count"] > 1 else base
            fields.append((f["name"], ctype))
        type_name = s["type_name"]
        cls = type(
            s["name"],
            (ctypes.Structure,),
            {
                "_fields_": fields,
                "type_name": classmethod(lambda cls, t=type_name: t),
                "__doc__": f"Wire type {s['name']} (iceoryx2 type name {type_name!r}).",
            },
        )
        types[s["name"]] = cls
    return types


TYPES = _build()
"""Every wire struct by its Rust name."""

Header = TYPES["Header"]
Pose = TYPES["Pose"]
Wrench = TYPES["Wrench"]
Twist = TYPES["Twist"]
HapticState = TYPES["HapticState"]
Guidance = TYPES["Guidance"]
Path = TYPES["Path"]
RoadmapTree = TYPES["RoadmapTree"]
RoadmapNode = TYPES["RoadmapNode"]
Roadmap = TYPES["Roadmap"]
DriverState = TYPES["DriverState"]
DriverCommand = TYPES["DriverCommand"]


def check():
    """Raises ``AssertionError`` naming the first size, alignment or offset where ctypes
    disagrees with the Rust layout in ``layout.json``."""
    for s in LAYOUT["structs"]:
        cls = TYPES[s["name"]]
        assert ctypes.sizeof(cls) == s["size"], (s["name"], ctypes.sizeof(cls), s["size"])
        assert ctypes.alignment(cls) == s["align"], (s["name"], "alignment")
        for f in s["fields"]:
            offset = getattr(cls, f["name"]).offset
            assert offset == f["offset"], (s["name"], f["name"], offset, f["offset"])


check()
