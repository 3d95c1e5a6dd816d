//! A ROS 2 node on rmw_zenoh's wire: a Zenoh session configured as rmw_zenoh configures its
//! own, the node's liveliness token, and publishers and subscriptions that declare their
//! endpoint tokens and put or check the attachment (see [`crate::rmw`]).
//!
//! Session settings are rmw_zenoh's defaults (`DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5`): peer
//! mode, connect to the router on `tcp/localhost:7447`, listen on `tcp/localhost:0`, no
//! multicast scouting, gossip scouting to the router, timestamps on data. With the router
//! (`ros2 run rmw_zenoh_cpp rmw_zenohd`) ROS 2 nodes on this host then reach us peer to peer.
//! The router need not run when we start: the connection is retried in the background.
//!
//! A `TRANSIENT_LOCAL` publisher is, as in rmw_zenoh, zenoh-ext's advanced publisher with a
//! cache of `depth` samples, publisher detection and (reliable) sporadic heartbeats every
//! 500 ms, so rmw_zenoh's advanced subscribers that join late query the cache.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicI64, AtomicU32, AtomicU64, Ordering};
use std::time::Duration;

use zenoh::Wait;
use zenoh::qos::CongestionControl;
use zenoh_ext::{AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

use crate::msgs::Message;
use crate::rmw::{
    self, Attachment, Distro, Durability, EndpointKind, NodeId, Qos, Reliability, TypeInfo,
};

/// The Zenoh side of a participant.
#[derive(Debug, Clone)]
pub struct SessionConfig {
    /// `ROS_DOMAIN_ID`.
    pub domain: u32,
    /// Endpoints to connect to (the rmw_zenoh router, or peers), given explicitly; `None`:
    /// the Zenoh file's, else rmw_zenoh's router on `tcp/localhost:7447`.
    pub connect: Option<Vec<String>>,
    /// Endpoints to listen on, given explicitly; `None`: the file's, else
    /// `tcp/localhost:0`.
    pub listen: Option<Vec<String>>,
    /// Whose rmw_zenoh to meet.
    pub distro: Distro,
    /// The Zenoh file (rmw_zenoh's `ZENOH_SESSION_CONFIG_URI`), TLS, `--insecure`.
    pub security: zenoh_session::Security,
}

impl Default for SessionConfig {
    /// Domain 0, rmw_zenoh's router on this host (plain TCP: refused unless
    /// `security.insecure`), Jazzy.
    fn default() -> Self {
        SessionConfig {
            domain: 0,
            connect: None,
            listen: None,
            distro: Distro::Jazzy,
            security: zenoh_session::Security::default(),
        }
    }
}

impl SessionConfig {
    /// Plain TCP on these endpoints, `--insecure` (tests on one machine).
    pub fn insecure(listen: Vec<String>, connect: Vec<String>) -> Self {
        SessionConfig {
            listen: Some(listen),
            connect: Some(connect),
            security: zenoh_session::Security {
                insecure: true,
                ..zenoh_session::Security::default()
            },
            ..SessionConfig::default()
        }
    }
}

/// What can go wrong setting a participant up.
#[derive(Debug, thiserror::Error)]
pub enum RosError {
    /// A bad name.
    #[error(transparent)]
    Name(#[from] rmw::NameError),
    /// A Zenoh endpoint does not parse, the session could not be opened (e.g. a listen
    /// endpoint is taken), or a publisher, subscriber or token could not be declared.
    #[error(transparent)]
    Zenoh(#[from] zenoh_session::SessionError),
}

/// The error of declaring something on `key`.
pub(crate) fn declare_error(key: &str) -> impl FnOnce(zenoh::Error) -> RosError + '_ {
    move |e| zenoh_session::declare_error(key)(e).into()
}

/// Opens a Zenoh session with rmw_zenoh's session settings (below the user's Zenoh file),
/// these endpoints and this security; the verdict says what it listens on and connects to.
pub fn open_session(
    config: &SessionConfig,
) -> Result<(zenoh::Session, zenoh_session::Verdict), RosError> {
    let settings = zenoh_session::Settings {
        defaults: vec![
            ("connect/endpoints", "[\"tcp/localhost:7447\"]".to_owned()),
            ("listen/endpoints", "[\"tcp/localhost:0\"]".to_owned()),
            // Start without the router and keep trying to reach it in the background, as
            // an rmw_zenoh peer does (an infinite timeout without exit on failure: zenoh
            // then connects in the background; a zero timeout would try once).
            ("connect/timeout_ms", "-1".to_owned()),
            ("connect/exit_on_failure", "false".to_owned()),
            ("connect/retry", zenoh_session::RETRY.to_owned()),
            ("scouting/multicast/enabled", "false".to_owned()),
            ("scouting/gossip/enabled", "true".to_owned()),
            (
                "scouting/gossip/target",
                "{router: [\"router\", \"peer\"], peer: [\"router\"]}".to_owned(),
            ),
            (
                "timestamping/enabled",
                "{router: true, peer: true, client: true}".to_owned(),
            ),
            ("queries_default_timeout", "60000".to_owned()),
        ],
        listen: config.listen.clone(),
        connect: config.connect.clone(),
        overrides: Vec::new(),
        security: config.security.clone(),
    };
    Ok(zenoh_session::open(&settings)?)
}

/// A subscription's Zenoh subscriber (declared by the caller, see
/// [`Participant::subscription_token`]) and its endpoint token; dropping it undeclares both.
pub type Subscription = (
    zenoh::pubsub::Subscriber<()>,
    zenoh::liveliness::LivelinessToken,
);

/// A ROS 2 node: a Zenoh session, its node token and the ids of its endpoints.
pub struct Participant {
    session: zenoh::Session,
    node: NodeId,
    distro: Distro,
    next_entity: AtomicU32,
    links: zenoh_session::Verdict,
    _token: zenoh::liveliness::LivelinessToken,
}

impl std::fmt::Debug for Participant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Participant")
            .field("node", &self.node)
            .field("distro", &self.distro)
            .finish()
    }
}

