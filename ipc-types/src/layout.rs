//! The memory layout of every wire type, as the compiler lays it out, for clients in other
//! languages: names, offsets, sizes, alignments, element types and the iceoryx2 type
//! names, plus the named values of the `u32` codes.
//!
//! Offsets and sizes come from `offset_of!` / `size_of`, element types from the Rust
//! field types ([`WireField`]), type names from the `#[type_name]` attribute: only the
//! field *names* are listed here, and [`wire_types`] checks that the listed fields tile
//! each struct without a gap, so a field added in Rust and not here fails the tests.
//! `layout.json` of the Python package (`ipc-types/python`) and the C header
//! (`ipc-types/include/hrrtc.h`) are generated from it; a test keeps both current.

use crate::{
    ContactCode, DriverCommand, DriverState, DriverStatus, FaultCode, Guidance, GuidanceFreshness,
    GuidanceMode, HapticState, Header, OutputCode, Path, Pose, Roadmap, RoadmapNode, RoadmapTree,
    TreeKind, Twist, Wrench,
};
use core::fmt::Write as _;
use core::mem::{align_of, offset_of, size_of};
use iceoryx2::prelude::ZeroCopySend;
use serde::Serialize;

/// The element type of a field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Element {
    /// IEEE 754 binary64.
    F64,
    /// Unsigned 64-bit integer.
    U64,
    /// Unsigned 32-bit integer.
    U32,
    /// Unsigned byte.
    U8,
    /// A `u32` code newtype (its name in [`Field::type_name`]; values in [`codes`]).
    Code,
    /// Another wire struct (its name in [`Field::type_name`]).
    Struct,
}

/// A Rust type that may be a field of a wire type.
pub trait WireField {
    /// Its element type.
    const ELEMENT: Element;
    /// Its name when it is a code or a struct, else the element's name.
    const NAME: &'static str;
    /// Elements it holds (1 for a scalar or a struct).
    const COUNT: usize;
}

macro_rules! scalar {
    ($($t:ty => $e:ident, $n:literal;)*) => {$(
        impl WireField for $t {
            const ELEMENT: Element = Element::$e;
            const NAME: &'static str = $n;
            const COUNT: usize = 1;
        }
    )*};
}

scalar! {
    f64 => F64, "f64";
    u64 => U64, "u64";
    u32 => U32, "u32";
    u8 => U8, "u8";
}

macro_rules! named {
    ($e:ident: $($t:ident),*) => {$(
        impl WireField for $t {
            const ELEMENT: Element = Element::$e;
            const NAME: &'static str = stringify!($t);
            const COUNT: usize = 1;
        }
    )*};
}

named!(Code: FaultCode, ContactCode, GuidanceMode, GuidanceFreshness, TreeKind, DriverStatus, OutputCode);
named!(Struct: Header, Pose, Wrench, Twist, RoadmapTree, RoadmapNode);

impl<T: WireField, const N: usize> WireField for [T; N] {
    const ELEMENT: Element = T::ELEMENT;
    const NAME: &'static str = T::NAME;
    const COUNT: usize = N * T::COUNT;
}

/// One field of a wire struct.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Field {
    /// Its Rust name.
    pub name: &'static str,
    /// Byte offset from the start of the struct.
    pub offset: usize,
    /// Element type.
    pub element: Element,
    /// The element's type name: `f64`, `u64`, `u32`, `u8`, or a code or struct name.
    pub type_name: &'static str,
    /// Elements (1 unless the field is an array).
    pub count: usize,
    /// Bytes.
    pub size: usize,
}

/// The layout of one wire struct.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct StructLayout {
    /// Rust name, e.g. `HapticState`.
    pub name: &'static str,
    /// The iceoryx2 type name a service of this payload is created with.
    pub type_name: &'static str,
    /// Bytes.
    pub size: usize,
    /// Alignment, bytes.
    pub align: usize,
    /// Fields in memory order.
    pub fields: Vec<Field>,
}

/// The named values of one code newtype.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CodeValues {
    /// Rust name, e.g. `FaultCode`.
    pub name: &'static str,
    /// `(constant name, value)` pairs.
    pub values: Vec<(&'static str, u32)>,
}

#[doc(hidden)]
pub fn field_of<S, T: WireField>(
    name: &'static str,
    offset: usize,
    _project: fn(&S) -> &T,
) -> Field {
    Field {
        name,
        offset,
        element: T::ELEMENT,
        type_name: T::NAME,
        count: T::COUNT,
        size: size_of::<T>(),
    }
}

