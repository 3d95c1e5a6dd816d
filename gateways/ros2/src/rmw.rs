//! rmw_zenoh's wire, as its design document (`docs/design.md` of ros2/rmw_zenoh, Jazzy and
//! later) states it: topic key expressions, liveliness tokens for nodes and endpoints, the
//! QoS text inside them, the attachment of every sample and entity GIDs.
//!
//! - **Topic key**: `<domain_id>/<fully qualified name without its leading and trailing
//!   '/'>/<DDS type name>/<type hash>`, e.g.
//!   `0/hrrtc/object_pose/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_10f3…`.
//! - **Node token**: `@ros2_lv/<domain>/<session id>/<node id>/<node id>/NN/<enclave>/
//!   <namespace>/<node name>`; **endpoint token**: `@ros2_lv/<domain>/<session id>/<node
//!   id>/<entity id>/<MP|MS>/<enclave>/<namespace>/<node name>/<topic>/<DDS type name>/<type
//!   hash>/<qos>`, names "mangled" (each `/` replaced by `%`; the root namespace and the
//!   default enclave `/` become `%`). The session id is the Zenoh id as Zenoh prints it.
//! - **QoS** (`qos_to_keyexpr`): `<reliability>:<durability>:<history>,<depth>:<deadline s>,
//!   <ns>:<lifespan s>,<ns>:<liveliness>,<lease s>,<ns>`, each number written only where it
//!   differs from rmw_zenoh's default (reliable, volatile, keep last, depth 42, infinite
//!   durations, automatic liveliness); values are the `rmw_qos_*_policy_e` numbers.
//! - **Attachment**: 33 bytes, the sequence number (`i64`, from 1 per publisher) and the
//!   source timestamp (`i64`, ns since the UNIX epoch), little-endian, then the GID's length
//!   as one LEB128 byte (16) and its 16 bytes: zenoh-ext's serialization of
//!   `(i64, i64, [u8; 16])`.
//! - **GID**: the XXH3-128 of the endpoint's liveliness key, low 64 bits then high 64 bits,
//!   each little-endian (`liveliness::Entity` in rmw_zenoh_cpp).
//!
//! Humble's rmw_zenoh has no type hashes and writes `TypeHashNotSupported` where Jazzy
//! writes the RIHS01 hash ([`Distro::Humble`]).

use crate::typehash::MsgType;

/// The admin space of liveliness tokens.
pub const ADMIN_SPACE: &str = "@ros2_lv";
/// Bytes of an attachment.
pub const ATTACHMENT_LEN: usize = 33;
/// rmw_zenoh's default history depth (what depth 0 means).
pub const DEFAULT_DEPTH: u32 = 42;

/// Which ROS 2 distribution's rmw_zenoh to meet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Distro {
    /// Humble: no type hashes (`TypeHashNotSupported`).
    Humble,
    /// Jazzy (the default): RIHS01 type hashes.
    #[default]
    Jazzy,
    /// Kilted: as Jazzy (the messages used here have the same definitions and hashes).
    Kilted,
}

impl Distro {
    /// `humble`, `jazzy` or `kilted`.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "humble" => Some(Distro::Humble),
            "jazzy" => Some(Distro::Jazzy),
            "kilted" => Some(Distro::Kilted),
            _ => None,
        }
    }

    /// The hash this distribution's rmw_zenoh writes for `ty`.
    pub fn type_hash(self, ty: &'static MsgType) -> String {
        match self {
            Distro::Humble => "TypeHashNotSupported".to_owned(),
            Distro::Jazzy | Distro::Kilted => ty.rihs01(),
        }
    }
}

/// A message type as it appears on the wire: DDS name and hash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TypeInfo {
    /// E.g. `geometry_msgs::msg::dds_::PoseStamped_`.
    pub dds_name: String,
    /// `RIHS01_…` or `TypeHashNotSupported`.
    pub hash: String,
}

impl TypeInfo {
    /// `ty` as `distro` writes it.
    pub fn of(ty: &'static MsgType, distro: Distro) -> Self {
        TypeInfo {
            dds_name: ty.dds_name(),
            hash: distro.type_hash(ty),
        }
    }
}