impl Participant {
    /// A node `name` in `namespace` (absolute, `/` for none) on a session opened with
    /// `config`, its liveliness token declared.
    pub fn open(config: &SessionConfig, namespace: &str, name: &str) -> Result<Self, RosError> {
        rmw::validate_absolute("namespace", namespace)?;
        rmw::validate_node_name(name)?;
        let (session, links) = open_session(config)?;
        let node = NodeId {
            domain: config.domain,
            session: session.zid().to_string(),
            id: 0,
            namespace: namespace.to_owned(),
            name: name.to_owned(),
        };
        let key = node.token();
        let token = session
            .liveliness()
            .declare_token(key.clone())
            .wait()
            .map_err(declare_error(&key))?;
        Ok(Participant {
            session,
            node,
            distro: config.distro,
            next_entity: AtomicU32::new(1),
            links,
            _token: token,
        })
    }

    /// The node's identity (its token is [`NodeId::token`]).
    pub fn node(&self) -> &NodeId {
        &self.node
    }

    /// The Zenoh session.
    pub fn session(&self) -> &zenoh::Session {
        &self.session
    }

    /// What the session listens on and connects to, and whether every link is mutual TLS.
    pub fn links(&self) -> &zenoh_session::Verdict {
        &self.links
    }

    /// The distribution met.
    pub fn distro(&self) -> Distro {
        self.distro
    }

    /// The fully qualified name of `topic` (relative to the node's namespace, or absolute).
    pub fn qualify(&self, topic: &str) -> String {
        rmw::qualify(&self.node.namespace, topic)
    }

    /// Declares a publisher of `M` on `topic` with `qos`; `express` sends each sample at once
    /// rather than batching (for small, frequent samples).
    pub fn publisher<M: Message>(
        &self,
        topic: &str,
        qos: Qos,
        express: bool,
    ) -> Result<RosPublisher<M>, RosError> {
        let topic = self.qualify(topic);
        rmw::validate_absolute("topic", &topic)?;
        let ty = TypeInfo::of(M::TYPE, self.distro);
        let key = rmw::topic_key(self.node.domain, &topic, &ty);
        let entity = self.next_entity.fetch_add(1, Ordering::Relaxed);
        let token_key =
            self.node
                .endpoint_token(entity, EndpointKind::Publisher, &topic, &ty, &qos);
        let builder = self
            .session
            .declare_publisher(key.clone())
            .congestion_control(CongestionControl::Drop)
            .reliability(match qos.reliability {
                Reliability::Reliable => zenoh::qos::Reliability::Reliable,
                Reliability::BestEffort => zenoh::qos::Reliability::BestEffort,
            })
            .express(express);
        let inner = match qos.durability {
            Durability::Volatile => Inner::Plain(builder.wait().map_err(declare_error(&key))?),
            Durability::TransientLocal => {
                let mut b = builder
                    .cache(CacheConfig::default().max_samples(qos.effective_depth() as usize))
                    .publisher_detection();
                if qos.reliability == Reliability::Reliable {
                    b = b.sample_miss_detection(
                        MissDetectionConfig::default()
                            .sporadic_heartbeat(Duration::from_millis(500)),
                    );
                }
                Inner::Advanced(b.wait().map_err(declare_error(&key))?)
            }
        };
        let token = self
            .session
            .liveliness()
            .declare_token(token_key.clone())
            .wait()
            .map_err(declare_error(&token_key))?;
        Ok(RosPublisher {
            inner,
            gid: rmw::gid(&token_key),
            topic,
            key,
            token_key,
            sequence: AtomicI64::new(1),
            sent: AtomicU64::new(0),
            failed: AtomicU64::new(0),
            _token: token,
            _message: PhantomData,
        })
    }

