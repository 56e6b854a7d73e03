//! Multi-host security through `TransportConfig::config_file`: mutual TLS on loopback with
//! certificates made at test time, access control, and the precedence of nrslam's settings over
//! the file's.
//!
//! The configuration files are the JSON5 blocks of docs/security.md, with their
//! `/etc/nrslam/tls/` paths pointed at a temporary directory, so the documented files are the
//! tested ones.

use nrslam_runtime::transport::{self, Session, SessionMode, TransportConfig, TransportError};
use rcgen::{
    BasicConstraints, CertificateParams, CertifiedIssuer, DnType, ExtendedKeyUsagePurpose, IsCa,
    KeyPair, KeyUsagePurpose,
};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};
use zenoh::Wait;

const SECURITY_MD: &str = include_str!("../../docs/security.md");
const DOC_DIR: &str = "/etc/nrslam/tls/";

/// The JSON5 block that follows the marker `<!-- file: NAME` in docs/security.md.
fn doc_block(name: &str) -> String {
    let marker = format!("<!-- file: {name}");
    let start = SECURITY_MD
        .find(&marker)
        .unwrap_or_else(|| panic!("docs/security.md has no block {name}"));
    let rest = &SECURITY_MD[start..];
    let open = rest
        .find("```json5\n")
        .expect("a json5 block after the marker")
        + 9;
    let close = rest[open..].find("```").expect("the end of the block") + open;
    rest[open..close].to_owned()
}

/// A certificate authority.
struct Ca {
    issuer: CertifiedIssuer<'static, KeyPair>,
}

impl Ca {
    fn new(name: &str) -> Self {
        let mut params = CertificateParams::new(Vec::<String>::new()).unwrap();
        params.distinguished_name.push(DnType::CommonName, name);
        params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
        params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
        let issuer = CertifiedIssuer::self_signed(params, KeyPair::generate().unwrap()).unwrap();
        Self { issuer }
    }

    /// Writes `ca.pem` (of `trusted`), and `host.pem`, `host-key.pem` (common name `name`,
    /// for 127.0.0.1 and localhost, signed by `self`) into `dir`: the layout the doc's files
    /// expect in /etc/nrslam/tls/.
    fn host_dir(&self, trusted: &Ca, name: &str, dir: &Path) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let mut params =
            CertificateParams::new(vec!["127.0.0.1".to_owned(), "localhost".to_owned()]).unwrap();
        params.distinguished_name.push(DnType::CommonName, name);
        params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
        params.extended_key_usages = vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            ExtendedKeyUsagePurpose::ClientAuth,
        ];
        let key = KeyPair::generate().unwrap();
        let cert = params.signed_by(&key, &self.issuer).unwrap();
        std::fs::write(dir.join("ca.pem"), trusted.issuer.pem()).unwrap();
        std::fs::write(dir.join("host.pem"), cert.pem()).unwrap();
        std::fs::write(dir.join("host-key.pem"), key.serialize_pem()).unwrap();
        dir.to_owned()
    }
}

