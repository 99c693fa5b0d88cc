//! An SROS2 keystore, laid out file for file as sros2's `ros2 security` lays it out
//! (`sros2/keystore/_keystore.py`, `_enclave.py`, `_permission.py`):
//!
//! ```text
//! KEYSTORE/
//!   public/ca.cert.pem                    the CA (CN=sros2CA), self-signed
//!   public/identity_ca.cert.pem     -> ca.cert.pem
//!   public/permissions_ca.cert.pem  -> ca.cert.pem
//!   private/ca.key.pem                    its key (mode 0600 here; sros2 leaves the umask's)
//!   private/identity_ca.key.pem     -> ca.key.pem
//!   private/permissions_ca.key.pem  -> ca.key.pem
//!   enclaves/governance.xml               the domain's governance
//!   enclaves/governance.p7s               … signed by the permissions CA
//!   enclaves/<enclave>/                   e.g. enclaves/crossym/node/ for /crossym/node
//!     cert.pem                            CN=<enclave>, issued by the identity CA
//!     key.pem                             its key (0600)
//!     identity_ca.cert.pem          -> ../../../public/identity_ca.cert.pem
//!     permissions_ca.cert.pem       -> ../../../public/permissions_ca.cert.pem
//!     governance.p7s                -> ../../governance.p7s
//!     permissions.xml                     what the enclave may do
//!     permissions.p7s                     … signed by the permissions CA
//! ```
//!
//! The links are relative symbolic links, as sros2 makes them, so a keystore can be moved or
//! copied with `cp -a`. The enclave directory is what `ROS_SECURITY_KEYSTORE` plus the enclave
//! name points a ROS 2 process at (rcl's `rcl_get_secure_root`), and what RustDDS's
//! `DomainParticipantSecurityConfigFiles::with_ros_default_names` reads.

use std::path::{Component, Path, PathBuf};

use super::error::SecurityError;
use super::pki::{self, KeyPair};
use super::policy::{self, Enclave, Policy};

/// The CA's common name, sros2's.
pub const CA_COMMON_NAME: &str = "sros2CA";

/// Files every keystore has (sros2's `is_valid_keystore`).
const REQUIRED: [&str; 5] = [
    "public/permissions_ca.cert.pem",
    "public/identity_ca.cert.pem",
    "private/permissions_ca.key.pem",
    "private/identity_ca.key.pem",
    "enclaves/governance.p7s",
];

/// A keystore directory.
#[derive(Debug, Clone)]
pub struct Keystore {
    root: PathBuf,
}

/// Seconds since the Unix epoch, now.
fn now_unix() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() as i64)
}

fn write(path: &Path, bytes: &[u8], private: bool) -> Result<(), SecurityError> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create(true).truncate(true);
    if private {
        opts.mode(0o600);
    }
    let mut f = opts.open(path).map_err(SecurityError::io(path))?;
    f.write_all(bytes).map_err(SecurityError::io(path))
}

/// `dst` → `src` (a relative path), replacing whatever `dst` was unless it already is
/// that file (sros2's `create_symlink`).
fn symlink(src: &Path, dst: &Path) -> Result<(), SecurityError> {
    let parent = dst.parent().unwrap_or(Path::new("."));
    if dst.symlink_metadata().is_ok() {
        let same = match (
            std::fs::canonicalize(dst),
            std::fs::canonicalize(parent.join(src)),
        ) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        };
        if same {
            return Ok(());
        }
        std::fs::remove_file(dst).map_err(SecurityError::io(dst))?;
    }
    std::os::unix::fs::symlink(src, dst).map_err(SecurityError::io(dst))
}

/// Checks an enclave name as rcl checks a namespace: absolute, `/`-separated tokens of
/// letters, digits and `_`, none empty or starting with a digit.
pub fn check_enclave_name(name: &str) -> Result<(), SecurityError> {
    let bad = |reason| {
        Err(SecurityError::EnclaveName {
            name: name.to_string(),
            reason,
        })
    };
    if !name.starts_with('/') {
        return bad("must start with /");
    }
    if name == "/" {
        return Ok(());
    }
    if name.ends_with('/') {
        return bad("must not end with /");
    }
    for token in name[1..].split('/') {
        if token.is_empty() {
            return bad("must not contain //");
        }
        if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return bad("may hold only letters, digits, _ and /");
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            return bad("no part may start with a digit");
        }
    }
    Ok(())
}

/// `..` repeated once per component of `rel` (a relative directory).
fn up(rel: &Path) -> PathBuf {
    rel.components()
        .filter(|c| matches!(c, Component::Normal(_)))
        .map(|_| Path::new(".."))
        .collect()
}

