//! The latency paths that skip a thread: Zenoh's callback hands a sample straight to the
//! local service. On the loop's host, guidance goes to the loop's relay ([`Direct`]); on a
//! planner's host, the state goes into the local blackboard; and a planner that runs its
//! bridge in its own process puts its guidance on Zenoh from its own thread
//! ([`GuidanceSender`]).

use crate::clock::{HostClock, PeerDelays};
use crate::frame::Kind;
use crate::import::{Incoming, accept};
use crate::report::{Counters, bump};
use crate::session::{declare_error, key, outgoing};
use crate::{BridgeConfig, BridgeError, Side, lock};
use ipc_types::services;
use ipc_types::{Guidance, HapticState};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use zenoh::Wait;
use zenoh::pubsub::Subscriber;

/// The side's direct path, declared on the session; dropped in a safe order (the
/// subscribers before the ports and writer their callbacks hold, the writer before its
/// node).
pub(crate) struct Direct {
    /// Loop side: the guidance subscriber and the ports its callback sends to.
    _guidance: Option<(Subscriber<()>, Arc<GuidancePorts>)>,
    /// Planner side: the state subscriber (its callback holds the blackboard's writer).
    _state: Option<Subscriber<()>>,
    /// The writer's node.
    _state_node: Option<(iceoryx2::node::Node<services::Ipc>, usize)>,
}

impl Direct {
    /// Guidance into the loop's relay ([`Side::Loop`]) or the state into the local
    /// blackboard ([`Side::Planner`]), from Zenoh's callbacks.
    pub(crate) fn declare(
        config: &BridgeConfig,
        counters: &Arc<Counters>,
        delays: &Arc<Mutex<PeerDelays>>,
        session: &zenoh::Session,
    ) -> Result<Self, BridgeError> {
        let keys = config.keys();
        match config.side {
            Side::Loop => Ok(Direct {
                _guidance: Some(direct_guidance(
                    config,
                    keys,
                    counters.clone(),
                    delays.clone(),
                    session,
                )?),
                _state: None,
                _state_node: None,
            }),
            Side::Planner => {
                let node = services::create_node(&format!("bridge_state_{}", std::process::id()))?;
                let state = direct_state(
                    config,
                    &node.0,
                    keys,
                    counters.clone(),
                    delays.clone(),
                    session,
                )?;
                Ok(Direct {
                    _guidance: None,
                    _state: Some(state),
                    _state_node: Some(node),
                })
            }
        }
    }
}

/// Puts a planner's guidance on Zenoh from the planner's own thread ([`run_in_planner`]).
#[derive(Clone)]
pub struct GuidanceSender {
    pub(crate) publisher: Arc<zenoh::pubsub::Publisher<'static>>,
    pub(crate) clock: HostClock,
    pub(crate) id: u64,
    pub(crate) counters: Arc<Counters>,
}

impl GuidanceSender {
    /// Sends `g` (re-stamped into the presented clock) to the loop's host; never waits on
    /// the network: a sample Zenoh cannot take at once is dropped and counted. `false` if
    /// it was dropped.
    pub fn send(&self, g: &Guidance) -> bool {
        let sent = self
            .publisher
            .put(outgoing(*g, &self.clock, self.id))
            .wait()
            .is_ok();
        let counter = if sent {
            &self.counters.sent
        } else {
            &self.counters.dropped
        };
        bump(counter, Kind::GUIDANCE);
        sent
    }
}

/// The loop side's guidance path: a Zenoh subscriber whose callback checks, re-stamps and
/// sends each sample to the local guidance service and notifies the relay. Dropping the
/// returned pair undeclares the subscriber, then closes the ports.
fn direct_guidance(
    config: &BridgeConfig,
    keys: &str,
    counters: Arc<Counters>,
    delays: Arc<Mutex<PeerDelays>>,
    session: &zenoh::Session,
) -> Result<(zenoh::pubsub::Subscriber<()>, Arc<GuidancePorts>), BridgeError> {
    let ports = Arc::new(GuidancePorts {
        inlet: services::GuidanceInlet::open(
            &format!("bridge_guidance_{}", std::process::id()),
            &config.namespace,
        )?,
        last_warning: Mutex::new(None),
    });
    let k = key(keys, "guidance");
    let out = ports.clone();
    let sub = session
        .declare_subscriber(&k)
        .callback(move |sample| {
            let incoming = Incoming::arrived(&sample);
            bump(&counters.received, Kind::GUIDANCE);
            let mut warned = lock(&out.last_warning);
            if let Some((_, g)) = accept::<Guidance>(&incoming, &counters, &delays, &mut warned) {
                if out.inlet.send(g) {
                    bump(&counters.delivered, Kind::GUIDANCE);
                } else {
                    bump(&counters.dropped, Kind::GUIDANCE);
                }
            }
        })
        .wait()
        .map_err(declare_error(&k))?;
    Ok((sub, ports))
}

/// The planner side's state path: a Zenoh subscriber whose callback checks and re-stamps
/// each sample and writes it to the local `HapticState` blackboard as its writer (the pid
/// is this bridge's: readers check the writer's liveness by it). Dropping the subscriber
/// drops the writer; `node` must outlive both.
fn direct_state(
    config: &BridgeConfig,
    node: &iceoryx2::node::Node<services::Ipc>,
    keys: &str,
    counters: Arc<Counters>,
    delays: Arc<Mutex<PeerDelays>>,
    session: &zenoh::Session,
) -> Result<zenoh::pubsub::Subscriber<()>, BridgeError> {
    let writer = Mutex::new(services::state_writer(node, &config.namespace)?);
    let warned = Mutex::new(None);
    let pid = std::process::id();
    let k = key(keys, "state");
    session
        .declare_subscriber(&k)
        .callback(move |sample| {
            let incoming = Incoming::arrived(&sample);
            bump(&counters.received, Kind::STATE);
            if let Some((_, mut s)) =
                accept::<HapticState>(&incoming, &counters, &delays, &mut lock(&warned))
            {
                s.header.writer_pid = pid;
                lock(&writer).update_with_copy(s);
                bump(&counters.delivered, Kind::STATE);
            }
        })
        .wait()
        .map_err(declare_error(&k))
}

/// The loop side's guidance ports, shared with Zenoh's callback threads.
struct GuidancePorts {
    inlet: services::GuidanceInlet,
    last_warning: Mutex<Option<Instant>>,
}