/// Writes the doc's block `name` with its certificate paths in `certs`, as `file`.
fn config_from_doc(name: &str, certs: &Path, file: &Path) -> PathBuf {
    let text = doc_block(name).replace(DOC_DIR, &format!("{}/", certs.display()));
    assert!(!text.contains(DOC_DIR));
    std::fs::write(file, text).unwrap();
    file.to_owned()
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// A session of `mode` with the configuration `file`: a router listens on `endpoint`, the others
/// connect to it.
fn open(mode: SessionMode, endpoint: &str, file: &Path) -> Result<Session, TransportError> {
    let endpoints = vec![endpoint.to_owned()];
    let (listen, connect) = match mode {
        SessionMode::Router => (endpoints, Vec::new()),
        _ => (Vec::new(), endpoints),
    };
    transport::open(&TransportConfig {
        mode,
        listen,
        connect,
        config_file: Some(file.to_owned()),
        ..TransportConfig::default()
    })
}

/// A client that tries to connect to `endpoint` on another thread: its result and how long it
/// took.
fn client_in_background(
    endpoint: &str,
    file: &Path,
) -> std::thread::JoinHandle<(Result<(), TransportError>, Duration)> {
    let (endpoint, file) = (endpoint.to_owned(), file.to_owned());
    std::thread::spawn(move || {
        let started = Instant::now();
        let result = open(SessionMode::Client, &endpoint, &file);
        (result.map(|_| ()), started.elapsed())
    })
}

/// Every payload received on `key` goes into the returned channel.
fn collect(
    session: &Session,
    key: &str,
) -> (zenoh::pubsub::Subscriber<()>, mpsc::Receiver<String>) {
    let (sender, receiver) = mpsc::channel();
    let subscriber = session
        .declare_subscriber(key)
        .callback(move |sample| {
            let _ = sender.send(format!(
                "{}={}",
                sample.key_expr(),
                String::from_utf8_lossy(&sample.payload().to_bytes())
            ));
        })
        .wait()
        .unwrap();
    (subscriber, receiver)
}

fn drain(receiver: &mpsc::Receiver<String>) -> Vec<String> {
    receiver.try_iter().collect()
}

/// Publishes `count` samples on `key`, `every` apart.
fn publish(session: &Session, key: &str, payload: &str, count: usize, every: Duration) {
    for i in 0..count {
        session.put(key, format!("{payload}{i}")).wait().unwrap();
        std::thread::sleep(every);
    }
}

#[test]
fn mutual_tls_admits_only_certificates_of_the_ca() {
    let tmp = tempfile::tempdir().unwrap();
    let ca = Ca::new("nrslam test CA");
    let rogue_ca = Ca::new("rogue CA");
    let router_dir = ca.host_dir(&ca, "launcher", &tmp.path().join("router"));
    let client_dir = ca.host_dir(&ca, "node-host", &tmp.path().join("client"));
    // Trusts the real CA (so it would accept the router) but shows a certificate of another CA.
    let rogue_dir = rogue_ca.host_dir(&ca, "node-host", &tmp.path().join("rogue"));
    let router_file = config_from_doc("mtls.json5", &router_dir, &tmp.path().join("router.json5"));
    let client_file = config_from_doc("mtls.json5", &client_dir, &tmp.path().join("client.json5"));
    let rogue_file = config_from_doc("mtls.json5", &rogue_dir, &tmp.path().join("rogue.json5"));
    // Trusts the CA, shows no certificate at all. A 2 s connect timeout, which nrslam keeps.
    let anonymous_file = tmp.path().join("anonymous.json5");
    std::fs::write(
        &anonymous_file,
        format!(
            "{{ connect: {{ timeout_ms: 2000 }}, transport: {{ link: {{ tls: {{ \
             root_ca_certificate: {:?} }} }} }} }}",
            client_dir.join("ca.pem").display().to_string()
        ),
    )
    .unwrap();

    let endpoint = format!("tls/127.0.0.1:{}", free_port());
    let router = open(SessionMode::Router, &endpoint, &router_file)
        .expect("router with a valid certificate");
    let (_router_sub, router_got) = collect(&router, "nrslam/tls/**");

    // The invalid clients try to connect meanwhile: a refused handshake, retried until the
    // connect timeout (10 s by nrslam's default; 2 s from the anonymous one's file).
    let rogue_client = client_in_background(&endpoint, &rogue_file);
    let anonymous_client = client_in_background(&endpoint, &anonymous_file);

    let client = open(SessionMode::Client, &endpoint, &client_file)
        .expect("client with a certificate of the CA");
    let (_client_sub, client_got) = collect(&client, "nrslam/tls/**");
    // A peer with the rogue certificate opens (a peer retries its connections in the
    // background) and subscribes and publishes; none of it may cross.
    let rogue_peer = open(SessionMode::Peer, &endpoint, &rogue_file)
        .expect("a peer opens even when its connection is refused");
    let (_rogue_sub, rogue_got) = collect(&rogue_peer, "nrslam/tls/**");
    std::thread::sleep(Duration::from_millis(300));

    publish(
        &router,
        "nrslam/tls/map",
        "router",
        20,
        Duration::from_millis(50),
    );
    publish(
        &client,
        "nrslam/tls/odom",
        "client",
        5,
        Duration::from_millis(20),
    );
    publish(
        &rogue_peer,
        "nrslam/tls/odom",
        "rogue",
        5,
        Duration::from_millis(20),
    );
    std::thread::sleep(Duration::from_millis(500));

    let client_got = drain(&client_got);
    let router_got = drain(&router_got);
    let rogue_got = drain(&rogue_got);
    assert_eq!(
        client_got.iter().filter(|s| s.contains("=router")).count(),
        20,
        "the valid client receives every sample: {client_got:?}"
    );
    assert_eq!(
        router_got.iter().filter(|s| s.contains("=client")).count(),
        5,
        "the router receives the valid client's samples: {router_got:?}"
    );
    assert!(
        !router_got.iter().any(|s| s.contains("=rogue")),
        "the router receives nothing from the rogue peer: {router_got:?}"
    );
    assert!(
        !rogue_got.iter().any(|s| !s.contains("=rogue")),
        "the rogue peer receives nothing but its own samples: {rogue_got:?}"
    );

    let (rogue_result, rogue_took) = rogue_client.join().unwrap();
    let (anonymous_result, anonymous_took) = anonymous_client.join().unwrap();
    for (who, result, took) in [
        ("rogue", &rogue_result, rogue_took),
        ("anonymous", &anonymous_result, anonymous_took),
    ] {
        let error = result
            .as_ref()
            .expect_err(&format!("the {who} client must not open a session"));
        let message = error.to_string();
        assert!(
            message.contains(&endpoint) || message.to_lowercase().contains("connect"),
            "{who}: {message}"
        );
        eprintln!("{who} client: refused after {took:?}: {message}");
    }
    // The anonymous client's file sets connect.timeout_ms: nrslam's 10 s does not override it.
    assert!(
        anonymous_took < Duration::from_secs(6),
        "anonymous: {anonymous_took:?}"
    );
    let _ = rogue_peer.close().wait();
    let _ = client.close().wait();
    let _ = router.close().wait();
}

#[test]
fn access_control_limits_what_a_viewer_may_publish() {
    let tmp = tempfile::tempdir().unwrap();
    let ca = Ca::new("nrslam test CA");
    let router_dir = ca.host_dir(&ca, "launcher", &tmp.path().join("router"));
    let viewer_dir = ca.host_dir(&ca, "viewer", &tmp.path().join("viewer"));
    let router_file = config_from_doc(
        "mtls-acl.json5",
        &router_dir,
        &tmp.path().join("router.json5"),
    );
    let viewer_file = config_from_doc("mtls.json5", &viewer_dir, &tmp.path().join("viewer.json5"));
    let endpoint = format!("tls/127.0.0.1:{}", free_port());
    let router =
        open(SessionMode::Router, &endpoint, &router_file).expect("router with access control");
    let (_router_sub, router_got) = collect(&router, "**");
    let viewer = open(SessionMode::Client, &endpoint, &viewer_file)
        .expect("viewer with a certificate of the CA");
    let (_viewer_sub, viewer_got) = collect(&viewer, "map");
    std::thread::sleep(Duration::from_millis(300));

    publish(&router, "map", "router", 10, Duration::from_millis(30));
    publish(&viewer, "map", "forged", 5, Duration::from_millis(30));
    publish(&viewer, "viewer/note", "note", 5, Duration::from_millis(30));
    std::thread::sleep(Duration::from_millis(500));

    let viewer_got = drain(&viewer_got);
    let router_got = drain(&router_got);
    assert_eq!(
        viewer_got.iter().filter(|s| s.contains("=router")).count(),
        10,
        "the viewer receives the graph's topics: {viewer_got:?}"
    );
    assert_eq!(
        router_got
            .iter()
            .filter(|s| s.starts_with("viewer/note="))
            .count(),
        5,
        "the viewer may publish under viewer/**: {router_got:?}"
    );
    assert!(
        !router_got.iter().any(|s| s.contains("=forged")),
        "the viewer may not publish on map: {router_got:?}"
    );
    let _ = viewer.close().wait();
    let _ = router.close().wait();
}

fn json(config: &zenoh::Config, key: &str) -> serde_json::Value {
    serde_json::from_str(&config.get_json(key).unwrap()).unwrap()
}

/// `value` for `mode` when zenoh reports a per-mode object, else `value` itself.
fn for_mode(value: serde_json::Value, mode: &str) -> serde_json::Value {
    match value {
        serde_json::Value::Object(per_mode) if per_mode.contains_key(mode) => {
            per_mode[mode].clone()
        }
        other => other,
    }
}

#[test]
fn nrslam_settings_go_on_top_of_the_file_by_the_documented_rules() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("base.json5");
    std::fs::write(
        &file,
        r#"{
            mode: "peer",
            listen: { endpoints: ["tcp/127.0.0.1:7001"] },
            connect: { endpoints: { router: ["tcp/127.0.0.1:7002"], client: ["tcp/127.0.0.1:7003"] } },
            scouting: { gossip: { enabled: true } },
        }"#,
    )
    .unwrap();
    let config = |mode, listen: &[&str], connect: &[&str]| TransportConfig {
        mode,
        listen: listen.iter().map(|s| s.to_string()).collect(),
        connect: connect.iter().map(|s| s.to_string()).collect(),
        config_file: Some(file.clone()),
        ..TransportConfig::default()
    };

    // A router: nrslam's mode wins; the file's listen endpoints come first, then nrslam's; the
    // file's connect endpoints for a router are kept when none is given.
    let z = transport::zenoh_config(&config(
        SessionMode::Router,
        &["tcp/127.0.0.1:7010", "tcp/127.0.0.1:7001"],
        &[],
    ))
    .unwrap();
    assert_eq!(json(&z, "mode"), "router");
    assert_eq!(
        for_mode(json(&z, "listen/endpoints"), "router"),
        serde_json::json!(["tcp/127.0.0.1:7001", "tcp/127.0.0.1:7010"])
    );
    assert_eq!(
        for_mode(json(&z, "connect/endpoints"), "router"),
        serde_json::json!(["tcp/127.0.0.1:7002"])
    );
    // Multicast scouting: off (the file does not name it); gossip: the file enables it.
    assert_eq!(json(&z, "scouting/multicast/enabled"), false);
    assert_eq!(json(&z, "scouting/gossip/enabled"), true);

    // A client: --connect replaces the file's; the file's listen endpoints are ignored; nrslam's
    // connect timeout applies (the file sets none).
    let z = transport::zenoh_config(&config(SessionMode::Client, &[], &["tcp/127.0.0.1:7020"]))
        .unwrap();
    assert_eq!(json(&z, "mode"), "client");
    assert_eq!(
        for_mode(json(&z, "connect/endpoints"), "client"),
        serde_json::json!(["tcp/127.0.0.1:7020"])
    );
    assert_eq!(
        for_mode(json(&z, "listen/endpoints"), "client"),
        serde_json::json!([])
    );
    assert_eq!(json(&z, "connect/timeout_ms"), serde_json::json!(10000));

    // A peer: the file names no connect endpoint for peers, so there is none (never zenoh's
    // default).
    let z = transport::zenoh_config(&config(SessionMode::Peer, &[], &[])).unwrap();
    assert_eq!(
        for_mode(json(&z, "connect/endpoints"), "peer"),
        serde_json::json!([])
    );

    // Without a file: nothing listens, no scouting.
    let z = transport::zenoh_config(&TransportConfig::default()).unwrap();
    assert_eq!(
        for_mode(json(&z, "listen/endpoints"), "peer"),
        serde_json::json!([])
    );
    assert_eq!(json(&z, "scouting/multicast/enabled"), false);
    assert_eq!(json(&z, "scouting/gossip/enabled"), false);
}

#[test]
fn a_bad_config_file_is_an_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("no-such-zenoh.json5");
    let malformed = tmp.path().join("malformed.json5");
    std::fs::write(&malformed, "{ transport: { link: ").unwrap();
    let invalid = tmp.path().join("invalid.json5");
    std::fs::write(
        &invalid,
        "{ transport: { link: { tls: { enable_mtls: \"yes\" } } } }",
    )
    .unwrap();
    let no_extension = tmp.path().join("zenoh-config");
    std::fs::write(&no_extension, "{}").unwrap();
    for path in [&missing, &malformed, &invalid, &no_extension] {
        let config = TransportConfig {
            config_file: Some(path.clone()),
            ..TransportConfig::default()
        };
        let error = transport::zenoh_config(&config).expect_err("a bad file is refused");
        let message = error.to_string();
        assert!(
            message.contains(&path.display().to_string()),
            "{message:?} names {}",
            path.display()
        );
        assert!(transport::open(&config).is_err());
    }
}
