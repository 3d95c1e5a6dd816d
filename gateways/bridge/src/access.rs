//! Who may do what on a bridge's keys: Zenoh's own access control, built from
//! `--allow-peer` (certificate common names, matched on mutually authenticated TLS links).
//! Everything not allowed here is denied, for every other peer and every other key.
//!
//! | side | allowed peers may put to this host | this host puts to them |
//! |---|---|---|
//! | loop | guidance, paths, roadmaps | the state |
//! | planner | the state | guidance, paths, roadmaps |
//!
//! Both ways: the probes (`bridge/ping`, `bridge/pong`), and declaring subscribers on the
//! namespace's keys (without which Zenoh routes no sample to a subscriber of the other
//! side).

use crate::Side;
use crate::session::key;
use serde_json::json;

/// The `access_control` section (JSON) for `side` on key namespace `keys`, allowing the
/// peers whose certificates' common names are `allowed`.
pub(crate) fn access_control(side: Side, keys: &str, allowed: &[String]) -> String {
    let keys_of =
        |leaves: &[&str]| -> Vec<String> { leaves.iter().map(|l| key(keys, l)).collect() };
    let from_planners = keys_of(&["guidance", "path", "roadmap"]);
    let from_loop = keys_of(&["state"]);
    let (ingress, egress) = match side {
        Side::Loop => (from_planners, from_loop),
        Side::Planner => (from_loop, from_planners),
    };
    let rule = |id: &str, messages: &[&str], flows: &[&str], key_exprs: Vec<String>| {
        json!({
            "id": id,
            "messages": messages,
            "flows": flows,
            "permission": "allow",
            "key_exprs": key_exprs,
        })
    };
    json!({
        "enabled": true,
        "default_permission": "deny",
        "rules": [
            rule("hrrtc-in", &["put"], &["ingress"], ingress),
            rule("hrrtc-out", &["put"], &["egress"], egress),
            rule(
                "hrrtc-probes",
                &["put"],
                &["ingress", "egress"],
                keys_of(&["bridge/ping", "bridge/pong"]),
            ),
            rule(
                "hrrtc-subscribers",
                &["declare_subscriber"],
                &["ingress", "egress"],
                vec![key(keys, "**")],
            ),
        ],
        "subjects": [{ "id": "allowed-peers", "cert_common_names": allowed }],
        "policies": [{
            "id": "allowed-peers",
            "rules": ["hrrtc-in", "hrrtc-out", "hrrtc-probes", "hrrtc-subscribers"],
            "subjects": ["allowed-peers"],
        }],
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Zenoh takes the section, and it allows what the side needs and nothing else.
    #[test]
    fn each_side_lets_its_peer_put_only_what_it_receives() {
        for side in [Side::Loop, Side::Planner] {
            let acl = access_control(side, "lab", &["planner-1".into(), "planner-2".into()]);
            let mut z = zenoh::Config::default();
            z.insert_json5("access_control", &acl)
                .unwrap_or_else(|e| panic!("{acl}: {e}"));
            let v: serde_json::Value = serde_json::from_str(&acl).unwrap();
            let keys_of = |id: &str| -> Vec<String> {
                let rules = v["rules"].as_array().unwrap();
                let r = rules.iter().find(|r| r["id"] == id).unwrap();
                serde_json::from_value(r["key_exprs"].clone()).unwrap()
            };
            let (inbound, outbound) = (keys_of("hrrtc-in"), keys_of("hrrtc-out"));
            let state = vec!["hrrtc/lab/state".to_owned()];
            let planners = ["guidance", "path", "roadmap"].map(|l| format!("hrrtc/lab/{l}"));
            match side {
                Side::Loop => {
                    assert_eq!(inbound, planners);
                    assert_eq!(outbound, state);
                }
                Side::Planner => {
                    assert_eq!(inbound, state);
                    assert_eq!(outbound, planners);
                }
            }
            assert_eq!(v["default_permission"], "deny");
            assert_eq!(
                v["subjects"][0]["cert_common_names"],
                json!(["planner-1", "planner-2"])
            );
        }
    }
}