impl Keystore {
    /// The keystore at `root` (nothing is checked or created).
    pub fn at(root: impl Into<PathBuf>) -> Self {
        Self { root: root.into() }
    }

    /// Its directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The first file of a complete keystore that is missing, or `None` when complete.
    pub fn missing(&self) -> Option<PathBuf> {
        REQUIRED
            .iter()
            .map(|f| self.root.join(f))
            .find(|p| !p.is_file())
    }

    /// The enclave directory of `enclave` (`/crossym/node` → `enclaves/crossym/node`).
    pub fn enclave_dir(&self, enclave: &str) -> PathBuf {
        self.root
            .join("enclaves")
            .join(enclave.trim_start_matches('/'))
    }

    /// `ros2 security create_keystore`: the directories, one CA (identity and
    /// permissions CA both link to it), the governance for `domain_id` and its signature.
    /// Refuses a directory that already holds a complete keystore; completes a partial one.
    pub fn create(root: impl Into<PathBuf>, domain_id: u16) -> Result<Self, SecurityError> {
        let ks = Self::at(root);
        if ks.missing().is_none() {
            return Err(SecurityError::KeystoreExists(ks.root.clone()));
        }
        for d in ["public", "private", "enclaves"] {
            let p = ks.root.join(d);
            std::fs::create_dir_all(&p).map_err(SecurityError::io(&p))?;
        }
        let (public, private) = (ks.root.join("public"), ks.root.join("private"));
        let cas_present = REQUIRED[..4].iter().all(|f| ks.root.join(f).is_file());
        if !cas_present {
            let ca = pki::new_key_and_cert(CA_COMMON_NAME, None, now_unix())?;
            write(&private.join("ca.key.pem"), &pki::key_pem(&ca.key)?, true)?;
            write(
                &public.join("ca.cert.pem"),
                &pki::cert_pem(&ca.cert)?,
                false,
            )?;
            for role in ["identity_ca", "permissions_ca"] {
                symlink(
                    Path::new("ca.cert.pem"),
                    &public.join(format!("{role}.cert.pem")),
                )?;
                symlink(
                    Path::new("ca.key.pem"),
                    &private.join(format!("{role}.key.pem")),
                )?;
            }
        }
        let gov = ks.root.join("enclaves/governance.xml");
        if !gov.is_file() {
            write(&gov, policy::governance_xml(domain_id).as_bytes(), false)?;
        }
        let signed = ks.root.join("enclaves/governance.p7s");
        if !signed.is_file() {
            let xml = std::fs::read(&gov).map_err(SecurityError::io(&gov))?;
            write(
                &signed,
                &pki::sign_smime(&ks.permissions_ca()?, &xml)?,
                false,
            )?;
        }
        Ok(ks)
    }

    /// Opens an existing keystore (every file of [`Keystore::missing`] present).
    pub fn open(root: impl Into<PathBuf>) -> Result<Self, SecurityError> {
        let ks = Self::at(root);
        match ks.missing() {
            None => Ok(ks),
            Some(missing) => Err(SecurityError::NotAKeystore {
                path: ks.root.clone(),
                missing,
            }),
        }
    }

    fn permissions_ca(&self) -> Result<KeyPair, SecurityError> {
        pki::read_key_pair(
            &self.root.join("public/permissions_ca.cert.pem"),
            &self.root.join("private/permissions_ca.key.pem"),
        )
    }

    /// `ros2 security create_enclave`: the enclave's directory, links to the CAs and the
    /// governance, a key and certificate `CN=<enclave>` from the identity CA (kept if both
    /// exist), and sros2's default permissions (everything allowed) for `domain_id`, signed.
    pub fn create_enclave(&self, enclave: &str, domain_id: u16) -> Result<PathBuf, SecurityError> {
        check_enclave_name(enclave)?;
        if let Some(missing) = self.missing() {
            return Err(SecurityError::NotAKeystore {
                path: self.root.clone(),
                missing,
            });
        }
        let dir = self.enclave_dir(enclave);
        std::fs::create_dir_all(&dir).map_err(SecurityError::io(&dir))?;
        // enclaves/a/b → ../../public/…, ../governance.p7s relative to enclaves/.
        let rel = up(Path::new(enclave.trim_start_matches('/')));
        for ca in ["identity_ca.cert.pem", "permissions_ca.cert.pem"] {
            symlink(&rel.join("..").join("public").join(ca), &dir.join(ca))?;
        }
        symlink(&rel.join("governance.p7s"), &dir.join("governance.p7s"))?;
        let (cert, key) = (dir.join("cert.pem"), dir.join("key.pem"));
        if !cert.is_file() || !key.is_file() {
            let ca = pki::read_key_pair(
                &self.root.join("public/identity_ca.cert.pem"),
                &self.root.join("private/identity_ca.key.pem"),
            )?;
            let pair = pki::new_key_and_cert(enclave, Some(&ca), now_unix())?;
            write(&key, &pki::key_pem(&pair.key)?, true)?;
            write(&cert, &pki::cert_pem(&pair.cert)?, false)?;
        }
        self.write_permissions(&Policy::allow_all(enclave), domain_id)?;
        Ok(dir)
    }

