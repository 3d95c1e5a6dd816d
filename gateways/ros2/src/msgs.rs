//! The ROS 2 messages the gateway writes and reads: their type descriptions (for RIHS01, see
//! [`crate::typehash`]) and their CDR encodings. Definitions as in Jazzy and Kilted (and
//! Humble: none of these changed between them).
//!
//! Units and conventions are ROS's (REP-103): metres, radians, newtons, newton-metres,
//! seconds; quaternions `x, y, z, w`; `header.stamp` is ROS time (the system clock, seconds
//! and nanoseconds since the UNIX epoch); `header.frame_id` names the frame the values are
//! in.

use crate::cdr::{CdrError, CdrReader, CdrWriter};
use crate::typehash::{Field, MsgType, Prim};

/// Most elements a sequence may have in a message we read (a guard against absurd counts;
/// the bytes remaining bound it too).
pub const MAX_SEQUENCE: usize = 1 << 20;

macro_rules! fields {
    ($($f:expr),* $(,)?) => { &[$($f),*] };
}

/// `builtin_interfaces/msg/Time`.
pub static TIME: MsgType = MsgType {
    name: "builtin_interfaces/msg/Time",
    fields: fields![
        Field::prim("sec", Prim::I32),
        Field::prim("nanosec", Prim::U32)
    ],
};
/// `builtin_interfaces/msg/Duration`.
pub static DURATION: MsgType = MsgType {
    name: "builtin_interfaces/msg/Duration",
    fields: fields![
        Field::prim("sec", Prim::I32),
        Field::prim("nanosec", Prim::U32)
    ],
};
/// `std_msgs/msg/Header`.
pub static HEADER: MsgType = MsgType {
    name: "std_msgs/msg/Header",
    fields: fields![
        Field::msg("stamp", &TIME),
        Field::prim("frame_id", Prim::String)
    ],
};
/// `geometry_msgs/msg/Point`.
pub static POINT: MsgType = MsgType {
    name: "geometry_msgs/msg/Point",
    fields: fields![
        Field::prim("x", Prim::F64),
        Field::prim("y", Prim::F64),
        Field::prim("z", Prim::F64)
    ],
};
/// `geometry_msgs/msg/Vector3`.
pub static VECTOR3: MsgType = MsgType {
    name: "geometry_msgs/msg/Vector3",
    fields: fields![
        Field::prim("x", Prim::F64),
        Field::prim("y", Prim::F64),
        Field::prim("z", Prim::F64)
    ],
};
/// `geometry_msgs/msg/Quaternion`.
pub static QUATERNION: MsgType = MsgType {
    name: "geometry_msgs/msg/Quaternion",
    fields: fields![
        Field::prim("x", Prim::F64),
        Field::prim("y", Prim::F64),
        Field::prim("z", Prim::F64),
        Field::prim("w", Prim::F64)
    ],
};
/// `geometry_msgs/msg/Pose`.
pub static POSE: MsgType = MsgType {
    name: "geometry_msgs/msg/Pose",
    fields: fields![
        Field::msg("position", &POINT),
        Field::msg("orientation", &QUATERNION)
    ],
};
/// `geometry_msgs/msg/PoseStamped`.
pub static POSE_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/msg/PoseStamped",
    fields: fields![Field::msg("header", &HEADER), Field::msg("pose", &POSE)],
};
/// `geometry_msgs/msg/Wrench`.
pub static WRENCH: MsgType = MsgType {
    name: "geometry_msgs/msg/Wrench",
    fields: fields![
        Field::msg("force", &VECTOR3),
        Field::msg("torque", &VECTOR3)
    ],
};
/// `geometry_msgs/msg/WrenchStamped`.
pub static WRENCH_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/msg/WrenchStamped",
    fields: fields![Field::msg("header", &HEADER), Field::msg("wrench", &WRENCH)],
};
/// `geometry_msgs/msg/Twist`.
pub static TWIST: MsgType = MsgType {
    name: "geometry_msgs/msg/Twist",
    fields: fields![
        Field::msg("linear", &VECTOR3),
        Field::msg("angular", &VECTOR3)
    ],
};
/// `geometry_msgs/msg/TwistStamped`.
pub static TWIST_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/msg/TwistStamped",
    fields: fields![Field::msg("header", &HEADER), Field::msg("twist", &TWIST)],
};
/// `geometry_msgs/msg/Transform`.
pub static TRANSFORM: MsgType = MsgType {
    name: "geometry_msgs/msg/Transform",
    fields: fields![
        Field::msg("translation", &VECTOR3),
        Field::msg("rotation", &QUATERNION)
    ],
};
/// `geometry_msgs/msg/TransformStamped`.
pub static TRANSFORM_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/msg/TransformStamped",
    fields: fields![
        Field::msg("header", &HEADER),
        Field::prim("child_frame_id", Prim::String),
        Field::msg("transform", &TRANSFORM)
    ],
};
/// `tf2_msgs/msg/TFMessage`.
pub static TF_MESSAGE: MsgType = MsgType {
    name: "tf2_msgs/msg/TFMessage",
    fields: fields![Field::msg_seq("transforms", &TRANSFORM_STAMPED)],
};
/// `nav_msgs/msg/Path`.
pub static PATH: MsgType = MsgType {
    name: "nav_msgs/msg/Path",
    fields: fields![
        Field::msg("header", &HEADER),
        Field::msg_seq("poses", &POSE_STAMPED)
    ],
};
/// `std_msgs/msg/ColorRGBA`.
pub static COLOR_RGBA: MsgType = MsgType {
    name: "std_msgs/msg/ColorRGBA",
    fields: fields![
        Field::prim("r", Prim::F32),
        Field::prim("g", Prim::F32),
        Field::prim("b", Prim::F32),
        Field::prim("a", Prim::F32)
    ],
};
/// `sensor_msgs/msg/CompressedImage` (only inside a marker, always empty here).
pub static COMPRESSED_IMAGE: MsgType = MsgType {
    name: "sensor_msgs/msg/CompressedImage",
    fields: fields![
        Field::msg("header", &HEADER),
        Field::prim("format", Prim::String),
        Field::prim_seq("data", Prim::U8)
    ],
};
/// `visualization_msgs/msg/UVCoordinate`.
pub static UV_COORDINATE: MsgType = MsgType {
    name: "visualization_msgs/msg/UVCoordinate",
    fields: fields![Field::prim("u", Prim::F32), Field::prim("v", Prim::F32)],
};
/// `visualization_msgs/msg/MeshFile` (only inside a marker, always empty here).
pub static MESH_FILE: MsgType = MsgType {
    name: "visualization_msgs/msg/MeshFile",
    fields: fields![
        Field::prim("filename", Prim::String),
        Field::prim_seq("data", Prim::U8)
    ],
};
/// `visualization_msgs/msg/Marker`.
pub static MARKER: MsgType = MsgType {
    name: "visualization_msgs/msg/Marker",
    fields: fields![
        Field::msg("header", &HEADER),
        Field::prim("ns", Prim::String),
        Field::prim("id", Prim::I32),
        Field::prim("type", Prim::I32),
        Field::prim("action", Prim::I32),
        Field::msg("pose", &POSE),
        Field::msg("scale", &VECTOR3),
        Field::msg("color", &COLOR_RGBA),
        Field::msg("lifetime", &DURATION),
        Field::prim("frame_locked", Prim::Bool),
        Field::msg_seq("points", &POINT),
        Field::msg_seq("colors", &COLOR_RGBA),
        Field::prim("texture_resource", Prim::String),
        Field::msg("texture", &COMPRESSED_IMAGE),
        Field::msg_seq("uv_coordinates", &UV_COORDINATE),
        Field::prim("text", Prim::String),
        Field::prim("mesh_resource", Prim::String),
        Field::msg("mesh_file", &MESH_FILE),
        Field::prim("mesh_use_embedded_materials", Prim::Bool)
    ],
};
/// `visualization_msgs/msg/MarkerArray`.
pub static MARKER_ARRAY: MsgType = MsgType {
    name: "visualization_msgs/msg/MarkerArray",
    fields: fields![Field::msg_seq("markers", &MARKER)],
};
/// `std_msgs/msg/MultiArrayDimension`.
pub static MULTI_ARRAY_DIMENSION: MsgType = MsgType {
    name: "std_msgs/msg/MultiArrayDimension",
    fields: fields![
        Field::prim("label", Prim::String),
        Field::prim("size", Prim::U32),
        Field::prim("stride", Prim::U32)
    ],
};
/// `std_msgs/msg/MultiArrayLayout`.
pub static MULTI_ARRAY_LAYOUT: MsgType = MsgType {
    name: "std_msgs/msg/MultiArrayLayout",
    fields: fields![
        Field::msg_seq("dim", &MULTI_ARRAY_DIMENSION),
        Field::prim("data_offset", Prim::U32)
    ],
};
/// `std_msgs/msg/Float64MultiArray`.
pub static FLOAT64_MULTI_ARRAY: MsgType = MsgType {
    name: "std_msgs/msg/Float64MultiArray",
    fields: fields![
        Field::msg("layout", &MULTI_ARRAY_LAYOUT),
        Field::prim_seq("data", Prim::F64)
    ],
};
/// `sensor_msgs/msg/Joy`.
pub static JOY: MsgType = MsgType {
    name: "sensor_msgs/msg/Joy",
    fields: fields![
        Field::msg("header", &HEADER),
        Field::prim_seq("axes", Prim::F32),
        Field::prim_seq("buttons", Prim::I32)
    ],
};