/// QoS reliability (`rmw_qos_reliability_policy_e`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// 1, the default.
    Reliable,
    /// 2.
    BestEffort,
}

/// QoS durability (`rmw_qos_durability_policy_e`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// 1: late subscribers get the last `depth` samples.
    TransientLocal,
    /// 2, the default.
    Volatile,
}

/// The QoS of an endpoint (history keep-last, infinite deadline, lifespan and lease,
/// automatic liveliness: the only other settings used here).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// Keep-last depth (0 means rmw_zenoh's default, 42).
    pub depth: u32,
}

impl Qos {
    /// Reliable, volatile, keep last `depth`.
    pub const fn volatile(depth: u32) -> Self {
        Qos {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            depth,
        }
    }

    /// Reliable, transient local, keep last `depth` (late joiners get the last `depth`).
    pub const fn transient_local(depth: u32) -> Self {
        Qos {
            reliability: Reliability::Reliable,
            durability: Durability::TransientLocal,
            depth,
        }
    }

    /// The depth rmw_zenoh would use (0 → 42).
    pub fn effective_depth(&self) -> u32 {
        if self.depth == 0 {
            DEFAULT_DEPTH
        } else {
            self.depth
        }
    }

    /// The QoS part of a liveliness token (`qos_to_keyexpr`).
    pub fn key(&self) -> String {
        let reliability = match self.reliability {
            Reliability::Reliable => "",
            Reliability::BestEffort => "2",
        };
        let durability = match self.durability {
            Durability::Volatile => "",
            Durability::TransientLocal => "1",
        };
        let depth = match self.effective_depth() {
            DEFAULT_DEPTH => String::new(),
            d => d.to_string(),
        };
        format!("{reliability}:{durability}:,{depth}:,:,:,,")
    }
}

/// What an endpoint does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EndpointKind {
    /// A message publisher, `MP`.
    Publisher,
    /// A message subscription, `MS`.
    Subscription,
}

impl EndpointKind {
    fn code(self) -> &'static str {
        match self {
            EndpointKind::Publisher => "MP",
            EndpointKind::Subscription => "MS",
        }
    }
}

/// A name that is not a valid ROS 2 name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} {name:?}: {reason}")]
pub struct NameError {
    /// What kind of name.
    pub what: &'static str,
    /// As given.
    pub name: String,
    /// The rule it breaks.
    pub reason: &'static str,
}

fn token_error(token: &str) -> Option<&'static str> {
    if token.is_empty() {
        Some("empty token (a doubled or trailing '/')")
    } else if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        Some("only letters, digits and '_' are allowed between '/'")
    } else if token.starts_with(|c: char| c.is_ascii_digit()) {
        Some("a token may not start with a digit")
    } else {
        None
    }
}

/// Checks a node name: letters, digits and `_`, not starting with a digit.
pub fn validate_node_name(name: &str) -> Result<(), NameError> {
    match token_error(name) {
        None => Ok(()),
        Some(reason) => Err(NameError {
            what: "node name",
            name: name.to_owned(),
            reason,
        }),
    }
}

/// Checks an absolute name (`/a/b`): a namespace (`/` alone allowed) or a topic.
pub fn validate_absolute(what: &'static str, name: &str) -> Result<(), NameError> {
    let err = |reason| NameError {
        what,
        name: name.to_owned(),
        reason,
    };
    let Some(rest) = name.strip_prefix('/') else {
        return Err(err("must be absolute (start with '/')"));
    };
    if rest.is_empty() {
        return if what == "namespace" {
            Ok(())
        } else {
            Err(err("empty"))
        };
    }
    match rest.split('/').find_map(token_error) {
        None => Ok(()),
        Some(reason) => Err(err(reason)),
    }
}

/// The fully qualified name of `topic` in `namespace`: itself when absolute.
pub fn qualify(namespace: &str, topic: &str) -> String {
    if topic.starts_with('/') {
        topic.to_owned()
    } else if namespace == "/" {
        format!("/{topic}")
    } else {
        format!("{namespace}/{topic}")
    }
}

/// `/` replaced by `%` (an empty name by `%` too).
pub fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".to_owned()
    } else {
        name.replace('/', "%")
    }
}