    /// Declares a subscription's endpoint token for `M` on `topic` with `qos` and returns
    /// `(fully qualified topic, its key, the token)`: the caller declares the Zenoh
    /// subscriber (on the key, or on `<domain>/<topic>/*/*` to also see other types).
    pub fn subscription_token<M: Message>(
        &self,
        topic: &str,
        qos: Qos,
    ) -> Result<(String, String, zenoh::liveliness::LivelinessToken), RosError> {
        let topic = self.qualify(topic);
        rmw::validate_absolute("topic", &topic)?;
        let ty = TypeInfo::of(M::TYPE, self.distro);
        let key = rmw::topic_key(self.node.domain, &topic, &ty);
        let entity = self.next_entity.fetch_add(1, Ordering::Relaxed);
        let token_key =
            self.node
                .endpoint_token(entity, EndpointKind::Subscription, &topic, &ty, &qos);
        let token = self
            .session
            .liveliness()
            .declare_token(token_key.clone())
            .wait()
            .map_err(declare_error(&token_key))?;
        Ok((topic, key, token))
    }

    /// Undeclares everything and closes the session.
    pub fn close(self) {
        let _ = self.session.close().wait();
    }
}

enum Inner {
    Plain(zenoh::pubsub::Publisher<'static>),
    Advanced(zenoh_ext::AdvancedPublisher<'static>),
}

/// A publisher of `M` on one topic: each sample CDR-encoded, with its attachment.
pub struct RosPublisher<M> {
    inner: Inner,
    gid: [u8; 16],
    topic: String,
    key: String,
    token_key: String,
    sequence: AtomicI64,
    sent: AtomicU64,
    failed: AtomicU64,
    _token: zenoh::liveliness::LivelinessToken,
    _message: PhantomData<fn(&M)>,
}

impl<M> std::fmt::Debug for RosPublisher<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RosPublisher")
            .field("key", &self.key)
            .finish()
    }
}

impl<M: Message> RosPublisher<M> {
    /// Publishes `msg`, stamped `source_timestamp_ns` (ns since the UNIX epoch) in its
    /// attachment; never waits on the network (a sample Zenoh cannot take is dropped).
    /// `false` when it was not sent.
    pub fn publish(&self, msg: &M, source_timestamp_ns: i64) -> bool {
        self.publish_payload(msg.encode(), source_timestamp_ns)
    }

    /// Publishes an encoded payload of `M` (see [`RosPublisher::publish`]).
    pub fn publish_payload(&self, payload: Vec<u8>, source_timestamp_ns: i64) -> bool {
        let attachment = Attachment {
            sequence: self.sequence.fetch_add(1, Ordering::Relaxed),
            source_timestamp_ns,
            gid: self.gid,
        }
        .encode();
        let ok = match &self.inner {
            Inner::Plain(p) => p.put(payload).attachment(attachment.to_vec()).wait(),
            Inner::Advanced(p) => p.put(payload).attachment(attachment.to_vec()).wait(),
        }
        .is_ok();
        let counter = if ok { &self.sent } else { &self.failed };
        counter.fetch_add(1, Ordering::Relaxed);
        ok
    }

    /// The fully qualified topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Its key expression.
    pub fn key(&self) -> &str {
        &self.key
    }

    /// Its liveliness token.
    pub fn token_key(&self) -> &str {
        &self.token_key
    }

    /// Samples put, samples Zenoh refused.
    pub fn counts(&self) -> (u64, u64) {
        (
            self.sent.load(Ordering::Relaxed),
            self.failed.load(Ordering::Relaxed),
        )
    }
}
