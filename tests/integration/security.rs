//! `crossym security` (cargo feature `security`): SROS2 keystores checked with the tools
//! a ROS 2 user checks them with, not with crossym's own code:
//!
//! - the tree is sros2's, file by file and link by link (`ros2 security create_keystore`,
//!   `create-enclave`: sros2/keystore/_keystore.py, _enclave.py);
//! - every `.p7s` verifies with `openssl smime -verify` against the permissions CA and
//!   carries the `.xml` beside it; a changed document does not verify;
//! - the enclaves' certificates chain to the identity CA (`openssl verify`) and not to
//!   another keystore's; keys are ECDSA P-256;
//! - the shipped policy (config/security/policy.xml) becomes the grants the guide promises,
//!   with ROS 2's DDS names (`rt/`, `rq/…Request`, `rr/…Reply`).
//!
//! No DDS: nothing here opens a participant.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use crate::skip::skip;

/// The `openssl` command line tool, or `None` after a skip (CI: a failure).
fn openssl() -> Option<()> {
    match Command::new("openssl").arg("version").output() {
        Ok(o) if o.status.success() => Some(()),
        _ => {
            skip("the openssl command line tool is missing (Debian: apt-get install openssl)");
            None
        }
    }
}

/// `openssl ARGS…` run in `dir`: (success, stdout + stderr).
fn run_openssl(dir: &Path, args: &[&str]) -> (bool, String) {
    let out = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .output()
        .expect("openssl starts");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// `crossym security ARGS…` with ROS_DOMAIN_ID = `domain`; panics unless it succeeds.
fn security(domain: u16, args: &[&str]) -> String {
    common::run_ok(
        common::crossym(["security"].iter().chain(args))
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env_remove("ROS_SECURITY_KEYSTORE"),
    )
}

/// A keystore with the enclave /crossym/node (sros2's default permissions), in a fresh
/// directory.
fn keystore_with_node(tag: &str) -> PathBuf {
    let ks = common::temp_dir(tag).join("keystore");
    let k = ks.to_str().unwrap();
    security(0, &["create-keystore", k]);
    security(0, &["create-enclave", k, "/crossym/node"]);
    ks
}

/// What is at `rel` under `root`: `file`, `dir` or `-> target`.
fn entry(root: &Path, rel: &str) -> String {
    let p = root.join(rel);
    let m = p
        .symlink_metadata()
        .unwrap_or_else(|e| panic!("{rel}: {e}"));
    if m.file_type().is_symlink() {
        format!("-> {}", std::fs::read_link(&p).unwrap().display())
    } else if m.is_dir() {
        "dir".into()
    } else {
        "file".into()
    }
}

/// Every path under `dir`, relative, sorted.
fn tree(dir: &Path) -> Vec<String> {
    fn walk(dir: &Path, base: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(base).unwrap().display().to_string());
            if p.is_dir() && !p.is_symlink() {
                walk(&p, base, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// The tree `ros2 security create_keystore ks && ros2 security create_enclave ks
/// /crossym/node` writes (sros2's _keystore.py and _enclave.py): one CA that both roles
/// link to, relative links from the enclave to the CAs and the governance.
#[test]
fn keystore_tree_matches_sros2_file_by_file() {
    let ks = keystore_with_node("sec-tree");
    let want = [
        ("enclaves", "dir"),
        ("enclaves/crossym", "dir"),
        ("enclaves/crossym/node", "dir"),
        ("enclaves/crossym/node/cert.pem", "file"),
        (
            "enclaves/crossym/node/governance.p7s",
            "-> ../../governance.p7s",
        ),
        (
            "enclaves/crossym/node/identity_ca.cert.pem",
            "-> ../../../public/identity_ca.cert.pem",
        ),
        ("enclaves/crossym/node/key.pem", "file"),
        ("enclaves/crossym/node/permissions.p7s", "file"),
        ("enclaves/crossym/node/permissions.xml", "file"),
        (
            "enclaves/crossym/node/permissions_ca.cert.pem",
            "-> ../../../public/permissions_ca.cert.pem",
        ),
        ("enclaves/governance.p7s", "file"),
        ("enclaves/governance.xml", "file"),
        ("private", "dir"),
        ("private/ca.key.pem", "file"),
        ("private/identity_ca.key.pem", "-> ca.key.pem"),
        ("private/permissions_ca.key.pem", "-> ca.key.pem"),
        ("public", "dir"),
        ("public/ca.cert.pem", "file"),
        ("public/identity_ca.cert.pem", "-> ca.cert.pem"),
        ("public/permissions_ca.cert.pem", "-> ca.cert.pem"),
    ];
    let got: Vec<(String, String)> = tree(&ks)
        .into_iter()
        .map(|rel| {
            let e = entry(&ks, &rel);
            (rel, e)
        })
        .collect();
    let want: Vec<(String, String)> = want
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    assert_eq!(got, want);
    // Every link resolves, and the enclave holds the seven files rcl and RustDDS read.
    for rel in tree(&ks) {
        assert!(ks.join(&rel).exists(), "{rel} is a dangling link");
    }
    for f in [
        "cert.pem",
        "key.pem",
        "identity_ca.cert.pem",
        "permissions_ca.cert.pem",
        "governance.p7s",
        "permissions.xml",
        "permissions.p7s",
    ] {
        assert!(ks.join("enclaves/crossym/node").join(f).is_file(), "{f}");
    }
    // Private keys are readable by their owner only.
    use std::os::unix::fs::PermissionsExt;
    for key in ["private/ca.key.pem", "enclaves/crossym/node/key.pem"] {
        let mode = std::fs::metadata(ks.join(key))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o077, 0, "{key}: mode {mode:o}");
    }
    let listed = security(0, &["list-enclaves", ks.to_str().unwrap()]);
    assert_eq!(listed, "/crossym/node\n");
}

/// Every signed document verifies against the permissions CA as `openssl smime -verify`
/// checks it (what sros2's docs and DDS implementations check) and carries exactly the
/// `.xml` beside it; the same document changed by one word does not verify.
#[test]
fn signed_documents_verify_with_openssl_and_tampering_is_caught() {
    if openssl().is_none() {
        return;
    }
    let ks = keystore_with_node("sec-smime");
    let k = ks.to_str().unwrap();
    security(0, &["create-enclave", k, "/crossym/operator"]);
    let ca = "public/permissions_ca.cert.pem";
    let docs = [
        "enclaves/governance",
        "enclaves/crossym/node/permissions",
        "enclaves/crossym/operator/permissions",
    ];
    for doc in docs {
        let p7s = format!("{doc}.p7s");
        let (ok, out) = run_openssl(
            &ks,
            &[
                "smime",
                "-verify",
                "-text",
                "-in",
                &p7s,
                "-CAfile",
                ca,
                "-out",
                "verified.xml",
            ],
        );
        assert!(ok, "{p7s}: {out}");
        assert!(out.contains("Verification successful"), "{p7s}: {out}");
        let verified = std::fs::read_to_string(ks.join("verified.xml")).unwrap();
        let xml = std::fs::read_to_string(ks.join(format!("{doc}.xml"))).unwrap();
        assert_eq!(
            verified.replace("\r\n", "\n"),
            xml,
            "{p7s} carries another document"
        );
    }
    // The governance through the enclave's link verifies too (what a node reads).
    let (ok, out) = run_openssl(
        &ks,
        &[
            "smime",
            "-verify",
            "-in",
            "enclaves/crossym/node/governance.p7s",
            "-CAfile",
            ca,
            "-out",
            "/dev/null",
        ],
    );
    assert!(ok, "{out}");

    // Tampered: discovery left unprotected, a topic granted that the CA never signed.
    let tampered = [
        (
            "enclaves/governance.p7s",
            "<discovery_protection_kind>ENCRYPT",
            "<discovery_protection_kind>NONE",
        ),
        (
            "enclaves/crossym/operator/permissions.p7s",
            "<topic>rt/*</topic>",
            "<topic>rt/x</topic>",
        ),
    ];
    for (file, from, to) in tampered {
        let text = std::fs::read_to_string(ks.join(file)).unwrap();
        assert!(text.contains(from), "{file} has no {from}");
        let bad = ks.join("tampered.p7s");
        std::fs::write(&bad, text.replacen(from, to, 1)).unwrap();
        let (ok, out) = run_openssl(
            &ks,
            &[
                "smime",
                "-verify",
                "-in",
                "tampered.p7s",
                "-CAfile",
                ca,
                "-out",
                "/dev/null",
            ],
        );
        assert!(!ok, "a changed {file} verified: {out}");
        assert!(
            out.contains("Verification failure") || out.contains("digest failure"),
            "{out}"
        );
    }

    // Signed by another keystore's CA: refused against this one.
    let other = keystore_with_node("sec-smime-other");
    let (ok, out) = run_openssl(
        &ks,
        &[
            "smime",
            "-verify",
            "-in",
            other.join("enclaves/governance.p7s").to_str().unwrap(),
            "-CAfile",
            ca,
            "-out",
            "/dev/null",
        ],
    );
    assert!(!ok, "another CA's governance verified: {out}");
}

/// The enclave's certificate is `CN=<enclave>`, issued by the identity CA and valid against
/// it (`openssl verify`), not against another keystore's CA; keys are ECDSA P-256; the
/// CA is a CA.
#[test]
fn certificates_chain_to_the_identity_ca() {
    if openssl().is_none() {
        return;
    }
    let ks = keystore_with_node("sec-chain");
    let other = keystore_with_node("sec-chain-other");
    let cert = "enclaves/crossym/node/cert.pem";
    let (ok, out) = run_openssl(
        &ks,
        &["verify", "-CAfile", "public/identity_ca.cert.pem", cert],
    );
    assert!(ok && out.contains(": OK"), "{out}");
    let foreign = other.join("public/identity_ca.cert.pem");
    let (ok, out) = run_openssl(&ks, &["verify", "-CAfile", foreign.to_str().unwrap(), cert]);
    assert!(!ok, "verified against a foreign CA: {out}");

    let (_, subject) = run_openssl(&ks, &["x509", "-in", cert, "-noout", "-subject", "-issuer"]);
    assert!(subject.contains("subject=CN = /crossym/node"), "{subject}");
    assert!(subject.contains("issuer=CN = sros2CA"), "{subject}");
    let (_, ca) = run_openssl(
        &ks,
        &["x509", "-in", "public/ca.cert.pem", "-noout", "-text"],
    );
    assert!(ca.contains("CA:TRUE, pathlen:1"), "{ca}");
    assert!(ca.contains("ecdsa-with-SHA256"), "{ca}");
    for key in ["private/ca.key.pem", "enclaves/crossym/node/key.pem"] {
        let pem = std::fs::read_to_string(ks.join(key)).unwrap();
        assert!(
            pem.starts_with("-----BEGIN PRIVATE KEY-----"),
            "{key}: not PKCS#8"
        );
        let (ok, text) = run_openssl(&ks, &["pkey", "-in", key, "-noout", "-text"]);
        assert!(ok && text.contains("prime256v1"), "{key}: {text}");
    }
}

/// The shipped policy: the node reads its inputs and serves ~/pause; the operator calls
/// ~/pause and the parameter services; perception publishes ~/task_pose and nothing the
/// node reads besides. Domain from ROS_DOMAIN_ID, validity from the certificate.
#[test]
fn shipped_policy_grants_what_the_guide_says() {
    if openssl().is_none() {
        return;
    }
    let ks = common::temp_dir("sec-policy").join("keystore");
    let k = ks.to_str().unwrap();
    let policy = common::path("config/security/policy.xml");
    let out = security(
        7,
        &[
            "generate-artifacts",
            "-k",
            k,
            "-p",
            policy.to_str().unwrap(),
        ],
    );
    assert_eq!(out.lines().count(), 5, "{out}");
    let listed = security(7, &["list-enclaves", k]);
    assert_eq!(
        listed,
        "/crossym/demo\n/crossym/mock_hw\n/crossym/node\n/crossym/operator\n/crossym/perception\n"
    );
    let grant = |enclave: &str| -> (Vec<String>, Vec<String>, String) {
        let xml =
            std::fs::read_to_string(ks.join(format!("enclaves{enclave}/permissions.xml"))).unwrap();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let allow = doc
            .descendants()
            .find(|n| n.has_tag_name("allow_rule"))
            .unwrap();
        let topics = |tag: &str| -> Vec<String> {
            allow
                .children()
                .find(|n| n.has_tag_name(tag))
                .map(|n| {
                    n.descendants()
                        .filter(|t| t.has_tag_name("topic"))
                        .map(|t| t.text().unwrap().to_string())
                        .collect()
                })
                .unwrap_or_default()
        };
        (topics("publish"), topics("subscribe"), xml.clone())
    };
    let has = |list: &[String], t: &str| list.iter().any(|x| x == t);

    let (publish, subscribe, xml) = grant("/crossym/node");
    for t in [
        "rt/joint_states",
        "rt/crossym/symmetry_condition",
        "rt/crossym/task_pose",
        "rq/crossym/pauseRequest",
        "rq/crossym/resetRequest",
        "rq/crossym/set_parametersRequest",
    ] {
        assert!(
            has(&subscribe, t),
            "node does not subscribe {t}: {subscribe:?}"
        );
    }
    for t in [
        "rt/forward_velocity_controller/commands",
        "rt/both_arms_controller/joint_trajectory",
        "rt/crossym/status",
        "rt/rosout",
        "rr/crossym/pauseReply",
        "rr/crossym/get_parametersReply",
    ] {
        assert!(has(&publish, t), "node does not publish {t}: {publish:?}");
    }
    assert!(!has(&publish, "rt/joint_states") && !has(&publish, "rt/crossym/symmetry_condition"));
    assert!(xml.contains("<subject_name>CN=/crossym/node</subject_name>"));
    assert!(
        xml.contains("<id>7</id>") && !xml.contains("<id>0</id>"),
        "{xml}"
    );
    assert!(xml.contains("<default>DENY</default>"));
    // The grant's validity is the certificate's (as sros2 takes it).
    let (_, dates) = run_openssl(
        &ks,
        &[
            "x509",
            "-in",
            "enclaves/crossym/node/cert.pem",
            "-noout",
            "-startdate",
        ],
    );
    let year = dates.trim().rsplit(' ').nth(1).unwrap().to_string();
    let not_before = xml.split("<not_before>").nth(1).unwrap();
    assert!(not_before.starts_with(&year), "{dates} vs {not_before}");

    let (publish, subscribe, _) = grant("/crossym/operator");
    for t in [
        "rq/crossym/pauseRequest",
        "rq/crossym/resetRequest",
        "rq/crossym/set_parametersRequest",
        "rq/crossym/get_parametersRequest",
    ] {
        assert!(has(&publish, t), "operator cannot call {t}: {publish:?}");
    }
    assert!(has(&subscribe, "rr/crossym/pauseReply"));
    for t in [
        "rt/crossym/symmetry_condition",
        "rt/crossym/task_pose",
        "rt/joint_states",
        "rt/forward_velocity_controller/commands",
    ] {
        assert!(!has(&publish, t), "operator may publish {t}");
    }

    let (publish, subscribe, _) = grant("/crossym/perception");
    assert!(has(&publish, "rt/crossym/task_pose"));
    for t in [
        "rt/crossym/symmetry_condition",
        "rt/joint_states",
        "rq/crossym/pauseRequest",
        "rq/crossym/set_parametersRequest",
    ] {
        assert!(!has(&publish, t), "perception may publish {t}");
    }
    assert!(!subscribe.iter().any(|t| t.starts_with("rr/crossym/")));

    for e in ["node", "operator", "perception"] {
        let p7s = format!("enclaves/crossym/{e}/permissions.p7s");
        let (ok, out) = run_openssl(
            &ks,
            &[
                "smime",
                "-verify",
                "-in",
                &p7s,
                "-CAfile",
                "public/permissions_ca.cert.pem",
                "-out",
                "/dev/null",
            ],
        );
        assert!(ok, "{p7s}: {out}");
    }
}

/// Refusals name what to do: a second create-keystore, a permission for an enclave not
/// made, an enclave name that is no ROS namespace, a policy without the enclave.
#[test]
fn refusals_say_what_to_do() {
    let ks = common::temp_dir("sec-refuse").join("keystore");
    let k = ks.to_str().unwrap();
    let fails = |args: &[&str]| -> String {
        let out = common::crossym(["security"].iter().chain(args))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let e = fails(&["create-enclave", k, "/crossym/node"]);
    assert!(
        e.contains("is not a keystore") && e.contains("create-keystore"),
        "{e}"
    );
    security(0, &["create-keystore", k]);
    let e = fails(&["create-keystore", k]);
    assert!(e.contains("already a keystore"), "{e}");
    let policy = common::path("config/security/policy.xml");
    let p = policy.to_str().unwrap();
    let e = fails(&["create-permission", k, "/crossym/node", p]);
    assert!(e.contains("create-enclave"), "{e}");
    let e = fails(&["create-enclave", k, "crossym/node"]);
    assert!(e.contains("must start with /"), "{e}");
    security(0, &["create-enclave", k, "/elsewhere"]);
    let e = fails(&["create-permission", k, "/elsewhere", p]);
    assert!(
        e.contains("no <enclave path=\"/elsewhere\">") && e.contains("/crossym/operator"),
        "{e}"
    );
}

/// Changes the keystore's signed governance after signing (RTPS protection SIGN → NONE):
/// its signature no longer matches.
fn tamper_governance(ks: &Path) {
    let gov = ks.join("enclaves/governance.p7s");
    let text = std::fs::read_to_string(&gov).unwrap();
    let changed = text.replacen(
        "<rtps_protection_kind>SIGN",
        "<rtps_protection_kind>NONE",
        1,
    );
    assert_ne!(text, changed);
    std::fs::write(&gov, changed).unwrap();
}

/// `cp -a from to` (the keystore's relative links kept).
fn copy_keystore(from: &Path, to: &Path) {
    let ok = Command::new("cp")
        .arg("-a")
        .arg(from)
        .arg(to)
        .status()
        .expect("cp starts")
        .success();
    assert!(ok, "cp -a {} {}", from.display(), to.display());
}

/// The consumer the keystore is for: RustDDS (through ros2-client's `enable_security`)
/// opens a secured participant from each enclave of the shipped policy — identity
/// certificate and key, both CAs, governance and permissions read, verified and parsed —
/// and refuses an enclave whose governance was changed after signing or whose permissions
/// another keystore's CA signed. Opens DDS participants (domain 187): CI runs it inside
/// tools/netns-run; nothing is sent to a peer.
#[test]
fn rustdds_opens_secured_participants_and_refuses_tampered_files() {
    let dir = common::temp_dir("sec-rustdds");
    let ks = dir.join("keystore");
    let policy = common::path("config/security/policy.xml");
    security(
        187,
        &[
            "generate-artifacts",
            "-k",
            ks.to_str().unwrap(),
            "-p",
            policy.to_str().unwrap(),
        ],
    );
    let open = |enclave: &Path| -> Result<(), String> {
        let options = ros2_client::ContextOptions::new()
            .domain_id(187)
            .enable_security(enclave, String::new());
        ros2_client::Context::with_options(options)
            .map(drop)
            .map_err(|e| format!("{e:?}"))
    };
    for e in ["node", "operator", "perception"] {
        let enclave = ks.join("enclaves/crossym").join(e);
        open(&enclave).unwrap_or_else(|err| panic!("/crossym/{e}: {err}"));
    }

    let tampered = dir.join("tampered");
    copy_keystore(&ks, &tampered);
    tamper_governance(&tampered);
    let err = open(&tampered.join("enclaves/crossym/node")).unwrap_err();
    assert!(err.contains("does not match"), "{err}");

    let foreign = dir.join("foreign");
    copy_keystore(&ks, &foreign);
    let other = keystore_with_node("sec-rustdds-other");
    std::fs::copy(
        other.join("enclaves/crossym/node/permissions.p7s"),
        foreign.join("enclaves/crossym/node/permissions.p7s"),
    )
    .unwrap();
    let err = open(&foreign.join("enclaves/crossym/node")).unwrap_err();
    assert!(err.contains("Signature verification failure"), "{err}");
}

// ---------------------------------------------------------------------------------------
// Running secured (SROS2's environment, as rcl reads it): the node, the mock robot, the
// demo and the tools over DDS. Domains 188–193 (no other test uses them); CI runs these
// inside tools/netns-run.
// ---------------------------------------------------------------------------------------

use std::time::{Duration, Instant};

use crossym::ros::dds::{self, DdsSettings, DiscoveryRange};
use crossym::ros::sros2::SecurityEnv;

/// A keystore of the shipped policy's enclaves for `domain` (governance and permissions
/// name the domain), in a fresh directory.
fn shipped_keystore(domain: u16, tag: &str) -> PathBuf {
    let ks = common::temp_dir(tag).join("keystore");
    let policy = common::path("config/security/policy.xml");
    security(
        domain,
        &[
            "generate-artifacts",
            "-k",
            ks.to_str().unwrap(),
            "-p",
            policy.to_str().unwrap(),
        ],
    );
    ks
}

/// `crossym ARGS…` under SROS2: `ROS_SECURITY_ENABLE=true`, the keystore and `strategy`
/// (`None`: the variables removed, an ordinary process).
fn crossym_sec(args: &[&str], sec: Option<(&Path, &str)>) -> Command {
    let mut c = common::crossym(args);
    c.current_dir(common::root())
        .env_remove("ROS_SECURITY_ENCLAVE_OVERRIDE");
    match sec {
        Some((ks, strategy)) => {
            c.env("ROS_SECURITY_ENABLE", "true")
                .env("ROS_SECURITY_KEYSTORE", ks)
                .env("ROS_SECURITY_STRATEGY", strategy);
        }
        None => {
            c.env_remove("ROS_SECURITY_ENABLE")
                .env_remove("ROS_SECURITY_KEYSTORE")
                .env_remove("ROS_SECURITY_STRATEGY");
        }
    }
    c
}

fn letters() -> String {
    common::path("config/letters.toml").display().to_string()
}

/// The node and the mock robot of config/letters.toml in `domain`, secured from `ks`
/// (Enforce; as /crossym/node and /crossym/mock_hw) or not; waits until the node has
/// joint states. Logs in `dir`.
fn node_and_robot(
    domain: u16,
    ks: Option<&Path>,
    dir: &Path,
) -> (common::Proc, common::Proc, PathBuf) {
    let c = letters();
    let sec = ks.map(|k| (k, "Enforce"));
    let with_enclave = |args: &[&str], e: &str| -> Vec<String> {
        let mut v: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        if ks.is_some() {
            v.extend(["--ros-args", "--enclave", e].map(String::from));
        }
        v
    };
    let node_args = with_enclave(&["node", "--config", &c], "/crossym/node");
    let hw_args = with_enclave(&["mock-hw", "--config", &c], "/crossym/mock_hw");
    let node_log = dir.join("node.log");
    let hw_log = dir.join("hw.log");
    fn argv(v: &[String]) -> Vec<&str> {
        v.iter().map(String::as_str).collect()
    }
    let node = common::Proc::spawn(
        crossym_sec(&argv(&node_args), sec),
        "node",
        domain,
        &node_log,
    );
    let hw = common::Proc::spawn(
        crossym_sec(&argv(&hw_args), sec),
        "mock-hw",
        domain,
        &hw_log,
    );
    assert!(
        common::wait_for_text(&node_log, "joint states received", Duration::from_secs(60)),
        "the node never got joint states\n--- node\n{}\n--- mock-hw\n{}",
        common::log_tail(&node_log),
        common::log_tail(&hw_log)
    );
    (node, hw, node_log)
}

/// What the unsecured peer (tests/peer/attack_peer.py) saw in `seconds` with `args` (its
/// one JSON line).
fn attack_peer(domain: u16, seconds: f64, args: &[&str]) -> serde_json::Value {
    assert!(
        common::python_has_cyclonedds(),
        "PyPI cyclonedds is missing: run `bash tests/peer/install.sh` (.ci/run does)"
    );
    let out = Command::new("python3")
        .arg(common::root().join("tests/peer/attack_peer.py"))
        .args([
            "--domain",
            &domain.to_string(),
            "--seconds",
            &seconds.to_string(),
        ])
        .args(args)
        .output()
        .expect("python3 starts");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "attack_peer.py: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).expect("one JSON line")
}

/// What the unsecured peer saw while it published a condition (θ 0.5, λ 0.8, σ 1) for
/// `seconds`: (conditions sent, commands received, statuses received, raw JSON).
fn attack(domain: u16, seconds: f64) -> (u64, u64, u64, String) {
    let v = attack_peer(
        domain,
        seconds,
        &["--theta", "0.5", "--scale", "0.8", "--reflection", "1"],
    );
    let n = |k: &str| v[k].as_u64().unwrap_or(0);
    (n("sent"), n("commands"), n("statuses"), v.to_string())
}

/// RustDDS's warnings and errors of this process's participants (the peer's side of a
/// handshake or key exchange), captured with each test's output: shown when it fails (CI
/// 2026-12-05: an operator got no answer for 30 s while the node's log showed its keys
/// registered; the operator's side was not logged).
fn capture_rustdds_log() {
    let _ = env_logger::Builder::new()
        .parse_filters("rustdds=warn")
        .format_timestamp_millis()
        .is_test(true)
        .try_init();
}

/// A DDS participant of this process in `domain`, secured as `enclave` of `ks` (Enforce).
fn secured_context(domain: u16, ks: &Path, enclave: &str) -> Result<ros2_client::Context, String> {
    capture_rustdds_log();
    DdsSettings {
        domain_id: domain,
        range: DiscoveryRange::Localhost,
        distro: dds::DEFAULT_DISTRO,
        security: SecurityEnv::enforce(ks, enclave),
    }
    .context()
    .map_err(|e| e.to_string())
}

/// A DDS participant of this process in `domain` secured as `enclave` of `ks` the way any
/// DDS Security peer builds one: RustDDS given the enclave's files, without crossym's own
/// start-up checks (a peer with an expired certificate is for the node to refuse; crossym's
/// tools would not start with it).
fn raw_secured_context(
    domain: u16,
    ks: &Path,
    enclave: &str,
) -> Result<ros2_client::Context, String> {
    use ros2_client::dds::rustdds::{
        DomainParticipantBuilder, DomainParticipantSecurityConfigFiles as Files,
    };
    use std::net::{IpAddr, Ipv4Addr};
    capture_rustdds_log();
    ros2_client::set_ros_distro(dds::DEFAULT_DISTRO);
    let dir = ks.join("enclaves").join(enclave.trim_start_matches('/'));
    let dp = DomainParticipantBuilder::new(domain)
        .with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)])
        .builtin_security(Files::with_ros_default_names(&dir, String::new()))
        .build()
        .map_err(|e| e.to_string())?;
    ros2_client::Context::from_domain_participant(dp).map_err(|e| e.to_string())
}

/// A node `/crossym_<tag>` of `ctx` (no rosout).
fn plain_node(ctx: &ros2_client::Context, tag: &str) -> ros2_client::Node {
    ctx.new_node(
        dds::node_name("/", &format!("crossym_{tag}")).unwrap(),
        ros2_client::NodeOptions::new().enable_rosout(false),
    )
    .unwrap()
}

/// (a) A secured node and a secured mock robot complete a short demo: every process of
/// `crossym demo` runs secured (Enforce) as its enclave of the shipped policy, and the
/// loop passes with the same checks as unsecured (`demo: OK`): joint states, commands,
/// status, the mock robot's resets and a changed symmetry condition (demo → node, applied
/// by the node) cross DDS Security.
#[test]
fn secured_demo_passes() {
    let domain = 188;
    let ks = shipped_keystore(domain, "sec-demo");
    let out = common::temp_dir("sec-demo-out");
    let mut cmd = crossym_sec(
        &[
            "demo",
            "--no-isolation",
            "--duration-s",
            "1",
            // A changed condition (17°, 0.73, reflected): it must cross from the demo's
            // secured publisher to the secured node, which no condition did before the
            // payload-padding fix in vendor/rustdds.patch (vendor/README.md).
            "--condition",
            "0.2967:0.73:-1",
            "--out",
            out.to_str().unwrap(),
        ],
        Some((&ks, "Enforce")),
    );
    cmd.env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env_remove("CROSSYM_PRIVATE_NETNS");
    let o = cmd.output().expect("crossym demo starts");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let node_log = std::fs::read_to_string(out.join("node.log")).unwrap_or_default();
    let hw_log = std::fs::read_to_string(out.join("mock_hw.log")).unwrap_or_default();
    // The demo's own errors, without RustDDS's log lines.
    let stderr: Vec<String> = String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| !l.contains(" rustdds::"))
        .map(String::from)
        .collect();
    assert!(
        o.status.success() && stdout.contains("demo: OK"),
        "{:?}\n{stdout}\n{}\n--- node\n{}\n--- mock-hw\n{}",
        o.status,
        stderr.join("\n"),
        common::log_tail(&out.join("node.log")),
        common::log_tail(&out.join("mock_hw.log"))
    );
    assert!(
        stdout.contains("secured as enclave /crossym/demo (strategy Enforce"),
        "{stdout}"
    );
    assert!(
        node_log.contains("secured as enclave /crossym/node (strategy Enforce"),
        "{node_log}"
    );
    assert!(
        hw_log.contains("secured as enclave /crossym/mock_hw (strategy Enforce"),
        "{hw_log}"
    );
    assert!(
        node_log.contains("symmetry condition accepted: θ = 0.2967 rad"),
        "the secured node never applied the demo's condition\n{}",
        common::log_tail(&out.join("node.log"))
    );
}