/// A ROS 2 message with its CDR encoding.
pub trait Message: Sized {
    /// Its type description.
    const TYPE: &'static MsgType;

    /// Writes its fields.
    fn write(&self, w: &mut CdrWriter);

    /// Reads its fields.
    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError>;

    /// Its CDR payload, header included.
    fn encode(&self) -> Vec<u8> {
        self.encode_into(Vec::new())
    }

    /// Its CDR payload, written into `buf`'s allocation.
    fn encode_into(&self, buf: Vec<u8>) -> Vec<u8> {
        let mut w = CdrWriter::with_buffer(buf);
        self.write(&mut w);
        w.finish()
    }

    /// The message in a whole payload (header, fields, at most 3 bytes of padding).
    fn decode(payload: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(payload)?;
        let v = Self::read(&mut r)?;
        r.finish()?;
        Ok(v)
    }
}

fn write_vec3(w: &mut CdrWriter, v: &[f64; 3]) {
    v.iter().for_each(|x| w.f64(*x));
}

fn read_vec3(r: &mut CdrReader<'_>, what: [&'static str; 3]) -> Result<[f64; 3], CdrError> {
    Ok([r.f64(what[0])?, r.f64(what[1])?, r.f64(what[2])?])
}

fn read_quat(r: &mut CdrReader<'_>, what: [&'static str; 4]) -> Result<[f64; 4], CdrError> {
    Ok([
        r.f64(what[0])?,
        r.f64(what[1])?,
        r.f64(what[2])?,
        r.f64(what[3])?,
    ])
}

