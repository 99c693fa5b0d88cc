//! What can go wrong making a keystore: every variant names the file or the name at fault.

use std::path::PathBuf;

/// An error of [`crate::security`]: a keystore, an enclave, a policy or a signature.
#[derive(Debug, thiserror::Error)]
pub enum SecurityError {
    /// A file or directory could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// OpenSSL refused an operation (key generation, a certificate, a signature).
    #[error("{what}: {source}")]
    Crypto {
        /// The operation, naming its file where there is one.
        what: String,
        /// OpenSSL's error stack.
        source: openssl::error::ErrorStack,
    },
    /// `create-keystore` on a directory that already holds a complete keystore.
    #[error("{} is already a keystore (public/, private/ and enclaves/governance.p7s exist); nothing was changed", .0.display())]
    KeystoreExists(PathBuf),
    /// An enclave or permission asked of a directory that is not a keystore.
    #[error(
        "{path} is not a keystore: {missing} is missing (make one with `crossym security create-keystore {path}`)",
        path = .path.display(),
        missing = .missing.display()
    )]
    NotAKeystore {
        /// The directory given as the keystore.
        path: PathBuf,
        /// The first required file not found.
        missing: PathBuf,
    },
    /// An enclave name that is not a valid ROS 2 namespace (`/crossym/node`).
    #[error(
        "enclave name {name:?}: {reason} (an enclave is named like a ROS namespace: /crossym/node)"
    )]
    EnclaveName {
        /// The name given.
        name: String,
        /// The rule it breaks.
        reason: &'static str,
    },
    /// `create-permission` for an enclave whose certificate does not exist yet.
    #[error(
        "enclave {enclave} has no certificate {cert} (make it with `crossym security create-enclave {keystore} {enclave}`)",
        cert = .cert.display(),
        keystore = .keystore.display()
    )]
    NoEnclave {
        /// The keystore.
        keystore: PathBuf,
        /// The enclave.
        enclave: String,
        /// The certificate looked for.
        cert: PathBuf,
    },
    /// A policy file that does not follow sros2's policy schema (version 0.2.0).
    #[error("{path}:{line}: {message}", path = .path.display())]
    Policy {
        /// The policy file.
        path: PathBuf,
        /// The line of the offending element (1 for the document as a whole).
        line: u32,
        /// What is wrong.
        message: String,
    },
    /// A policy file without the enclave asked for.
    #[error("{path}: no <enclave path=\"{enclave}\"> (enclaves in the file: {known})", path = .path.display())]
    PolicyEnclave {
        /// The policy file.
        path: PathBuf,
        /// The enclave asked for.
        enclave: String,
        /// The enclaves the file has, comma-separated.
        known: String,
    },
}

impl SecurityError {
    /// An [`SecurityError::Io`] for `path`.
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.into();
        move |source| Self::Io { path, source }
    }

    /// A [`SecurityError::Crypto`] for the operation `what`.
    pub(crate) fn crypto(
        what: impl Into<String>,
    ) -> impl FnOnce(openssl::error::ErrorStack) -> Self {
        let what = what.into();
        move |source| Self::Crypto { what, source }
    }
}