    /// `ros2 security create_permission`: the enclave's permissions from its entry in the
    /// policy file, signed by the permissions CA. The enclave must exist (its certificate
    /// gives the permissions' validity).
    pub fn create_permission(
        &self,
        enclave: &str,
        policy_file: &Path,
        domain_id: u16,
    ) -> Result<PathBuf, SecurityError> {
        check_enclave_name(enclave)?;
        let policy = Policy::read(policy_file)?;
        let e = policy.enclave(enclave, policy_file)?;
        self.write_permissions(e, domain_id)
    }

    /// `ros2 security generate_artifacts`: the keystore (made if it is not one), an enclave
    /// per name in `enclaves` and per enclave of each policy file, and the policies'
    /// permissions for theirs. Returns the enclave directories written.
    pub fn generate_artifacts(
        root: impl Into<PathBuf>,
        enclaves: &[String],
        policy_files: &[PathBuf],
        domain_id: u16,
    ) -> Result<(Self, Vec<PathBuf>), SecurityError> {
        let root = root.into();
        let ks = match Self::open(&root) {
            Ok(ks) => ks,
            Err(_) => Self::create(&root, domain_id)?,
        };
        let mut written = Vec::new();
        for e in enclaves {
            written.push(ks.create_enclave(e, domain_id)?);
        }
        for file in policy_files {
            let policy = Policy::read(file)?;
            for e in &policy.enclaves {
                check_enclave_name(&e.path)?;
                if !enclaves.contains(&e.path) {
                    ks.create_enclave(&e.path, domain_id)?;
                }
                written.push(ks.write_permissions(e, domain_id)?);
            }
        }
        written.dedup();
        Ok((ks, written))
    }

    fn write_permissions(&self, e: &Enclave, domain_id: u16) -> Result<PathBuf, SecurityError> {
        let dir = self.enclave_dir(&e.path);
        let cert = dir.join("cert.pem");
        if !cert.is_file() {
            return Err(SecurityError::NoEnclave {
                keystore: self.root.clone(),
                enclave: e.path.clone(),
                cert,
            });
        }
        let (from, to) = pki::validity(&pki::read_cert(&cert)?)?;
        let xml = policy::permissions_xml(e, domain_id, (&from, &to));
        write(&dir.join("permissions.xml"), xml.as_bytes(), false)?;
        let signed = pki::sign_smime(&self.permissions_ca()?, xml.as_bytes())?;
        write(&dir.join("permissions.p7s"), &signed, false)?;
        Ok(dir)
    }

    /// `ros2 security list_enclaves`: every directory under `enclaves/` holding a `key.pem`,
    /// as enclave names, sorted.
    pub fn enclaves(&self) -> Result<Vec<String>, SecurityError> {
        fn walk(dir: &Path, base: &Path, out: &mut Vec<String>) -> Result<(), SecurityError> {
            for entry in std::fs::read_dir(dir).map_err(SecurityError::io(dir))? {
                let p = entry.map_err(SecurityError::io(dir))?.path();
                if p.is_dir() && !p.is_symlink() {
                    if p.join("key.pem").is_file() {
                        let rel = p.strip_prefix(base).unwrap_or(&p);
                        out.push(format!("/{}", rel.display()));
                    }
                    walk(&p, base, out)?;
                }
            }
            Ok(())
        }
        let base = self.root.join("enclaves");
        let mut out = Vec::new();
        walk(&base, &base, &mut out)?;
        out.sort();
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enclave_names_follow_ros_namespaces() {
        for ok in ["/", "/crossym/node", "/a_1/b"] {
            check_enclave_name(ok).unwrap();
        }
        for (bad, why) in [
            ("crossym", "start with /"),
            ("/a/", "end with /"),
            ("/a//b", "//"),
            ("/a-b", "only letters"),
            ("/1a", "digit"),
            ("/a/../b", "only letters"),
        ] {
            let e = check_enclave_name(bad).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }

    #[test]
    fn relative_links_climb_out_of_the_enclave() {
        assert_eq!(up(Path::new("crossym/node")), Path::new("../.."));
        assert_eq!(up(Path::new("a")), Path::new(".."));
    }
}