/// `builtin_interfaces/msg/Time` (and `Duration`, laid out the same).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds, 0 ≤ nanosec < 10⁹.
    pub nanosec: u32,
}

impl Time {
    /// The time `ns` nanoseconds after the epoch (floored to whole seconds and the rest).
    pub fn from_ns(ns: i64) -> Self {
        Time {
            sec: i32::try_from(ns.div_euclid(1_000_000_000)).unwrap_or(i32::MAX),
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        }
    }

    /// Nanoseconds after the epoch.
    pub fn as_ns(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }

    fn write(&self, w: &mut CdrWriter) {
        w.i32(self.sec);
        w.u32(self.nanosec);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Time {
            sec: r.i32("header.stamp.sec")?,
            nanosec: r.u32("header.stamp.nanosec")?,
        })
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Header {
    /// ROS time of the data.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

impl Header {
    fn write(&self, w: &mut CdrWriter) {
        self.stamp.write(w);
        w.string(&self.frame_id);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Header {
            stamp: Time::read(r)?,
            frame_id: r.string("header.frame_id")?.to_owned(),
        })
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// Position, m.
    pub position: [f64; 3],
    /// Orientation quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

impl Pose {
    fn write(&self, w: &mut CdrWriter) {
        write_vec3(w, &self.position);
        self.orientation.iter().for_each(|x| w.f64(*x));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Pose {
            position: read_vec3(r, ["pose.position.x", "pose.position.y", "pose.position.z"])?,
            orientation: read_quat(
                r,
                [
                    "pose.orientation.x",
                    "pose.orientation.y",
                    "pose.orientation.z",
                    "pose.orientation.w",
                ],
            )?,
        })
    }
}

impl From<ipc_types::Pose> for Pose {
    fn from(p: ipc_types::Pose) -> Self {
        Pose {
            position: p.position_m,
            orientation: p.orientation_xyzw,
        }
    }
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose in `header.frame_id`.
    pub pose: Pose,
}

impl Message for PoseStamped {
    const TYPE: &'static MsgType = &POSE_STAMPED;

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        self.pose.write(w);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(PoseStamped {
            header: Header::read(r)?,
            pose: Pose::read(r)?,
        })
    }
}

/// `geometry_msgs/msg/Wrench`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench {
    /// Force, N.
    pub force: [f64; 3],
    /// Torque, N·m.
    pub torque: [f64; 3],
}