/// (b) An unsecured, independent peer (Cyclone DDS, no credentials) on the node's domain:
/// against an unsecured node it reads the commands and the condition it publishes is
/// applied (the attack works: seen first, in this test); against a secured node (Enforce)
/// it receives nothing and the node never applies its condition, while the node keeps
/// running — a secured operator (enclave /crossym/operator) reads its status afterwards.
#[test]
fn unsecured_peer_neither_commands_nor_reads_a_secured_node() {
    // The attack succeeds against an unsecured node.
    let dir = common::temp_dir("sec-attack-open");
    let (mut node, mut hw, node_log) = node_and_robot(189, None, &dir);
    let (sent, commands, _, raw) = attack(189, 6.0);
    assert!(
        commands > 0,
        "the unsecured peer read no command of the unsecured node: {raw}"
    );
    assert!(
        common::wait_for_text(
            &node_log,
            "symmetry condition accepted: θ = 0.5000 rad",
            Duration::from_secs(10)
        ),
        "the unsecured node did not apply the peer's condition ({sent} sent: {raw})\n{}",
        common::log_tail(&node_log)
    );
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);

    // The same attack against a secured node fails.
    let domain = 190;
    let ks = shipped_keystore(domain, "sec-attack");
    let dir = common::temp_dir("sec-attack-secured");
    let (mut node, mut hw, node_log) = node_and_robot(domain, Some(&ks), &dir);
    let (sent, commands, statuses, raw) = attack(domain, 6.0);
    assert!(sent >= 20, "{raw}");
    assert_eq!(
        (commands, statuses),
        (0, 0),
        "the unsecured peer read the secured node's topics: {raw}"
    );
    let text = std::fs::read_to_string(&node_log).unwrap();
    assert!(
        !text.contains("symmetry condition accepted"),
        "the secured node applied a condition ({raw})\n{text}"
    );
    // The node ran on: its status reaches a secured operator, with the default condition.
    let seen = operator_statuses(domain, &ks, 5);
    assert!(
        seen.len() >= 5,
        "the secured operator saw {} statuses\n{}",
        seen.len(),
        common::log_tail(&node_log)
    );
    assert!(
        seen.iter().all(|s| s.condition.theta == 0.0),
        "{:?}",
        seen.iter().map(|s| s.condition.theta).collect::<Vec<_>>()
    );
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);
}