macro_rules! wire_struct {
    ($t:ident { $($f:ident),* $(,)? }) => {
        StructLayout {
            name: stringify!($t),
            // SAFETY: `type_name` only returns the string of the type's `#[type_name]`
            // attribute; the layout promise it stands for is what this module documents.
            type_name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: size_of::<$t>(),
            align: align_of::<$t>(),
            fields: vec![$(field_of(stringify!($f), offset_of!($t, $f), |s: &$t| &s.$f)),*],
        }
    };
}

/// Every wire struct, dependencies before the structs that hold them.
pub fn wire_types() -> Vec<StructLayout> {
    vec![
        wire_struct!(Header {
            sequence,
            timestamp_ns,
            writer_pid,
            reserved
        }),
        wire_struct!(Pose {
            position_m,
            orientation_xyzw
        }),
        wire_struct!(Wrench { force_n, torque_nm }),
        wire_struct!(Twist {
            linear_m_s,
            angular_rad_s
        }),
        wire_struct!(HapticState {
            header,
            device_pose,
            device_twist,
            user_pose,
            proxy_pose,
            commanded_wrench,
            contact_wrench,
            guidance_wrench,
            contact,
            fault,
            buttons,
            guidance_freshness,
            contact_normal,
            contact_point_m,
            operator_force_n,
            displacement_m,
            penetration_m,
            guidance_sequence,
            prev_wake_latency_ns,
            prev_compute_ns,
            prev_period_ns,
            deadline_misses,
            published_ns,
        }),
        wire_struct!(Guidance {
            header,
            attractive,
            gain_n_per_m,
            gain_nm_per_rad,
            time_to_live_ns,
            state_sequence,
            mode,
            solved,
            iterations,
            nodes,
            trees,
            planner_id,
            distance_to_goal,
            collision_checks,
        }),
        wire_struct!(Path {
            header,
            len,
            length,
            waypoints
        }),
        wire_struct!(RoadmapTree {
            id,
            kind,
            len,
            reserved
        }),
        wire_struct!(RoadmapNode {
            pose,
            distance_to_goal,
            tree_id,
            index,
            parent,
            extension_attempts,
            collisions,
            reserved,
        }),
        wire_struct!(Roadmap {
            header,
            iterations,
            total_nodes,
            trees_len,
            trees_total,
            nodes_len,
            new_nodes,
            solved,
            reserved,
            trees,
            nodes,
        }),
        wire_struct!(DriverState {
            header,
            pose,
            twist,
            buttons,
            status,
            name,
            max_force_n,
            max_torque_nm,
            max_stiffness_n_per_m,
            max_rot_stiffness_nm_per_rad,
            max_damping_n_s_per_m,
            workspace_radius_m,
            button_count,
            orientation_input,
        }),
        wire_struct!(DriverCommand {
            header,
            wrench,
            output,
            reserved
        }),
    ]
}

macro_rules! code_values {
    ($t:ident: $($c:ident),* $(,)?) => {
        CodeValues {
            name: stringify!($t),
            values: vec![$((stringify!($c), $t::$c.0)),*],
        }
    };
}

/// The named values of every code newtype.
pub fn codes() -> Vec<CodeValues> {
    vec![
        code_values!(FaultCode: NONE, DEVICE_READ, DEVICE_WRITE, DEVICE_NON_FINITE, DEVICE_JUMP,
            DEVICE_STALE, DEVICE_DISCONNECTED, OVERRUN_STREAK, NON_FINITE_WRENCH, STARTUP),
        code_values!(ContactCode: DISABLED, FREE, PROXIMITY, CONTACT),
        code_values!(GuidanceMode: NONE, ROADMAP, PATH, NO_WAY),
        code_values!(GuidanceFreshness: NONE, FRESH, FADING, LOST),
        code_values!(TreeKind: START, GOAL, LOCAL),
        code_values!(DriverStatus: UNKNOWN, OK, NOT_READY, FAULT),
        code_values!(OutputCode: OFF, ON),
    ]
}

/// Everything a client needs, as written to `layout.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Layout {
    /// What wrote it and how to regenerate it.
    pub generated_by: &'static str,
    /// Wire structs, dependencies first.
    pub structs: Vec<StructLayout>,
    /// Code newtypes and their named values.
    pub codes: Vec<CodeValues>,
    /// Capacities and special values: `(name, value)`.
    pub constants: Vec<(&'static str, u64)>,
}

/// How the generated files are regenerated.
pub const REGENERATE: &str = "HRRTC_BLESS=1 cargo test -p ipc-types layout";

/// The whole layout.
pub fn layout() -> Layout {
    Layout {
        generated_by: REGENERATE,
        structs: wire_types(),
        codes: codes(),
        constants: vec![
            ("PATH_CAPACITY", crate::PATH_CAPACITY as u64),
            ("ROADMAP_NODES", crate::ROADMAP_NODES as u64),
            ("ROADMAP_TREES", crate::ROADMAP_TREES as u64),
            ("NO_PARENT", u64::from(crate::NO_PARENT)),
            ("DRIVER_NAME_LEN", crate::DRIVER_NAME_LEN as u64),
            ("ENTRY_KEY", crate::services::ENTRY_KEY),
        ],
    }
}

