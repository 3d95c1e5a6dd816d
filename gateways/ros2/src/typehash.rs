//! Message type descriptions and their RIHS01 type hashes (REP-2016), which rmw_zenoh puts in
//! every topic's key expression and liveliness token so that only publishers and subscribers
//! of the same type definition meet.
//!
//! RIHS01 is `RIHS01_` and the lowercase hex SHA-256 of one JSON text: the message's type
//! description and, sorted by type name, every type it refers to (transitively), each as its
//! type name and fields; a field as its name, a numeric type id (ROS IDL's
//! `type_description_interfaces/msg/FieldType`: 1 nested, 2 int8 … 11 float64 … 15 bool,
//! 16 byte, 17 string; +48 for a fixed array, +96 a bounded and +144 an unbounded sequence),
//! capacity, string capacity and nested type name. The JSON is Python's `json.dumps` default
//! form (`", "` and `": "` separators, keys in the order below), as rosidl writes it. Default
//! values and constants are not part of it.

use sha2::{Digest, Sha256};

/// A primitive field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prim {
    /// `bool`.
    Bool,
    /// `uint8`.
    U8,
    /// `int32`.
    I32,
    /// `uint32`.
    U32,
    /// `float32`.
    F32,
    /// `float64`.
    F64,
    /// `string` (unbounded).
    String,
}

impl Prim {
    fn type_id(self) -> u32 {
        match self {
            Prim::U8 => 3,
            Prim::I32 => 6,
            Prim::U32 => 7,
            Prim::F32 => 10,
            Prim::F64 => 11,
            Prim::Bool => 15,
            Prim::String => 17,
        }
    }
}

/// What one element of a field is.
#[derive(Debug, Clone, Copy)]
pub enum Elem {
    /// A primitive.
    Prim(Prim),
    /// A nested message.
    Msg(&'static MsgType),
}

/// How many elements a field holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Count {
    /// One.
    One,
    /// An unbounded sequence.
    Sequence,
}

/// One field of a message.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    /// Its name.
    pub name: &'static str,
    /// Its element type.
    pub elem: Elem,
    /// One or a sequence.
    pub count: Count,
}

impl Field {
    /// A single primitive.
    pub const fn prim(name: &'static str, p: Prim) -> Self {
        Field {
            name,
            elem: Elem::Prim(p),
            count: Count::One,
        }
    }

    /// A single nested message.
    pub const fn msg(name: &'static str, m: &'static MsgType) -> Self {
        Field {
            name,
            elem: Elem::Msg(m),
            count: Count::One,
        }
    }

    /// An unbounded sequence of primitives.
    pub const fn prim_seq(name: &'static str, p: Prim) -> Self {
        Field {
            name,
            elem: Elem::Prim(p),
            count: Count::Sequence,
        }
    }

    /// An unbounded sequence of messages.
    pub const fn msg_seq(name: &'static str, m: &'static MsgType) -> Self {
        Field {
            name,
            elem: Elem::Msg(m),
            count: Count::Sequence,
        }
    }
}

/// A message type: its ROS name (`package/msg/Name`) and fields in order.
#[derive(Debug)]
pub struct MsgType {
    /// `package/msg/Name`, e.g. `geometry_msgs/msg/PoseStamped`.
    pub name: &'static str,
    /// Fields in declaration order.
    pub fields: &'static [Field],
}

impl MsgType {
    /// The name DDS and rmw_zenoh give the type, e.g.
    /// `geometry_msgs::msg::dds_::PoseStamped_`.
    pub fn dds_name(&self) -> String {
        let mut parts: Vec<&str> = self.name.split('/').collect();
        let last = parts.pop().unwrap_or_default();
        let mut s = parts.join("::");
        s.push_str("::dds_::");
        s.push_str(last);
        s.push('_');
        s
    }

    /// The JSON text RIHS01 hashes.
    pub fn hash_input(&'static self) -> String {
        let mut referenced: Vec<&'static MsgType> = Vec::new();
        self.collect_referenced(&mut referenced);
        referenced.retain(|t| t.name != self.name);
        referenced.sort_by_key(|t| t.name);
        let mut s = String::from("{\"type_description\": ");
        self.write_json(&mut s);
        s.push_str(", \"referenced_type_descriptions\": [");
        for (i, t) in referenced.iter().enumerate() {
            if i > 0 {
                s.push_str(", ");
            }
            t.write_json(&mut s);
        }
        s.push_str("]}");
        s
    }

    /// `RIHS01_` and the SHA-256 of [`MsgType::hash_input`], lowercase hex.
    pub fn rihs01(&'static self) -> String {
        let digest = Sha256::digest(self.hash_input().as_bytes());
        let mut s = String::from("RIHS01_");
        for b in digest {
            s.push_str(&format!("{b:02x}"));
        }
        s
    }