/// `std_srvs/SetBool` (the node's `~/pause`), as this test's own client writes it.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
struct SetBoolRequest {
    data: bool,
}
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
struct SetBoolResponse {
    success: bool,
    message: String,
}
impl ros2_client::Message for SetBoolRequest {}
impl ros2_client::Message for SetBoolResponse {}

/// A `~/pause` client of the node `/crossym` on a new node of `ctx`.
fn pause_client(
    ctx: &ros2_client::Context,
    tag: &str,
) -> (
    ros2_client::Node,
    Result<ros2_client::Client<SetBoolRequest, SetBoolResponse>, String>,
) {
    let mut n = plain_node(ctx, tag);
    let qos = dds::qos_reliable(10);
    let c = n
        .create_client(
            ros2_client::ServiceMapping::Enhanced,
            &ros2_client::Name::new("/crossym", "pause").unwrap(),
            &ros2_client::ServiceTypeName::new("std_srvs", "SetBool"),
            qos.clone(),
            qos,
        )
        .map_err(|e| dds::create_error("~/pause client", &e).to_string());
    (n, c)
}

/// (c) A secured peer whose permissions lack `~/pause` (enclave /crossym/perception of the
/// shipped policy: it may publish `~/task_pose` only) cannot pause: DDS Security refuses
/// its request writer (and a condition publisher), naming the topic and the enclave, and
/// the node logs no pause; the operator enclave, which the policy grants it, pauses the
/// same node.
#[test]
fn secured_peer_without_the_grant_cannot_pause() {
    let domain = 191;
    let ks = shipped_keystore(domain, "sec-pause");
    let dir = common::temp_dir("sec-pause-run");
    let (mut node, mut hw, node_log) = node_and_robot(domain, Some(&ks), &dir);

    let ctx = secured_context(domain, &ks, "/crossym/perception").expect("perception");
    let (mut pnode, refused) = pause_client(&ctx, "perception");
    let e = refused.err().expect("perception may not call ~/pause");
    assert!(
        e.contains("not allowed by the permissions of enclave /crossym/perception")
            && e.contains("rq/crossym/pauseRequest"),
        "{e}"
    );
    let e = dds::publisher::<crossym::msg::SymmetryCondition>(
        &mut pnode,
        "/crossym/symmetry_condition",
        dds::qos_reliable(10),
    )
    .err()
    .expect("perception may not publish conditions")
    .to_string();
    assert!(
        e.contains("/crossym/symmetry_condition not allowed by the permissions of enclave /crossym/perception"),
        "{e}"
    );
    drop(pnode);
    drop(ctx);
    // The operator's enclave may create the same client.
    let ctx = secured_context(domain, &ks, "/crossym/operator").expect("operator");
    let (_onode, client) = pause_client(&ctx, "operator");
    client.expect("the operator may call ~/pause");
    let text = std::fs::read_to_string(&node_log).unwrap();
    assert!(!text.contains("~/pause"), "{text}");
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);
}