/// `geometry_msgs/msg/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WrenchStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The wrench in `header.frame_id` (torque about its origin).
    pub wrench: Wrench,
}

impl Message for WrenchStamped {
    const TYPE: &'static MsgType = &WRENCH_STAMPED;

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        write_vec3(w, &self.wrench.force);
        write_vec3(w, &self.wrench.torque);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(WrenchStamped {
            header: Header::read(r)?,
            wrench: Wrench {
                force: read_vec3(r, ["wrench.force.x", "wrench.force.y", "wrench.force.z"])?,
                torque: read_vec3(r, ["wrench.torque.x", "wrench.torque.y", "wrench.torque.z"])?,
            },
        })
    }
}

/// `geometry_msgs/msg/TwistStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TwistStamped {
    /// Stamp and frame.
    pub header: Header,
    /// Linear velocity, m/s.
    pub linear: [f64; 3],
    /// Angular velocity, rad/s.
    pub angular: [f64; 3],
}

impl Message for TwistStamped {
    const TYPE: &'static MsgType = &TWIST_STAMPED;

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        write_vec3(w, &self.linear);
        write_vec3(w, &self.angular);
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(TwistStamped {
            header: Header::read(r)?,
            linear: read_vec3(r, ["twist.linear.x", "twist.linear.y", "twist.linear.z"])?,
            angular: read_vec3(r, ["twist.angular.x", "twist.angular.y", "twist.angular.z"])?,
        })
    }
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's origin in the parent frame, m.
    pub translation: [f64; 3],
    /// The child frame's orientation in the parent frame, `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl TransformStamped {
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.string(&self.child_frame_id);
        write_vec3(w, &self.translation);
        self.rotation.iter().for_each(|x| w.f64(*x));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(TransformStamped {
            header: Header::read(r)?,
            child_frame_id: r.string("child_frame_id")?.to_owned(),
            translation: read_vec3(
                r,
                [
                    "transform.translation.x",
                    "transform.translation.y",
                    "transform.translation.z",
                ],
            )?,
            rotation: read_quat(
                r,
                [
                    "transform.rotation.x",
                    "transform.rotation.y",
                    "transform.rotation.z",
                    "transform.rotation.w",
                ],
            )?,
        })
    }
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl Message for TfMessage {
    const TYPE: &'static MsgType = &TF_MESSAGE;

    fn write(&self, w: &mut CdrWriter) {
        w.sequence(self.transforms.len());
        self.transforms.iter().for_each(|t| t.write(w));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let n = r.sequence("transforms", 8 + 4 + 4 + 4 + 56, MAX_SEQUENCE)?;
        let transforms = (0..n)
            .map(|_| TransformStamped::read(r))
            .collect::<Result<_, _>>()?;
        Ok(TfMessage { transforms })
    }
}

/// `nav_msgs/msg/Path`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Path {
    /// Stamp and frame.
    pub header: Header,
    /// The poses, start to goal.
    pub poses: Vec<PoseStamped>,
}

impl Message for Path {
    const TYPE: &'static MsgType = &PATH;

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.sequence(self.poses.len());
        self.poses.iter().for_each(|p| p.write(w));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let header = Header::read(r)?;
        let n = r.sequence("poses", 8 + 4 + 4 + 56, MAX_SEQUENCE)?;
        let poses = (0..n)
            .map(|_| PoseStamped::read(r))
            .collect::<Result<_, _>>()?;
        Ok(Path { header, poses })
    }
}

/// `std_msgs/msg/ColorRGBA`, components 0–1.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Color {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

impl Color {
    fn write(&self, w: &mut CdrWriter) {
        [self.r, self.g, self.b, self.a]
            .iter()
            .for_each(|c| w.f32(*c));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Color {
            r: r.f32("color.r")?,
            g: r.f32("color.g")?,
            b: r.f32("color.b")?,
            a: r.f32("color.a")?,
        })
    }
}