fn c_element(f: &Field) -> String {
    match f.element {
        Element::F64 => "double".into(),
        Element::U64 => "uint64_t".into(),
        Element::U32 => "uint32_t".into(),
        Element::U8 => "uint8_t".into(),
        Element::Code | Element::Struct => format!("hrrtc_{}", f.type_name),
    }
}

/// A C11 header of every wire type, with `_Static_assert`s of each size, alignment and
/// offset, so that a compiler that lays a struct out differently refuses it.
pub fn c_header(layout: &Layout) -> String {
    let mut h = String::new();
    let _ = writeln!(
        h,
        "/* hrrtc wire types: the payloads of the haptic loop's and the planner's iceoryx2\n * \
         services. Generated from ipc-types/src/layout.rs; do not edit. Regenerate with\n * \
         `{}`.\n *\n * Units are SI (m, N, N*m, s, rad); timestamps are CLOCK_MONOTONIC ns;\n * \
         quaternions are [x, y, z, w]; each field's frame is documented on the Rust type. */",
        layout.generated_by
    );
    h.push_str("#ifndef HRRTC_WIRE_H\n#define HRRTC_WIRE_H\n\n#include <stddef.h>\n#include <stdint.h>\n\n");
    for (name, value) in &layout.constants {
        let _ = writeln!(h, "#define HRRTC_{name} {value}u");
    }
    h.push('\n');
    for c in &layout.codes {
        let _ = writeln!(h, "typedef uint32_t hrrtc_{};", c.name);
        for (v, value) in &c.values {
            let _ = writeln!(h, "#define HRRTC_{}_{v} {value}u", upper_snake(c.name));
        }
        h.push('\n');
    }
    for s in &layout.structs {
        let _ = writeln!(h, "/* iceoryx2 type name \"{}\" */", s.type_name);
        let _ = writeln!(h, "typedef struct hrrtc_{0} {{", s.name);
        for f in &s.fields {
            let array = if f.count > 1 {
                format!("[{}]", f.count)
            } else {
                String::new()
            };
            let _ = writeln!(h, "    {} {}{};", c_element(f), f.name, array);
        }
        let _ = writeln!(h, "}} hrrtc_{};", s.name);
        let _ = writeln!(
            h,
            "_Static_assert(sizeof(hrrtc_{0}) == {1}, \"size of {0}\");\n_Static_assert(_Alignof(hrrtc_{0}) == {2}, \"alignment of {0}\");",
            s.name, s.size, s.align
        );
        for f in &s.fields {
            let _ = writeln!(
                h,
                "_Static_assert(offsetof(hrrtc_{0}, {1}) == {2}, \"offset of {0}.{1}\");",
                s.name, f.name, f.offset
            );
        }
        let _ = writeln!(
            h,
            "#define HRRTC_{}_TYPE_NAME \"{}\"\n",
            upper_snake(s.name),
            s.type_name
        );
    }
    h.push_str("#endif /* HRRTC_WIRE_H */\n");
    h
}

/// `GuidanceFreshness` → `GUIDANCE_FRESHNESS`.
fn upper_snake(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_listed_fields_tile_every_struct() {
        for s in wire_types() {
            let mut end = 0;
            for f in &s.fields {
                assert_eq!(
                    f.offset, end,
                    "{}.{} leaves a gap or overlaps",
                    s.name, f.name
                );
                end = f.offset + f.size;
            }
            assert_eq!(
                end, s.size,
                "{}: fields end at {end}, the struct at {}",
                s.name, s.size
            );
            assert!(s.type_name.starts_with("hrrtc::"), "{}", s.type_name);
        }
    }

    #[test]
    fn names_and_sizes_are_the_known_ones() {
        let all = wire_types();
        let state = all.iter().find(|s| s.name == "HapticState").expect("state");
        assert_eq!(
            (state.type_name, state.size),
            ("hrrtc::HapticState.v2", 552)
        );
        let f = state
            .fields
            .iter()
            .find(|f| f.name == "contact_normal")
            .expect("field");
        assert_eq!((f.element, f.count, f.size), (Element::F64, 3, 24));
        let g = all.iter().find(|s| s.name == "Guidance").expect("guidance");
        assert_eq!((g.type_name, g.size), ("hrrtc::Guidance.v1", 152));
        assert_eq!(upper_snake("GuidanceFreshness"), "GUIDANCE_FRESHNESS");
    }
}