/// (e) A request from another secured participant reaches the secured node: an operator
/// (enclave /crossym/operator) calls `~/pause` and is answered, and the node logs the pause.
/// The SetBool request's encrypted payload is not a multiple of 4 octets; RustDDS used to
/// take the CryptoFooter from the end of the padded DATA payload and fail to decrypt it
/// (`ring … 'Unspecified'`), so no such request or condition ever arrived (vendor/README.md).
#[test]
fn secured_operator_reaches_the_node() {
    let domain = 193;
    let ks = shipped_keystore(domain, "sec-operator");
    let dir = common::temp_dir("sec-operator-run");
    let (mut node, mut hw, node_log) = node_and_robot(domain, Some(&ks), &dir);
    let ctx = secured_context(domain, &ks, "/crossym/operator").expect("operator");
    let (_onode, client) = pause_client(&ctx, "operator");
    let client = client.expect("the operator may call ~/pause");
    let t0 = Instant::now();
    let mut answer = None;
    while answer.is_none() && t0.elapsed() < Duration::from_secs(30) {
        let _ = client.send_request(SetBoolRequest { data: true });
        let t1 = Instant::now();
        while t1.elapsed() < Duration::from_millis(500) {
            if let Ok(Some((_, r))) = client.receive_response() {
                answer = Some(r);
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    let answer = answer.expect("the operator's ~/pause was answered");
    assert!(answer.success, "{answer:?}");
    let text = std::fs::read_to_string(&node_log).unwrap();
    let pauses = text.matches("~/pause true from").count();
    assert!(pauses >= 1, "{}", common::log_tail(&node_log));
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);
}

/// (d) Enforce with a governance changed after signing: the node does not start, and says
/// why (RustDDS's signature check, naming the enclave's directory). Enforce with the node's
/// own certificate expired: it does not start, and gives the dates. Permissive with a
/// keystore that does not exist: the node starts unsecured and warns, naming the missing
/// keystore; Enforce with it: the node stops at once, naming it.
#[test]
fn enforce_refuses_bad_files_and_permissive_warns() {
    let domain = 192;
    let ks = shipped_keystore(domain, "sec-enforce");
    tamper_governance(&ks);
    let c = letters();
    let node = |ks: &Path, strategy: &str| {
        let mut cmd = crossym_sec(
            &[
                "node",
                "--config",
                &c,
                "--ros-args",
                "--enclave",
                "/crossym/node",
            ],
            Some((ks, strategy)),
        );
        cmd.env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_LOCALHOST_ONLY", "1");
        cmd
    };
    let o = node(&ks, "Enforce").output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("secured participant in domain 192 (enclave /crossym/node")
            && err.contains("does not match"),
        "{err}"
    );

    // The node's own certificate expired: refused at start with its dates (before, RustDDS
    // built the participant and every peer refused it: a node that ran alone, silently).
    let expired = common::temp_dir("sec-own-expired").join("keystore");
    copy_keystore(&shipped_keystore(domain, "sec-own-cert"), &expired);
    expire_certificate(&expired, "/crossym/node");
    let log = common::temp_dir("sec-own-expired-run").join("node.log");
    let mut n = common::Proc::spawn(node(&expired, "Enforce"), "node", domain, &log);
    let code = n.wait(Duration::from_secs(30), &log);
    let err = std::fs::read_to_string(&log).unwrap();
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("enclave /crossym/node: its identity certificate")
            && err.contains("not now")
            && err.contains("crossym security create-enclave"),
        "{err}"
    );

    let missing = common::temp_dir("sec-no-keystore").join("nowhere");
    let o = node(&missing, "Enforce").output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("ROS_SECURITY_STRATEGY=Enforce")
            && err.contains(&format!("{} is missing", missing.display())),
        "{err}"
    );

    let log = common::temp_dir("sec-permissive").join("node.log");
    let mut n = common::Proc::spawn(node(&missing, "Permissive"), "node", domain, &log);
    assert!(
        common::wait_for_text(&log, "running UNSECURED", Duration::from_secs(60)),
        "{}",
        common::log_tail(&log)
    );
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.contains("[WARN]") && text.contains(&format!("{} is missing", missing.display())),
        "{text}"
    );
    assert_eq!(n.term(), 0);
}