/// `visualization_msgs/msg/Marker` `type` values used here.
pub mod marker {
    /// An arrow from `points[0]` to `points[1]` (or along the pose's x axis).
    pub const ARROW: i32 = 0;
    /// A box of `scale` (full extents).
    pub const CUBE: i32 = 1;
    /// An ellipsoid of diameters `scale`.
    pub const SPHERE: i32 = 2;
    /// A polyline through `points`, width `scale.x`.
    pub const LINE_STRIP: i32 = 4;
    /// Segments between pairs of `points`, width `scale.x`.
    pub const LINE_LIST: i32 = 5;
    /// Small spheres at `points`, diameters `scale`.
    pub const SPHERE_LIST: i32 = 7;
    /// Triangles, three `points` each.
    pub const TRIANGLE_LIST: i32 = 11;
    /// `action`: add or replace.
    pub const ADD: i32 = 0;
    /// `action`: delete every marker (of this namespace in Humble and later: of all).
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/Marker`, with no texture, UV coordinates or embedded mesh file
/// (written empty).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Marker {
    /// Stamp and frame.
    pub header: Header,
    /// Namespace (with `id`, the marker's identity).
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// `marker::*` shape.
    pub kind: i32,
    /// `marker::ADD` or `marker::DELETEALL`.
    pub action: i32,
    /// Pose of the shape in `header.frame_id`.
    pub pose: Pose,
    /// Size, m (meaning depends on `kind`).
    pub scale: [f64; 3],
    /// Colour.
    pub color: Color,
    /// How long it lasts (0: until replaced).
    pub lifetime: Time,
    /// Re-transform with the frame every frame (for markers in moving frames).
    pub frame_locked: bool,
    /// Points, in the marker's pose.
    pub points: Vec<[f64; 3]>,
    /// Per-point colours (empty: `color`).
    pub colors: Vec<Color>,
    /// Text.
    pub text: String,
    /// Mesh file URI.
    pub mesh_resource: String,
}

impl Marker {
    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.string(&self.ns);
        w.i32(self.id);
        w.i32(self.kind);
        w.i32(self.action);
        self.pose.write(w);
        write_vec3(w, &self.scale);
        self.color.write(w);
        w.i32(self.lifetime.sec);
        w.u32(self.lifetime.nanosec);
        w.bool(self.frame_locked);
        w.sequence(self.points.len());
        self.points.iter().for_each(|p| write_vec3(w, p));
        w.sequence(self.colors.len());
        self.colors.iter().for_each(|c| c.write(w));
        w.string(""); // texture_resource
        Header::default().write(w); // texture.header
        w.string(""); // texture.format
        w.bytes(&[]); // texture.data
        w.sequence(0); // uv_coordinates
        w.string(&self.text);
        w.string(&self.mesh_resource);
        w.string(""); // mesh_file.filename
        w.bytes(&[]); // mesh_file.data
        w.bool(false); // mesh_use_embedded_materials
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let header = Header::read(r)?;
        let ns = r.string("ns")?.to_owned();
        let id = r.i32("id")?;
        let kind = r.i32("type")?;
        let action = r.i32("action")?;
        let pose = Pose::read(r)?;
        let scale = read_vec3(r, ["scale.x", "scale.y", "scale.z"])?;
        let color = Color::read(r)?;
        let lifetime = Time {
            sec: r.i32("lifetime.sec")?,
            nanosec: r.u32("lifetime.nanosec")?,
        };
        let frame_locked = r.bool("frame_locked")?;
        let n = r.sequence("points", 24, MAX_SEQUENCE)?;
        let points = (0..n)
            .map(|_| read_vec3(r, ["points.x", "points.y", "points.z"]))
            .collect::<Result<_, _>>()?;
        let n = r.sequence("colors", 16, MAX_SEQUENCE)?;
        let colors = (0..n).map(|_| Color::read(r)).collect::<Result<_, _>>()?;
        r.string("texture_resource")?;
        Header::read(r)?;
        r.string("texture.format")?;
        let n = r.sequence("texture.data", 1, MAX_SEQUENCE)?;
        (0..n).try_for_each(|_| r.u8("texture.data").map(|_| ()))?;
        let n = r.sequence("uv_coordinates", 8, MAX_SEQUENCE)?;
        (0..n).try_for_each(|_| {
            r.f32("uv_coordinates.u")?;
            r.f32("uv_coordinates.v").map(|_| ())
        })?;
        let text = r.string("text")?.to_owned();
        let mesh_resource = r.string("mesh_resource")?.to_owned();
        r.string("mesh_file.filename")?;
        let n = r.sequence("mesh_file.data", 1, MAX_SEQUENCE)?;
        (0..n).try_for_each(|_| r.u8("mesh_file.data").map(|_| ()))?;
        r.bool("mesh_use_embedded_materials")?;
        Ok(Marker {
            header,
            ns,
            id,
            kind,
            action,
            pose,
            scale,
            color,
            lifetime,
            frame_locked,
            points,
            colors,
            text,
            mesh_resource,
        })
    }
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MarkerArray {
    /// The markers, applied in order.
    pub markers: Vec<Marker>,
}

impl Message for MarkerArray {
    const TYPE: &'static MsgType = &MARKER_ARRAY;

    fn write(&self, w: &mut CdrWriter) {
        w.sequence(self.markers.len());
        self.markers.iter().for_each(|m| m.write(w));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let n = r.sequence("markers", 200, MAX_SEQUENCE)?;
        let markers = (0..n).map(|_| Marker::read(r)).collect::<Result<_, _>>()?;
        Ok(MarkerArray { markers })
    }
}

/// `std_msgs/msg/Float64MultiArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Float64MultiArray {
    /// `layout.dim`: (label, size, stride) per dimension.
    pub dims: Vec<(String, u32, u32)>,
    /// `layout.data_offset`.
    pub data_offset: u32,
    /// The values.
    pub data: Vec<f64>,
}

impl Message for Float64MultiArray {
    const TYPE: &'static MsgType = &FLOAT64_MULTI_ARRAY;

