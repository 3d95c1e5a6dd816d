use super::*;
use std::path::Path;

/// A folder of its own for a test's files.
fn folder(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("zenoh-session-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A lab: a CA and leaves it signed, written as PEM files into `dir`; the leaves' SANs are
/// 127.0.0.1 and their CN their name.
struct Lab {
    ca: PathBuf,
    issuer: rcgen::Issuer<'static, rcgen::KeyPair>,
    dir: PathBuf,
}

impl Lab {
    fn new(dir: &Path, tag: &str) -> Self {
        let mut params = rcgen::CertificateParams::new(Vec::<String>::new()).unwrap();
        params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
        params
            .distinguished_name
            .push(rcgen::DnType::CommonName, format!("test CA {tag}"));
        params.key_usages = vec![
            rcgen::KeyUsagePurpose::KeyCertSign,
            rcgen::KeyUsagePurpose::CrlSign,
        ];
        let key = rcgen::KeyPair::generate().unwrap();
        let cert = params.self_signed(&key).unwrap();
        let ca = write(dir, &format!("{tag}-ca.pem"), &cert.pem());
        Lab {
            ca,
            issuer: rcgen::Issuer::new(params, key),
            dir: dir.to_owned(),
        }
    }

    fn host(&self, name: &str) -> TlsFiles {
        let mut params = rcgen::CertificateParams::new(vec!["127.0.0.1".to_owned()]).unwrap();
        params
            .distinguished_name
            .push(rcgen::DnType::CommonName, name);
        let key = rcgen::KeyPair::generate().unwrap();
        let cert = params.signed_by(&key, &self.issuer).unwrap();
        TlsFiles {
            ca: self.ca.clone(),
            cert: write(&self.dir, &format!("{name}.pem"), &cert.pem()),
            key: write(&self.dir, &format!("{name}.key"), &key.serialize_pem()),
        }
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Settings of a peer on explicit endpoints with `security`, connecting fails fast.
fn peer(listen: &[String], connect: &[String], security: Security) -> Settings {
    Settings {
        defaults: vec![
            ("scouting/multicast/enabled", "false".into()),
            ("connect/timeout_ms", "5000".into()),
            ("connect/exit_on_failure", "true".into()),
        ],
        listen: Some(listen.to_vec()),
        connect: Some(connect.to_vec()),
        overrides: Vec::new(),
        security,
    }
}

fn mtls(files: TlsFiles) -> Security {
    Security {
        tls: Some(files),
        ..Security::default()
    }
}

#[test]
fn a_bad_endpoint_is_named() {
    let s = Settings {
        connect: Some(vec!["tcp/localhost:7447".into(), "nonsense".into()]),
        ..Settings::default()
    };
    match open(&s) {
        Err(SessionError::Endpoint { endpoint, .. }) => assert_eq!(endpoint, "nonsense"),
        other => panic!("expected the endpoint named, got {other:?}"),
    }
}

#[test]
fn a_bad_setting_is_named() {
    let s = Settings {
        defaults: vec![("connect/timeout_ms", "\"soon\"".into())],
        ..Settings::default()
    };
    let e = open(&s).expect_err("a string timeout is refused");
    assert!(e.to_string().contains("connect/timeout_ms"), "{e}");
}

#[test]
fn plain_tcp_is_refused_unless_insecure_loopback_included() {
    for (listen, connect) in [
        (vec!["tcp/127.0.0.1:0".to_owned()], vec![]),
        (vec![], vec!["tcp/127.0.0.1:7447".to_owned()]),
        (vec!["udp/127.0.0.1:0".to_owned()], vec![]),
    ] {
        let s = peer(&listen, &connect, Security::default());
        let e = open(&s).expect_err("plain links are refused").to_string();
        assert!(matches!(open(&s), Err(SessionError::Insecure(_))), "{e}");
        for named in [
            "--tls-ca",
            "--tls-cert",
            "--tls-key",
            "--insecure",
            "given on",
        ] {
            assert!(e.contains(named), "{named} not in: {e}");
        }
    }
    let prefixed = Security {
        flag_prefix: "bridge-",
        ..Security::default()
    };
    let e = open(&peer(&["tcp/127.0.0.1:0".into()], &[], prefixed)).expect_err("refused");
    assert!(e.to_string().contains("--bridge-insecure"), "{e}");
    // With --insecure the same session opens, and says so.
    let insecure = Security {
        insecure: true,
        ..Security::default()
    };
    assert!(insecure.describe().contains("INSECURE"));
    let (session, verdict) =
        open(&peer(&["tcp/127.0.0.1:0".into()], &[], insecure)).expect("opens");
    assert!(!verdict.mutual_tls);
    drop(session);
}

/// A file that names no `listen` gets Zenoh's own default (plain TCP on every interface,
/// `tcp/[::]:0`): the merged configuration is judged, so it is refused though no flag asked
/// for TCP.
#[test]
fn a_file_without_listen_is_judged_by_zenohs_default() {
    let dir = folder("nolisten");
    let file = write(
        &dir,
        "z.json5",
        "{ mode: 'peer', scouting: { multicast: { enabled: false } } }",
    );
    let s = Settings {
        security: Security {
            zenoh_config: Some(file),
            ..Security::default()
        },
        ..Settings::default()
    };
    let e = open(&s).expect_err("tcp/[::]:0 is refused").to_string();
    assert!(e.contains("tcp/[::]:0"), "{e}");
}

#[test]
fn defaults_then_file_then_flags() {
    let dir = folder("precedence");
    let file = write(
        &dir,
        "z.json5",
        "// rmw_zenoh's files have comments\n{ connect: { endpoints: ['tls/10.0.0.1:7447'] }, \
         scouting: { multicast: { enabled: false } }, }",
    );
    let mut s = Settings {
        defaults: vec![
            ("connect/endpoints", "[\"tcp/localhost:7447\"]".into()),
            ("listen/endpoints", "[]".into()),
            ("queries_default_timeout", "60000".into()),
        ],
        security: Security {
            zenoh_config: Some(file),
            insecure: true,
            ..Security::default()
        },
        ..Settings::default()
    };
    let connect = |s: &Settings| {
        let built = build(s).unwrap();
        (
            built.config.get_json("connect/endpoints").unwrap(),
            built.connect,
            built.config.get_json("queries_default_timeout").unwrap(),
        )
    };
    // The file replaces the default endpoint; a default it does not name stays.
    assert_eq!(
        connect(&s),
        (
            "[\"tls/10.0.0.1:7447\"]".into(),
            Origin::File,
            "60000".into()
        )
    );
    // A flag given replaces the file's.
    s.connect = Some(vec!["tls/10.0.0.2:7447".into()]);
    assert_eq!(connect(&s).0, "[\"tls/10.0.0.2:7447\"]");
    assert_eq!(connect(&s).1, Origin::Flag);
}

#[test]
fn the_files_errors_name_the_file_and_key() {
    let dir = folder("badfile");
    let key = write(
        &dir,
        "key.json5",
        "{ transport: { link: { tls: { enable_mtls: 'yes' } } } }",
    );
    let syntax = write(
        &dir,
        "syntax.json5",
        "{ mode: 'peer',\n  listen: { endpoints: [ }\n}",
    );
    let missing = dir.join("missing.json5");
    for (file, expect) in [
        (&key, "transport/link/tls/enable_mtls"),
        (&syntax, "--> 2:26"),
        (&missing, "No such file"),
    ] {
        let s = Settings {
            security: Security {
                zenoh_config: Some(file.clone()),
                ..Security::default()
            },
            ..Settings::default()
        };
        let e = build(&s).expect_err("refused").to_string();
        assert!(e.contains(&file.display().to_string()), "{e}");
        assert!(e.contains(expect), "{expect} not in: {e}");
    }
}

#[test]
fn tls_flags_are_checked_and_restrict_the_links_to_tls() {
    let dir = folder("flags");
    let lab = Lab::new(&dir, "flags");
    let files = lab.host("loop");
    // A missing key file is named with its flag.
    let mut bad = files.clone();
    bad.key = dir.join("nope.key");
    let e = build(&peer(&["tls/127.0.0.1:0".into()], &[], mtls(bad))).expect_err("refused");
    assert!(e.to_string().contains("--tls-key"), "{e}");
    // A certificate given as the key is not a key.
    let mut swapped = files.clone();
    swapped.key = files.cert.clone();
    let e = build(&peer(&["tls/127.0.0.1:0".into()], &[], mtls(swapped))).expect_err("refused");
    assert!(e.to_string().contains("not a PEM"), "{e}");
    // Good flags: judged mutual TLS, and only TLS links may be opened.
    let mut built = build(&peer(&["tls/127.0.0.1:0".into()], &[], mtls(files.clone()))).unwrap();
    let verdict = judge(&mut built, &mtls(files.clone())).unwrap();
    assert!(verdict.mutual_tls);
    assert_eq!(
        built.config.get_json("transport/link/protocols").unwrap(),
        "[\"tls\",\"quic\"]"
    );
    // A file that opens other protocols beside TLS is refused, naming the key.
    let file = write(
        &dir,
        "protocols.json5",
        "{ transport: { link: { protocols: ['tls', 'tcp'] } } }",
    );
    let security = Security {
        zenoh_config: Some(file),
        ..mtls(files.clone())
    };
    let e = open(&peer(&["tls/127.0.0.1:0".into()], &[], security)).expect_err("refused");
    assert!(e.to_string().contains("transport/link/protocols"), "{e}");
    // TLS without client certificates required is not mutual: refused.
    let file = write(
        &dir,
        "onesided.json5",
        "{ transport: { link: { tls: { enable_mtls: false } } } }",
    );
    let mut s = peer(&["tls/127.0.0.1:0".into()], &[], Security::default());
    s.security.zenoh_config = Some(file);
    s.overrides = vec![(
        "transport/link/tls/root_ca_certificate",
        serde_json::to_string(&files.ca).unwrap(),
    )];
    let e = open(&s).expect_err("refused").to_string();
    assert!(e.contains("enable_mtls"), "{e}");
}

/// Two hosts of one lab connect over mutual TLS and a sample crosses; a host whose
/// certificate another CA signed, or that presents none, cannot open its session (its one
/// connect endpoint never completes a handshake).
#[test]
fn mutual_tls_lets_the_lab_in_and_keeps_others_out() {
    let dir = folder("mtls");
    let lab = Lab::new(&dir, "lab");
    let other = Lab::new(&dir, "other");
    let port = free_port();
    let endpoint = vec![format!("tls/127.0.0.1:{port}")];
    let (a, _) = open(&peer(&endpoint, &[], mtls(lab.host("loop")))).expect("listens");
    let got = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(0));
    let counter = got.clone();
    let _sub = a
        .declare_subscriber("zs/test")
        .callback(move |_| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .wait()
        .unwrap();
    let (b, verdict) = open(&peer(&[], &endpoint, mtls(lab.host("planner")))).expect("connects");
    assert_eq!(verdict.connect, endpoint);
    assert!(verdict.mutual_tls);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while got.load(std::sync::atomic::Ordering::Relaxed) == 0 {
        assert!(std::time::Instant::now() < deadline, "no sample crossed");
        b.put("zs/test", "x").wait().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // Another CA's certificate: the handshake fails and the session does not open.
    let stranger = mtls(other.host("planner"));
    assert!(matches!(
        open(&peer(&[], &endpoint, stranger)),
        Err(SessionError::Open { .. })
    ));
    // No client certificate: TLS that trusts the lab's CA but presents nothing.
    let file = write(
        &dir,
        "nocert.json5",
        &format!(
            "{{ transport: {{ link: {{ tls: {{ root_ca_certificate: {} }} }} }} }}",
            serde_json::to_string(&lab.ca).unwrap()
        ),
    );
    let anonymous = Security {
        zenoh_config: Some(file),
        insecure: true,
        ..Security::default()
    };
    assert!(matches!(
        open(&peer(&[], &endpoint, anonymous)),
        Err(SessionError::Open { .. })
    ));
}

/// A session file of the shape rmw_zenoh's `zenoh_security_tools generate_configs` writes
/// for a node (its defaults' endpoints turned to `tls/`, mutual TLS with the enclave's files,
/// name verification off, TLS links only, access control with its rule names) is judged
/// mutually authenticated and opens as it is.
#[test]
fn a_file_from_rmw_zenohs_security_tools_is_taken_as_it_is() {
    let dir = folder("sros2");
    let lab = Lab::new(&dir, "sros2");
    let node = lab.host("hrrtc_gateway");
    let q = |p: &Path| serde_json::to_string(p).unwrap();
    let file = write(
        &dir,
        "hrrtc_gateway.json5",
        &format!(
            "{{ mode: 'peer',
              connect: {{ endpoints: ['tls/localhost:7447'] }},
              listen: {{ endpoints: ['tls/127.0.0.1:0'] }},
              scouting: {{ multicast: {{ enabled: false }} }},
              transport: {{ link: {{ protocols: ['tls'], tls: {{
                enable_mtls: true, verify_name_on_connect: false,
                root_ca_certificate: {ca}, listen_private_key: {key}, listen_certificate: {cert},
                connect_private_key: {key}, connect_certificate: {cert} }} }} }},
              access_control: {{ enabled: true, default_permission: 'deny',
                rules: [
                  {{ id: 'incoming_publications', messages: ['put'], flows: ['ingress'],
                     permission: 'allow', key_exprs: ['0/hrrtc/guidance/**'] }},
                  {{ id: 'liveliness_tokens', messages: ['liveliness_token', 'liveliness_query',
                     'declare_liveliness_subscriber'], flows: ['ingress', 'egress'],
                     permission: 'allow', key_exprs: ['@ros2_lv/0/**'] }} ],
                policies: [ {{ rules: ['liveliness_tokens'], subjects: ['router'] }},
                            {{ rules: ['incoming_publications'], subjects: ['hrrtc_gateway'] }} ],
                subjects: [ {{ id: 'router' }}, {{ id: 'hrrtc_gateway' }} ] }} }}",
            ca = q(&node.ca),
            key = q(&node.key),
            cert = q(&node.cert)
        ),
    );
    let s = Settings {
        defaults: vec![
            ("connect/timeout_ms", "-1".into()),
            ("connect/exit_on_failure", "false".into()),
        ],
        security: Security {
            zenoh_config: Some(file),
            ..Security::default()
        },
        ..Settings::default()
    };
    let (built, verdict) = prepare(&s).expect("judged mutual TLS");
    assert!(verdict.mutual_tls);
    assert_eq!(verdict.connect, ["tls/localhost:7447"]);
    assert_eq!(
        built.config.get_json("access_control/enabled").unwrap(),
        "true"
    );
    let session = open_prepared(built, &verdict).expect("opens");
    drop(session);
}