/// At least `n` statuses of the node `/crossym` in `domain`, as a secured operator of `ks`
/// reads them (within 20 s).
fn operator_statuses(domain: u16, ks: &Path, n: usize) -> Vec<crossym::msg::Status> {
    let ctx = secured_context(domain, ks, "/crossym/operator").expect("operator participant");
    let mut onode = plain_node(&ctx, "operator");
    let status = dds::subscription::<crossym::msg::Status>(
        &mut onode,
        "/crossym/status",
        dds::qos_reliable(100),
    )
    .expect("the operator may read the status");
    let t0 = Instant::now();
    let mut seen = Vec::new();
    while seen.len() < n && t0.elapsed() < Duration::from_secs(20) {
        while let Ok(Some((s, _))) = status.take() {
            seen.push(s);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    seen
}

/// (f) An unsecured peer (Cyclone DDS, no credentials) calls `~/pause` (SetBool true, written
/// on `rq/crossym/pauseRequest` as a plain DDS sample). Against an unsecured node the call
/// works — the node answers, pauses and says so on `~/status` (seen first, in this test);
/// against a secured node it gets no answer, no status, and the node never pauses: a
/// secured operator reads it running, not paused. The node logs the unprotected messages
/// it dropped.
#[test]
fn unsecured_peer_cannot_pause_a_secured_node() {
    let dir = common::temp_dir("sec-pause-open");
    let (mut node, mut hw, node_log) = node_and_robot(196, None, &dir);
    let v = attack_peer(196, 6.0, &["--pause"]);
    let n = |v: &serde_json::Value, k: &str| v[k].as_u64().unwrap_or(0);
    let text = std::fs::read_to_string(&node_log).unwrap();
    assert!(
        n(&v, "replies") > 0 && n(&v, "paused") > 0 && text.contains("~/pause true from"),
        "the unsecured node was not paused by the unsecured peer: {v}\n{}",
        common::log_tail(&node_log)
    );
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);

    let domain = 197;
    let ks = shipped_keystore(domain, "sec-pause-attack");
    let dir = common::temp_dir("sec-pause-secured");
    let (mut node, mut hw, node_log) = node_and_robot(domain, Some(&ks), &dir);
    let v = attack_peer(domain, 6.0, &["--pause"]);
    assert!(n(&v, "sent") >= 20, "{v}");
    assert_eq!(
        (n(&v, "replies"), n(&v, "statuses"), n(&v, "paused")),
        (0, 0, 0),
        "the unsecured peer reached the secured node's ~/pause: {v}"
    );
    let text = std::fs::read_to_string(&node_log).unwrap();
    assert!(
        !text.contains("~/pause"),
        "the secured node served the unsecured peer's ~/pause ({v})\n{text}"
    );
    // The node's log names what it refused: RustDDS drops the peer's unprotected discovery
    // (SEDP) in a domain whose governance protects RTPS, at ERROR.
    assert!(
        text.contains("Received an unprotected message containing a writer submessage"),
        "the secured node did not log the unsecured peer\n{}",
        common::log_tail(&node_log)
    );
    let seen = operator_statuses(domain, &ks, 5);
    assert!(
        seen.len() >= 5 && seen.iter().all(|s| !s.paused),
        "the secured operator saw {} statuses, paused: {:?}\n{}",
        seen.len(),
        seen.iter().map(|s| s.paused).collect::<Vec<_>>(),
        common::log_tail(&node_log)
    );
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);
}