    fn collect_referenced(&'static self, out: &mut Vec<&'static MsgType>) {
        for f in self.fields {
            if let Elem::Msg(m) = f.elem
                && !out.iter().any(|t| t.name == m.name)
            {
                out.push(m);
                m.collect_referenced(out);
            }
        }
    }

    fn write_json(&self, s: &mut String) {
        s.push_str("{\"type_name\": ");
        json_string(s, self.name);
        s.push_str(", \"fields\": [");
        for (i, f) in self.fields.iter().enumerate() {
            if i > 0 {
                s.push_str(", ");
            }
            let (id, nested) = match f.elem {
                Elem::Prim(p) => (p.type_id(), ""),
                Elem::Msg(m) => (1, m.name),
            };
            let id = id + if f.count == Count::Sequence { 144 } else { 0 };
            s.push_str("{\"name\": ");
            json_string(s, f.name);
            s.push_str(&format!(
                ", \"type\": {{\"type_id\": {id}, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": "
            ));
            json_string(s, nested);
            s.push_str("}}");
        }
        s.push_str("]}");
    }
}

/// A JSON string literal (names are ASCII identifiers; quotes and backslashes escaped anyway).
fn json_string(s: &mut String, v: &str) {
    s.push('"');
    for c in v.chars() {
        match c {
            '"' => s.push_str("\\\""),
            '\\' => s.push_str("\\\\"),
            c => s.push(c),
        }
    }
    s.push('"');
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs;

    static STRING: MsgType = MsgType {
        name: "std_msgs/msg/String",
        fields: &[Field::prim("data", Prim::String)],
    };

    /// rmw_zenoh's design document gives the `chatter` topic's key with std_msgs/String's
    /// hash; rosbags 0.11.9 computes the others from its own message definitions
    /// (`Typestore.hash_rihs01`, Jazzy store; its Humble and Kilted stores give the same).
    #[test]
    fn hashes_match_the_documented_and_rosbags_values() {
        assert_eq!(
            STRING.rihs01(),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        let expected: [(&'static MsgType, &str); 10] = [
            (
                &msgs::TIME,
                "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
            ),
            (
                &msgs::POSE_STAMPED,
                "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
            ),
            (
                &msgs::WRENCH_STAMPED,
                "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77",
            ),
            (
                &msgs::TWIST_STAMPED,
                "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
            ),
            (
                &msgs::PATH,
                "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b",
            ),
            (
                &msgs::TF_MESSAGE,
                "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
            ),
            (
                &msgs::MARKER_ARRAY,
                "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
            ),
            (
                &msgs::FLOAT64_MULTI_ARRAY,
                "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f",
            ),
            (
                &msgs::JOY,
                "RIHS01_0d356c79cad3401e35ffeb75a96a96e08be3ef896b8b83841d73e890989372c5",
            ),
            (
                &STRING,
                "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
            ),
        ];
        for (t, h) in expected {
            assert_eq!(t.rihs01(), h, "{}", t.name);
        }
    }

    #[test]
    fn the_hash_input_is_python_json_with_sorted_references() {
        let s = msgs::HEADER.hash_input();
        assert_eq!(
            s,
            "{\"type_description\": {\"type_name\": \"std_msgs/msg/Header\", \"fields\": [\
             {\"name\": \"stamp\", \"type\": {\"type_id\": 1, \"capacity\": 0, \"string_capacity\": 0, \
             \"nested_type_name\": \"builtin_interfaces/msg/Time\"}}, {\"name\": \"frame_id\", \"type\": \
             {\"type_id\": 17, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}, \
             \"referenced_type_descriptions\": [{\"type_name\": \"builtin_interfaces/msg/Time\", \"fields\": \
             [{\"name\": \"sec\", \"type\": {\"type_id\": 6, \"capacity\": 0, \"string_capacity\": 0, \
             \"nested_type_name\": \"\"}}, {\"name\": \"nanosec\", \"type\": {\"type_id\": 7, \"capacity\": 0, \
             \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}]}"
        );
        let names: Vec<String> = msgs::MARKER_ARRAY
            .hash_input()
            .match_indices("\"type_name\": \"")
            .map(|(i, m)| {
                let rest = &msgs::MARKER_ARRAY.hash_input()[i + m.len()..];
                rest[..rest.find('"').unwrap()].to_owned()
            })
            .collect();
        let mut sorted = names[1..].to_vec();
        sorted.sort();
        assert_eq!(
            names[1..],
            sorted[..],
            "references sorted by name, each once"
        );
        assert_eq!(names[0], "visualization_msgs/msg/MarkerArray");
    }

    #[test]
    fn dds_names() {
        assert_eq!(
            msgs::POSE_STAMPED.dds_name(),
            "geometry_msgs::msg::dds_::PoseStamped_"
        );
        assert_eq!(STRING.dds_name(), "std_msgs::msg::dds_::String_");
    }
}