    fn write(&self, w: &mut CdrWriter) {
        w.sequence(self.dims.len());
        for (label, size, stride) in &self.dims {
            w.string(label);
            w.u32(*size);
            w.u32(*stride);
        }
        w.u32(self.data_offset);
        w.sequence(self.data.len());
        self.data.iter().for_each(|v| w.f64(*v));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let n = r.sequence("layout.dim", 13, MAX_SEQUENCE)?;
        let dims = (0..n)
            .map(|_| {
                Ok((
                    r.string("layout.dim.label")?.to_owned(),
                    r.u32("layout.dim.size")?,
                    r.u32("layout.dim.stride")?,
                ))
            })
            .collect::<Result<_, CdrError>>()?;
        let data_offset = r.u32("layout.data_offset")?;
        let n = r.sequence("data", 8, MAX_SEQUENCE)?;
        let data = (0..n).map(|_| r.f64("data")).collect::<Result<_, _>>()?;
        Ok(Float64MultiArray {
            dims,
            data_offset,
            data,
        })
    }
}

/// `sensor_msgs/msg/Joy`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Joy {
    /// Stamp and frame.
    pub header: Header,
    /// Axes, −1…1.
    pub axes: Vec<f32>,
    /// Buttons, 1 pressed, 0 not.
    pub buttons: Vec<i32>,
}

impl Joy {
    /// The buttons as the loop's bit mask: bit i set for `buttons[i] != 0`, of the first 32.
    pub fn button_mask(&self) -> u32 {
        self.buttons
            .iter()
            .take(32)
            .enumerate()
            .filter(|(_, b)| **b != 0)
            .fold(0u32, |m, (i, _)| m | (1 << i))
    }
}

impl Message for Joy {
    const TYPE: &'static MsgType = &JOY;

    fn write(&self, w: &mut CdrWriter) {
        self.header.write(w);
        w.sequence(self.axes.len());
        self.axes.iter().for_each(|a| w.f32(*a));
        w.sequence(self.buttons.len());
        self.buttons.iter().for_each(|b| w.i32(*b));
    }

    fn read(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let header = Header::read(r)?;
        let n = r.sequence("axes", 4, MAX_SEQUENCE)?;
        let axes = (0..n).map(|_| r.f32("axes")).collect::<Result<_, _>>()?;
        let n = r.sequence("buttons", 4, MAX_SEQUENCE)?;
        let buttons = (0..n).map(|_| r.i32("buttons")).collect::<Result<_, _>>()?;
        Ok(Joy {
            header,
            axes,
            buttons,
        })
    }
}

#[cfg(test)]
mod tests;