/// The key expression of `topic` (fully qualified) of type `ty` on `domain`.
pub fn topic_key(domain: u32, topic: &str, ty: &TypeInfo) -> String {
    format!(
        "{}/{}/{}",
        topic_prefix(domain, topic),
        ty.dds_name,
        ty.hash
    )
}

/// The key expression of `topic` (fully qualified) of any type on `domain`: a subscriber
/// to it also gets samples of the wrong type, so that it can name them.
pub fn topic_key_any_type(domain: u32, topic: &str) -> String {
    format!("{}/*/*", topic_prefix(domain, topic))
}

/// `<domain>/<topic without its outer slashes>`.
fn topic_prefix(domain: u32, topic: &str) -> String {
    let name = topic.strip_prefix('/').unwrap_or(topic);
    let name = name.strip_suffix('/').unwrap_or(name);
    format!("{domain}/{name}")
}

/// A node: the identity its endpoints' tokens carry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeId {
    /// `ROS_DOMAIN_ID`.
    pub domain: u32,
    /// The Zenoh session id, as Zenoh prints it.
    pub session: String,
    /// The node's id within the session.
    pub id: u32,
    /// Absolute namespace (`/` for none).
    pub namespace: String,
    /// Node name.
    pub name: String,
}

impl NodeId {
    fn prefix(&self, entity: u32, kind: &str) -> String {
        format!(
            "{ADMIN_SPACE}/{}/{}/{}/{entity}/{kind}/%/{}/{}",
            self.domain,
            self.session,
            self.id,
            mangle(&self.namespace),
            mangle(&self.name)
        )
    }

    /// The node's liveliness token.
    pub fn token(&self) -> String {
        self.prefix(self.id, "NN")
    }

    /// The liveliness token of an endpoint `entity` of this node on `topic` (fully
    /// qualified).
    pub fn endpoint_token(
        &self,
        entity: u32,
        kind: EndpointKind,
        topic: &str,
        ty: &TypeInfo,
        qos: &Qos,
    ) -> String {
        format!(
            "{}/{}/{}/{}/{}",
            self.prefix(entity, kind.code()),
            mangle(topic),
            mangle(&ty.dds_name),
            mangle(&ty.hash),
            qos.key()
        )
    }
}

/// An endpoint's GID: XXH3-128 of its liveliness token.
pub fn gid(token: &str) -> [u8; 16] {
    let h = twox_hash::XxHash3_128::oneshot(token.as_bytes());
    let mut g = [0u8; 16];
    g[..8].copy_from_slice(&(h as u64).to_le_bytes());
    g[8..].copy_from_slice(&((h >> 64) as u64).to_le_bytes());
    g
}

/// The attachment of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attachment {
    /// From 1 per publisher.
    pub sequence: i64,
    /// When it was published, ns since the UNIX epoch.
    pub source_timestamp_ns: i64,
    /// The publisher's GID.
    pub gid: [u8; 16],
}

/// An attachment that is not rmw_zenoh's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AttachmentError {
    /// No attachment (rmw_zenoh drops such samples too).
    #[error("no attachment (rmw_zenoh samples carry sequence number, timestamp and GID)")]
    Missing,
    /// Not 33 bytes with a GID length of 16.
    #[error(
        "attachment of {len} bytes (GID length byte {gid_len:?}): expected 33 bytes, GID length 16"
    )]
    Malformed {
        /// Bytes.
        len: usize,
        /// Its 17th byte, if any.
        gid_len: Option<u8>,
    },
}

impl Attachment {
    /// Its 33 bytes.
    pub fn encode(&self) -> [u8; ATTACHMENT_LEN] {
        let mut b = [0u8; ATTACHMENT_LEN];
        b[..8].copy_from_slice(&self.sequence.to_le_bytes());
        b[8..16].copy_from_slice(&self.source_timestamp_ns.to_le_bytes());
        b[16] = 16;
        b[17..].copy_from_slice(&self.gid);
        b
    }

