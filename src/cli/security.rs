//! `crossym security`: SROS2 keystores without the ROS tools (`ros2 security`), through
//! `crossym::ros::security` (cargo feature `security`). Each verb takes the arguments of its
//! `ros2 security` namesake; the governance and permissions are written for `ROS_DOMAIN_ID`
//! (default 0), as sros2 writes them.
// Without the `security` feature only the options remain (`run` says how to get the command).
#![cfg_attr(not(feature = "security"), allow(dead_code, unused_imports))]

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

/// Options of `crossym security`.
#[derive(Debug, clap::Args)]
pub struct SecurityArgs {
    #[command(subcommand)]
    pub verb: SecurityVerb,
}

/// The verbs of `crossym security`, named as `ros2 security`'s.
#[derive(Debug, Subcommand)]
pub enum SecurityVerb {
    /// Create a keystore: one CA (identity and permissions CA), the domain's governance and
    /// its signature (`ros2 security create_keystore`). Refuses an existing keystore.
    CreateKeystore {
        /// The keystore directory (made if missing).
        keystore: PathBuf,
    },
    /// Create an enclave: key and certificate CN=NAME from the identity CA, links to the CAs
    /// and governance, allow-everything permissions (`ros2 security create_enclave`).
    CreateEnclave {
        /// The keystore directory.
        keystore: PathBuf,
        /// The enclave, e.g. /crossym/node.
        name: String,
    },
    /// Write and sign an enclave's permissions from its entry in a policy file
    /// (`ros2 security create_permission`; e.g. config/security/policy.xml).
    CreatePermission {
        /// The keystore directory.
        keystore: PathBuf,
        /// The enclave, e.g. /crossym/node (created by create-enclave first).
        name: String,
        /// The sros2 policy file (version 0.2.0).
        policy: PathBuf,
    },
    /// Keystore, enclaves and permissions in one go (`ros2 security generate_artifacts`):
    /// the keystore if missing, each enclave of -e and of the policy files, each policy
    /// enclave's permissions.
    GenerateArtifacts {
        /// The keystore directory (default: ROS_SECURITY_KEYSTORE).
        #[arg(short, long)]
        keystore: Option<PathBuf>,
        /// Enclaves to create with allow-everything permissions.
        #[arg(short, long, num_args = 1..)]
        enclaves: Vec<String>,
        /// Policy files whose enclaves to create, with their permissions.
        #[arg(short, long, num_args = 1..)]
        policy_files: Vec<PathBuf>,
    },
    /// List the enclaves of a keystore (`ros2 security list_enclaves`).
    ListEnclaves {
        /// The keystore directory.
        keystore: PathBuf,
    },
}

/// Without the `security` feature: an error saying how to build the command.
#[cfg(not(feature = "security"))]
pub fn run(_: &SecurityArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!(
        "`crossym security` needs the `security` feature (SROS2 / DDS Security, links the \
         system's OpenSSL: libssl-dev and pkg-config to build), which this build of crossym \
         leaves out: `cargo build --release --features security` (or `cargo run --release \
         --features security -- security …`)"
    )
}

/// `crossym security`.
#[cfg(feature = "security")]
pub fn run(a: &SecurityArgs) -> anyhow::Result<ExitCode> {
    use crossym::ros::dds::DdsSettings;
    use crossym::ros::security::Keystore;

    let domain = DdsSettings::from_env()?.domain_id;
    match &a.verb {
        SecurityVerb::CreateKeystore { keystore } => {
            Keystore::create(keystore, domain)?;
            println!(
                "created keystore {} (CA CN={}, governance for domain {domain})",
                keystore.display(),
                crossym::ros::security::keystore::CA_COMMON_NAME
            );
        }
        SecurityVerb::CreateEnclave { keystore, name } => {
            let dir = Keystore::open(keystore)?.create_enclave(name, domain)?;
            println!("created enclave {name} in {}", dir.display());
        }
        SecurityVerb::CreatePermission {
            keystore,
            name,
            policy,
        } => {
            let dir = Keystore::open(keystore)?.create_permission(name, policy, domain)?;
            println!(
                "wrote {} from {} (domain {domain})",
                dir.join("permissions.p7s").display(),
                policy.display()
            );
        }
        SecurityVerb::GenerateArtifacts {
            keystore,
            enclaves,
            policy_files,
        } => {
            let keystore = match keystore {
                Some(k) => k.clone(),
                None => std::env::var_os("ROS_SECURITY_KEYSTORE")
                    .map(PathBuf::from)
                    .ok_or_else(|| {
                        anyhow::anyhow!("no keystore: give -k DIR or set ROS_SECURITY_KEYSTORE")
                    })?,
            };
            let (_, dirs) =
                Keystore::generate_artifacts(&keystore, enclaves, policy_files, domain)?;
            for d in dirs {
                println!("wrote {}", d.display());
            }
        }
        SecurityVerb::ListEnclaves { keystore } => {
            for e in Keystore::open(keystore)?.enclaves()? {
                println!("{e}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::SecurityVerb;
    use crate::cli::{Cli, Command};

    #[test]
    fn verbs_parse_as_ros2_securitys() {
        let parse = |args: &[&str]| match Cli::try_parse_from(args).unwrap().command {
            Command::Security(a) => a.verb,
            other => panic!("{other:?}"),
        };
        match parse(&[
            "crossym",
            "security",
            "create-permission",
            "ks",
            "/crossym/node",
            "p.xml",
        ]) {
            SecurityVerb::CreatePermission {
                keystore,
                name,
                policy,
            } => {
                assert_eq!(
                    (keystore.to_str(), name.as_str(), policy.to_str()),
                    (Some("ks"), "/crossym/node", Some("p.xml"))
                );
            }
            other => panic!("{other:?}"),
        }
        match parse(&[
            "crossym",
            "security",
            "generate-artifacts",
            "-k",
            "ks",
            "-e",
            "/a",
            "/b",
            "-p",
            "p.xml",
        ]) {
            SecurityVerb::GenerateArtifacts {
                keystore,
                enclaves,
                policy_files,
            } => {
                assert_eq!(keystore.as_deref().and_then(|k| k.to_str()), Some("ks"));
                assert_eq!(enclaves, ["/a", "/b"]);
                assert_eq!(policy_files.len(), 1);
            }
            other => panic!("{other:?}"),
        }
    }
}