/// Replaces the certificate of `enclave` (e.g. `/crossym/operator`) in `ks` by one for the
/// same key and subject, signed by the keystore's identity CA, that expired in 2021
/// (`openssl ca` with explicit dates: `openssl x509` 3.0 has no `-not_after`).
fn expire_certificate(ks: &Path, enclave: &str) {
    let dir = ks.join("enclaves").join(enclave.trim_start_matches('/'));
    let work = common::temp_dir("sec-expire-ca");
    std::fs::write(work.join("index.txt"), "").unwrap();
    std::fs::write(work.join("serial"), "1000\n").unwrap();
    std::fs::write(
        work.join("ca.cnf"),
        format!(
            "[ca]\ndefault_ca = a\n[a]\ndatabase = {0}/index.txt\nnew_certs_dir = {0}\n\
             serial = {0}/serial\ndefault_md = sha256\npolicy = p\nunique_subject = no\n\
             [p]\ncommonName = supplied\n",
            work.display()
        ),
    )
    .unwrap();
    let openssl = |args: &[&str]| {
        let o = Command::new("openssl")
            .args(args)
            .output()
            .expect("openssl starts");
        assert!(
            o.status.success(),
            "openssl {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let csr = s(&work.join("req.pem"));
    let cert = s(&dir.join("cert.pem"));
    let key = s(&dir.join("key.pem"));
    openssl(&[
        "x509",
        "-x509toreq",
        "-in",
        &cert,
        "-signkey",
        &key,
        "-out",
        &csr,
    ]);
    std::fs::remove_file(&cert).unwrap();
    openssl(&[
        "ca",
        "-batch",
        "-notext",
        "-preserveDN",
        "-config",
        &s(&work.join("ca.cnf")),
        "-cert",
        &s(&ks.join("public/ca.cert.pem")),
        "-keyfile",
        &s(&ks.join("private/ca.key.pem")),
        "-startdate",
        "20200101000000Z",
        "-enddate",
        "20210101000000Z",
        "-in",
        &csr,
        "-out",
        &cert,
    ]);
}

/// `openssl verify -CAfile CA CERT`'s output (its verdict, or the error).
fn openssl_verify(ca: &Path, cert: &Path) -> String {
    let o = Command::new("openssl")
        .arg("verify")
        .arg("-CAfile")
        .arg(ca)
        .arg(cert)
        .output()
        .expect("openssl starts");
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A secured peer of `ks` in `domain` for up to `limit`: as `/crossym/operator` it calls
/// `~/pause` with `data` until answered, and with `condition` also as `/crossym/demo` it
/// publishes a condition (θ 0.5, λ 0.8, σ 1) every 200 ms. The answer, if one came.
fn secured_peer(
    domain: u16,
    ks: &Path,
    data: bool,
    condition: bool,
    limit: Duration,
) -> Option<SetBoolResponse> {
    let octx = raw_secured_context(domain, ks, "/crossym/operator").expect("operator participant");
    let (_onode, client) = pause_client(&octx, "operator");
    let client = client.expect("the operator may call ~/pause");
    let dctx = raw_secured_context(domain, ks, "/crossym/demo").expect("demo participant");
    let mut dnode = plain_node(&dctx, "demo");
    let conditions = dds::publisher::<crossym::msg::SymmetryCondition>(
        &mut dnode,
        "/crossym/symmetry_condition",
        dds::qos_reliable(10),
    )
    .expect("the demo may publish conditions");
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        let _ = client.send_request(SetBoolRequest { data });
        if condition {
            let _ = conditions.publish(crossym::msg::SymmetryCondition {
                theta: 0.5,
                scale: 0.8,
                reflection: 1,
                ..Default::default()
            });
        }
        let t1 = Instant::now();
        while t1.elapsed() < Duration::from_millis(200) {
            if let Ok(Some((_, r))) = client.receive_response() {
                return Some(r);
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    None
}

/// (g) Peers with credentials the node's identity CA does not vouch for, against a running
/// secured node: a whole keystore of another CA (its own governance and permissions, all
/// valid under that CA), and the node's own keystore with the operator's and the demo's
/// certificates replaced by expired ones signed by the right CA. Each runs secured (RustDDS
/// checks its own certificate against its own identity CA only), calls `~/pause` and
/// publishes a condition for 8 s: no answer, the node neither pauses nor applies the
/// condition, and it logs why it refused each (`Certificate signature verification
/// failure`, `Certificate not valid now`).
/// Seen working first: the keystore's own operator is answered by the same node.
#[test]
fn foreign_ca_or_expired_certificate_is_refused_by_a_running_node() {
    let domain = 198;
    let ks = shipped_keystore(domain, "sec-cert");
    let foreign = shipped_keystore(domain, "sec-cert-foreign");
    let expired = common::temp_dir("sec-cert-expired").join("keystore");
    copy_keystore(&ks, &expired);
    for e in ["/crossym/operator", "/crossym/demo"] {
        expire_certificate(&expired, e);
    }
    // What openssl says of the peers' certificates.
    let ca = ks.join("public/identity_ca.cert.pem");
    let v = openssl_verify(&ca, &expired.join("enclaves/crossym/operator/cert.pem"));
    assert!(v.contains("certificate has expired"), "{v}");
    let v = openssl_verify(&ca, &foreign.join("enclaves/crossym/operator/cert.pem"));
    assert!(!v.contains(": OK"), "{v}");

    let dir = common::temp_dir("sec-cert-run");
    let (mut node, mut hw, node_log) = node_and_robot(domain, Some(&ks), &dir);
    // The keystore's own operator is answered (~/pause false: the node stays unpaused; no
    // condition, so the node keeps the default one).
    let answer = secured_peer(domain, &ks, false, false, Duration::from_secs(30));
    assert!(
        answer.is_some_and(|a| a.success),
        "the node's own operator got no answer\n{}",
        common::log_tail(&node_log)
    );
    for (what, store) in [
        ("a foreign CA", &foreign),
        ("an expired certificate", &expired),
    ] {
        let answer = secured_peer(domain, store, true, true, Duration::from_secs(8));
        assert!(
            answer.is_none(),
            "a peer with {what} was answered: {answer:?}\n{}",
            common::log_tail(&node_log)
        );
    }
    let text = std::fs::read_to_string(&node_log).unwrap();
    assert!(
        !text.contains("~/pause true") && !text.contains("symmetry condition accepted"),
        "the node obeyed a refused peer\n{text}"
    );
    // RustDDS logs each refused handshake at ERROR. Which side verifies first is fixed by
    // the subjects (a participant's GUID prefix starts with a hash of its certificate's
    // subject; the larger initiates): the operator's certificate reaches the node in a
    // request, the demo's in a reply. The node must have refused the foreign CA's and an
    // expired certificate by their own faults: at least one of the two expired ones, since
    // under load a handshake reply can fail to reach the node at all (seen once in 3 runs
    // of the suite, 2026-12-05: the demo re-sent its reply every second, the node logged
    // none) — that peer then never authenticates either, which the checks above show.
    assert!(
        text.contains("Certificate signature verification failure"),
        "the node did not log the foreign CA's refusal\n{}",
        common::log_tail(&node_log)
    );
    assert!(
        ["operator", "demo"]
            .iter()
            .any(|e| text.contains(&format!("Certificate not valid now: \"CN=/crossym/{e}\""))),
        "the node did not log an expired certificate's refusal\n{}",
        common::log_tail(&node_log)
    );
    let seen = operator_statuses(domain, &ks, 5);
    assert!(
        seen.len() >= 5 && seen.iter().all(|s| !s.paused && s.condition.theta == 0.0),
        "{} statuses\n{}",
        seen.len(),
        common::log_tail(&node_log)
    );
    assert_eq!(node.term(), 0);
    assert_eq!(hw.term(), 0);
}