    /// An attachment from its bytes.
    pub fn decode(b: Option<&[u8]>) -> Result<Self, AttachmentError> {
        let b = b.ok_or(AttachmentError::Missing)?;
        if b.len() != ATTACHMENT_LEN || b[16] != 16 {
            return Err(AttachmentError::Malformed {
                len: b.len(),
                gid_len: b.get(16).copied(),
            });
        }
        let i64_at = |i: usize| {
            let mut a = [0u8; 8];
            a.copy_from_slice(&b[i..i + 8]);
            i64::from_le_bytes(a)
        };
        let mut gid = [0u8; 16];
        gid.copy_from_slice(&b[17..]);
        Ok(Attachment {
            sequence: i64_at(0),
            source_timestamp_ns: i64_at(8),
            gid,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs;

    fn node() -> NodeId {
        NodeId {
            domain: 2,
            session: "aac3178e146ba6f1fc6e6a4085e77f21".into(),
            id: 0,
            namespace: "/".into(),
            name: "listener".into(),
        }
    }

    static STRING: MsgType = MsgType {
        name: "std_msgs/msg/String",
        fields: &[crate::typehash::Field::prim(
            "data",
            crate::typehash::Prim::String,
        )],
    };

    /// The examples of rmw_zenoh's design document (demo_nodes_cpp, domain 2).
    #[test]
    fn keys_and_tokens_match_the_design_documents_examples() {
        let ty = TypeInfo::of(&STRING, Distro::Jazzy);
        assert_eq!(
            topic_key(0, "/chatter", &ty),
            "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        assert_eq!(
            topic_key(0, "/robot1/chatter", &ty),
            "0/robot1/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        // Any type of the same topic: the same prefix, the type and hash as wildcards.
        assert_eq!(
            topic_key_any_type(0, "/robot1/chatter"),
            "0/robot1/chatter/*/*"
        );
        assert_eq!(
            node().token(),
            "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
        );
        assert_eq!(
            node().endpoint_token(
                10,
                EndpointKind::Subscription,
                "/chatter",
                &ty,
                &Qos::volatile(10)
            ),
            "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,"
        );
        let talker = NodeId {
            session: "8b20917502ee955ac4476e0266340d5c".into(),
            name: "talker".into(),
            ..node()
        };
        assert_eq!(
            talker.endpoint_token(
                10,
                EndpointKind::Publisher,
                "/chatter",
                &ty,
                &Qos::volatile(7)
            ),
            "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,"
        );
    }

    #[test]
    fn qos_text_writes_only_what_differs_from_the_default() {
        assert_eq!(Qos::volatile(42).key(), "::,:,:,:,,");
        assert_eq!(Qos::volatile(0).key(), "::,:,:,:,,");
        assert_eq!(Qos::volatile(1).key(), "::,1:,:,:,,");
        assert_eq!(Qos::transient_local(1).key(), ":1:,1:,:,:,,");
        let best_effort = Qos {
            reliability: Reliability::BestEffort,
            ..Qos::volatile(5)
        };
        assert_eq!(best_effort.key(), "2::,5:,:,:,,");
    }

    #[test]
    fn namespaces_and_humble() {
        let ty = TypeInfo::of(&msgs::POSE_STAMPED, Distro::Humble);
        assert_eq!(ty.hash, "TypeHashNotSupported");
        let n = NodeId {
            namespace: "/lab/hrrtc".into(),
            name: "hrrtc_gateway".into(),
            ..node()
        };
        let topic = qualify(&n.namespace, "object_pose");
        assert_eq!(topic, "/lab/hrrtc/object_pose");
        assert_eq!(
            topic_key(0, &topic, &ty),
            "0/lab/hrrtc/object_pose/geometry_msgs::msg::dds_::PoseStamped_/TypeHashNotSupported"
        );
        assert_eq!(
            n.endpoint_token(3, EndpointKind::Publisher, &topic, &ty, &Qos::volatile(1)),
            "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/3/MP/%/%lab%hrrtc/hrrtc_gateway/%lab%hrrtc%object_pose/geometry_msgs::msg::dds_::PoseStamped_/TypeHashNotSupported/::,1:,:,:,,"
        );
        assert_eq!(qualify("/", "x"), "/x");
        assert_eq!(qualify("/a", "/tf"), "/tf");
    }

    #[test]
    fn names_are_validated() {
        assert!(validate_absolute("namespace", "/").is_ok());
        assert!(validate_absolute("topic", "/arm/pose_1").is_ok());
        for bad in ["arm", "/", "/a//b", "/a/", "/1a", "/a-b"] {
            let e = validate_absolute("topic", bad).unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
        assert!(validate_node_name("hrrtc_gateway").is_ok());
        assert!(validate_node_name("9x").is_err());
        assert!(validate_node_name("a/b").is_err());
    }

    /// The attachment is zenoh-ext's serialization of `(i64, i64, [u8; 16])`, which is what
    /// rmw_zenoh_cpp's `AttachmentData::serialize_to_zbytes` writes with zenoh-cpp's.
    #[test]
    fn the_attachment_is_zenoh_exts_serialization() {
        let a = Attachment {
            sequence: 7,
            source_timestamp_ns: 1_733_312_345_123_456_789,
            gid: core::array::from_fn(|i| i as u8 * 17),
        };
        let ours = a.encode();
        let theirs = zenoh_ext::z_serialize(&(a.sequence, a.source_timestamp_ns, a.gid));
        assert_eq!(ours.to_vec(), theirs.to_bytes().to_vec());
        assert_eq!(Attachment::decode(Some(&ours)), Ok(a));
        assert_eq!(Attachment::decode(None), Err(AttachmentError::Missing));
        assert!(matches!(
            Attachment::decode(Some(&ours[..32])),
            Err(AttachmentError::Malformed { len: 32, .. })
        ));
        let mut bad = ours;
        bad[16] = 15;
        assert!(Attachment::decode(Some(&bad)).is_err());
    }

    /// XXH3-128 as Python's `xxhash` 4.1 computes it (`xxh3_128_intdigest`), for inputs of
    /// every length class of the algorithm (0, 1–3, 4–8, 9–16, 17–128, 129–240, > 240) and a
    /// real token (187 bytes): rmw_zenoh_cpp's GID is this hash of the token.
    #[test]
    fn gids_are_xxh3_128_of_the_token() {
        let expected: [(usize, u128); 16] = [
            (0, 0x99aa06d3014798d86001c324468d497f),
            (1, 0xa6cd5e9392000f6ac44bdff4074eecdb),
            (3, 0xe3b55f57945a17cf5f4299fc161c9cbb),
            (4, 0xeb70bf5fc779e9e6a6111d53e80a3db5),
            (8, 0xe1e4432a62217fe4cfd50c61c8bb98c1),
            (9, 0x16c769d83e4aebce907931979dca3746),
            (16, 0x72950631827607e2842812cc870dcae2),
            (17, 0x685bc458b37d057fc06e233df7729217),
            (100, 0xda95ef16fd9566f329b20ba5f03ec01e),
            (128, 0x14792fc3af88dc6c05321a0b64d67b41),
            (129, 0xdd5e74ac6b45f54ebc30b63382b09a3b),
            (200, 0xcb0395310643ba0edd97e9af3609d9f5),
            (240, 0x65b5be86da5540e7c92b68e16f83bbb6),
            (241, 0x1da1cb61bcb8a2a102e8cd95421c6d02),
            (300, 0x948c8677fbb606fcfdda6967cf021dbc),
            (1000, 0x18bf41bc8229e27733ef703fb2b20ed1),
        ];
        for (n, h) in expected {
            // Python: bytes(range(256))[:n] up to 256, else bytes(i % 251 for i in range(n)).
            let input: Vec<u8> = (0..n)
                .map(|i| if n <= 256 { i as u8 } else { (i % 251) as u8 })
                .collect();
            assert_eq!(twox_hash::XxHash3_128::oneshot(&input), h, "{n} bytes");
        }
        let token = node().endpoint_token(
            10,
            EndpointKind::Subscription,
            "/chatter",
            &TypeInfo::of(&STRING, Distro::Jazzy),
            &Qos::volatile(10),
        );
        assert_eq!(token.len(), 187);
        let h: u128 = 0xe61dca625437c5a655fe0883538a1476;
        let g = gid(&token);
        assert_eq!(g[..8], (h as u64).to_le_bytes());
        assert_eq!(g[8..], ((h >> 64) as u64).to_le_bytes());
    }
}
