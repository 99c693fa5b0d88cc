//! SROS2 keystores without the ROS tools (cargo feature `security`): what
//! `crossym security create-keystore | create-enclave | create-permission |
//! generate-artifacts | list-enclaves` run, file for file what sros2's `ros2 security`
//! writes, so that either tool's keystore serves the other's processes.
//!
//! - [`keystore`]: the tree (`public/`, `private/`, `enclaves/`), the CA, the enclaves;
//! - [`policy`]: sros2 policy files and the DDS Security governance and permissions
//!   documents made from them (topic names mangled as ROS 2 does: `rt/`, `rq/…Request`,
//!   `rr/…Reply`);
//! - [`pki`]: ECDSA P-256 keys, X.509 certificates and S/MIME signatures (OpenSSL through
//!   the `openssl` crate, which RustDDS's DDS Security links anyway: no cryptography here);
//! - [`SecurityError`]: what went wrong, naming the file.
//!
//! Processes run secured from these files through [`crate::sros2`] (SROS2's variables) and
//! [`crate::dds::DdsSettings::context_with_hook`] (docs/guide/security.md).
//!
//! ```no_run
//! use crossym_ros::security::Keystore;
//! let ks = Keystore::create("keystore", 0)?;
//! ks.create_enclave("/crossym/node", 0)?;
//! ks.create_permission("/crossym/node", "config/security/policy.xml".as_ref(), 0)?;
//! # Ok::<(), crossym_ros::security::SecurityError>(())
//! ```

mod error;
pub mod keystore;
pub mod pki;
pub mod policy;

pub use error::SecurityError;
pub use keystore::Keystore;
pub use policy::Policy;
