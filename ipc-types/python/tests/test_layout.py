"""The ctypes structures agree with the Rust layout (layout.json, generated from the
compiler's offsets) and with the sizes the Rust crate asserts at compile time."""

import ctypes

import hrrtc
from hrrtc import wire


def test_every_size_alignment_and_offset_matches_the_rust_layout():
    wire.check()
    assert len(hrrtc.TYPES) == len(hrrtc.LAYOUT["structs"])


def test_sizes_and_type_names_of_the_services_payloads():
    # The sizes ipc-types asserts in Rust (`const _: () = assert!(size_of::<..>() == ..)`).
    assert ctypes.sizeof(hrrtc.HapticState) == 552
    assert ctypes.sizeof(hrrtc.Guidance) == 152
    assert ctypes.sizeof(hrrtc.Pose) == 56
    assert ctypes.sizeof(hrrtc.Header) == 24
    assert hrrtc.HapticState.type_name() == "hrrtc::HapticState.v2"
    assert hrrtc.Guidance.type_name() == "hrrtc::Guidance.v1"
    assert hrrtc.Path.type_name() == "hrrtc::Path.v1"
    assert hrrtc.Roadmap.type_name() == "hrrtc::Roadmap.v1"


def test_arrays_and_nested_structs_are_addressable():
    s = hrrtc.HapticState()
    s.user_pose.orientation_xyzw[3] = 1.0
    s.contact_normal[2] = 1.0
    raw = bytes(s)
    back = hrrtc.HapticState.from_buffer_copy(raw)
    assert back.user_pose.orientation_xyzw[:] == [0.0, 0.0, 0.0, 1.0]
    assert back.contact_normal[:] == [0.0, 0.0, 1.0]
    p = hrrtc.Path()
    assert len(p.waypoints) == hrrtc.CONSTANTS["PATH_CAPACITY"]


def test_codes_have_their_rust_values_and_names():
    assert hrrtc.ContactCode.CONTACT == 3
    assert hrrtc.FaultCode.NONE == 0
    assert hrrtc.FaultCode.name_of(hrrtc.FaultCode.OVERRUN_STREAK) == "overrun-streak"
    assert hrrtc.GuidanceFreshness.name_of(12345) == "unknown"
