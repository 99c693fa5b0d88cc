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
    assert_eq!(out.lines().count(), 3, "{out}");
    let listed = security(7, &["list-enclaves", k]);
    assert_eq!(
        listed,
        "/crossym/node\n/crossym/operator\n/crossym/perception\n"
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
    let gov = tampered.join("enclaves/governance.p7s");
    let text = std::fs::read_to_string(&gov).unwrap();
    let changed = text.replacen(
        "<rtps_protection_kind>SIGN",
        "<rtps_protection_kind>NONE",
        1,
    );
    assert_ne!(text, changed);
    std::fs::write(&gov, changed).unwrap();
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
