//! The keystore's cryptography, all of it OpenSSL's (the `openssl` crate, which RustDDS's
//! DDS Security already links): ECDSA P-256 keys, X.509 certificates, and S/MIME signatures
//! of the governance and permissions documents.
//!
//! As sros2 makes them (`sros2/_utilities.py`):
//! - keys: `prime256v1` (DDS Security 1.1 §9.3.1), written as unencrypted PKCS#8 PEM
//!   (`-----BEGIN PRIVATE KEY-----`), which RustDDS reads (ring's `from_pkcs8`);
//! - certificates: X.509 v3, a random 159-bit serial, valid from one day before now (so a
//!   peer whose clock is a little behind does not see it as future) for 3650 days, signed
//!   with ECDSA-SHA256; the CA with `basicConstraints` critical `CA:TRUE, pathlen:1`, an
//!   enclave's with non-critical `CA:FALSE`; subject `CN=<name>`;
//! - signed documents: `PKCS7_sign` with `PKCS7_DETACHED | PKCS7_TEXT` and the signer's
//!   certificate in the signature, written by `SMIME_write_PKCS7` as `multipart/signed`
//!   (clear text, then the base64 signature) — what `openssl smime -sign -text` writes and
//!   `openssl smime -verify` checks, and what RustDDS's access control parses.

use std::path::Path;

use openssl::asn1::Asn1Time;
use openssl::bn::{BigNum, MsbOption};
use openssl::ec::{EcGroup, EcKey};
use openssl::hash::MessageDigest;
use openssl::nid::Nid;
use openssl::pkcs7::{Pkcs7, Pkcs7Flags};
use openssl::pkey::{PKey, Private};
use openssl::stack::Stack;
use openssl::x509::extension::BasicConstraints;
use openssl::x509::{X509Name, X509NameBuilder, X509};

use super::error::SecurityError;

/// Days a certificate is valid (sros2's fixed ten years).
pub const VALID_DAYS: i64 = 3650;
/// How far before now a certificate becomes valid (sros2: one day).
pub const BACKDATE_S: i64 = 86_400;

/// A private key and its certificate.
pub struct KeyPair {
    /// The ECDSA P-256 private key.
    pub key: PKey<Private>,
    /// The X.509 certificate of its public key.
    pub cert: X509,
}

/// A new ECDSA P-256 key.
fn new_key() -> Result<PKey<Private>, SecurityError> {
    let group = EcGroup::from_curve_name(Nid::X9_62_PRIME256V1)
        .map_err(SecurityError::crypto("the P-256 curve"))?;
    let ec = EcKey::generate(&group).map_err(SecurityError::crypto("an ECDSA P-256 key"))?;
    PKey::from_ec_key(ec).map_err(SecurityError::crypto("an ECDSA P-256 key"))
}

/// `CN=<common_name>`.
fn common_name(common_name: &str) -> Result<X509Name, SecurityError> {
    let what = || format!("the subject name CN={common_name}");
    let mut b = X509NameBuilder::new().map_err(SecurityError::crypto(what()))?;
    b.append_entry_by_nid(Nid::COMMONNAME, common_name)
        .map_err(SecurityError::crypto(what()))?;
    Ok(b.build())
}

/// A new key and its certificate `CN=<subject>`, valid from `now_unix − 1 day` for 3650
/// days: a self-signed CA when `issuer` is `None`, else an end entity signed by `issuer`.
pub fn new_key_and_cert(
    subject: &str,
    issuer: Option<&KeyPair>,
    now_unix: i64,
) -> Result<KeyPair, SecurityError> {
    let what = || format!("the certificate of CN={subject}");
    let crypto = |e| SecurityError::crypto(what())(e);
    let key = new_key()?;
    let name = common_name(subject)?;
    let mut b = X509::builder().map_err(crypto)?;
    b.set_version(2).map_err(crypto)?; // X.509 v3
    let mut serial = BigNum::new().map_err(crypto)?;
    serial
        .rand(159, MsbOption::MAYBE_ZERO, false)
        .map_err(crypto)?;
    let serial = serial.to_asn1_integer().map_err(crypto)?;
    b.set_serial_number(&serial).map_err(crypto)?;
    b.set_subject_name(&name).map_err(crypto)?;
    match issuer {
        Some(ca) => b.set_issuer_name(ca.cert.subject_name()),
        None => b.set_issuer_name(&name),
    }
    .map_err(crypto)?;
    let from = now_unix - BACKDATE_S;
    let to = now_unix + VALID_DAYS * 86_400;
    let (from, to) = (
        Asn1Time::from_unix(from as libc::time_t).map_err(crypto)?,
        Asn1Time::from_unix(to as libc::time_t).map_err(crypto)?,
    );
    b.set_not_before(&from).map_err(crypto)?;
    b.set_not_after(&to).map_err(crypto)?;
    b.set_pubkey(&key).map_err(crypto)?;
    let constraints = match issuer {
        None => BasicConstraints::new().critical().ca().pathlen(1).build(),
        Some(_) => BasicConstraints::new().build(),
    }
    .map_err(crypto)?;
    b.append_extension(constraints).map_err(crypto)?;
    let signer = issuer.map_or(&key, |ca| &ca.key);
    b.sign(signer, MessageDigest::sha256()).map_err(crypto)?;
    Ok(KeyPair {
        key,
        cert: b.build(),
    })
}

/// Reads a PEM certificate.
pub fn read_cert(path: &Path) -> Result<X509, SecurityError> {
    let pem = std::fs::read(path).map_err(SecurityError::io(path))?;
    X509::from_pem(&pem).map_err(SecurityError::crypto(format!(
        "{}: not a PEM certificate",
        path.display()
    )))
}

/// Reads a certificate and its unencrypted PEM private key (PKCS#8 or SEC1).
pub fn read_key_pair(cert: &Path, key: &Path) -> Result<KeyPair, SecurityError> {
    let cert = read_cert(cert)?;
    let pem = std::fs::read(key).map_err(SecurityError::io(key))?;
    let key_path = key;
    let key = PKey::private_key_from_pem(&pem).map_err(SecurityError::crypto(format!(
        "{}: not an unencrypted PEM private key",
        key_path.display()
    )))?;
    Ok(KeyPair { key, cert })
}

/// The key as unencrypted PKCS#8 PEM (sros2's format).
pub fn key_pem(key: &PKey<Private>) -> Result<Vec<u8>, SecurityError> {
    key.private_key_to_pem_pkcs8()
        .map_err(SecurityError::crypto("writing a private key as PKCS#8 PEM"))
}

/// The certificate as PEM.
pub fn cert_pem(cert: &X509) -> Result<Vec<u8>, SecurityError> {
    cert.to_pem()
        .map_err(SecurityError::crypto("writing a certificate as PEM"))
}

/// `content` signed by `signer` as S/MIME `multipart/signed` (detached, text), as sros2 and
/// `openssl smime -sign -text` sign the governance and permissions documents.
pub fn sign_smime(signer: &KeyPair, content: &[u8]) -> Result<Vec<u8>, SecurityError> {
    let what = "signing a document (PKCS#7, S/MIME)";
    let flags = Pkcs7Flags::DETACHED | Pkcs7Flags::TEXT;
    let no_extra_certs = Stack::new().map_err(SecurityError::crypto(what))?;
    let p7 = Pkcs7::sign(&signer.cert, &signer.key, &no_extra_certs, content, flags)
        .map_err(SecurityError::crypto(what))?;
    p7.to_smime(content, flags)
        .map_err(SecurityError::crypto(what))
}

/// A certificate's validity as the `(not_before, not_after)` UTC times of a permissions
/// document's `<validity>`, `YYYY-MM-DDTHH:MM:SS` (what sros2 writes, from the enclave's
/// certificate).
pub fn validity(cert: &X509) -> Result<(String, String), SecurityError> {
    let crypto = SecurityError::crypto;
    let epoch = Asn1Time::from_unix(0).map_err(crypto("the epoch"))?;
    let unix = |t: &openssl::asn1::Asn1TimeRef| -> Result<i64, SecurityError> {
        let d = epoch.diff(t).map_err(crypto("a certificate's validity"))?;
        Ok(i64::from(d.days) * 86_400 + i64::from(d.secs))
    };
    Ok((
        iso_utc(unix(cert.not_before())?),
        iso_utc(unix(cert.not_after())?),
    ))
}

/// `Err` when the certificate in the PEM file `path` is outside its dates now, saying them
/// (`is valid from … to … UTC, not now`): what every peer's DDS Security checks of it at a
/// handshake. A file that cannot be read as a certificate is `Ok` here: RustDDS refuses it
/// with its own error when the participant is built.
pub fn valid_now(path: &Path) -> Result<(), String> {
    let Some(cert) = std::fs::read(path)
        .ok()
        .and_then(|pem| X509::from_pem(&pem).ok())
    else {
        return Ok(());
    };
    let now = Asn1Time::days_from_now(0).map_err(|e| format!("the time now: {e}"))?;
    if cert.not_before() <= now && cert.not_after() >= now {
        return Ok(());
    }
    let (from, to) = validity(&cert).map_err(|e| e.to_string())?;
    Err(format!("is valid from {from} to {to} UTC, not now"))
}

/// Seconds since the Unix epoch as `YYYY-MM-DDTHH:MM:SS` (UTC; the proleptic Gregorian
/// calendar, Howard Hinnant's `civil_from_days`).
pub fn iso_utc(unix: i64) -> String {
    let (days, secs) = (unix.div_euclid(86_400), unix.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}",
        secs / 3600,
        secs % 3600 / 60,
        secs % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_utc_matches_known_dates() {
        assert_eq!(iso_utc(0), "1970-01-01T00:00:00");
        assert_eq!(iso_utc(951_782_400), "2000-02-29T00:00:00");
        assert_eq!(iso_utc(1_690_100_917), "2023-07-23T08:28:37");
        assert_eq!(iso_utc(4_102_444_799), "2099-12-31T23:59:59");
        assert_eq!(iso_utc(-1), "1969-12-31T23:59:59");
    }

    #[test]
    fn certificates_chain_and_validity_reads_back() {
        let now = 1_700_000_000;
        let ca = new_key_and_cert("sros2CA", None, now).unwrap();
        let leaf = new_key_and_cert("/crossym/node", Some(&ca), now).unwrap();
        assert!(leaf.cert.verify(&ca.key).unwrap());
        assert!(ca.cert.verify(&ca.key).unwrap());
        assert!(!leaf.cert.verify(&leaf.key).unwrap());
        let (from, to) = validity(&leaf.cert).unwrap();
        assert_eq!(from, iso_utc(now - BACKDATE_S));
        assert_eq!(to, iso_utc(now + VALID_DAYS * 86_400));
        let pem = String::from_utf8(key_pem(&leaf.key).unwrap()).unwrap();
        assert!(pem.starts_with("-----BEGIN PRIVATE KEY-----"), "{pem}");
    }

    #[test]
    fn smime_signature_verifies_with_the_signer_and_not_after_a_change() {
        let ca = new_key_and_cert("sros2CA", None, 1_700_000_000).unwrap();
        let doc = b"<dds>\n  <x/>\n</dds>\n";
        let signed = sign_smime(&ca, doc).unwrap();
        let text = String::from_utf8(signed.clone()).unwrap();
        assert!(text.starts_with("MIME-Version: 1.0"), "{text}");
        assert!(text.contains("multipart/signed"), "{text}");
        assert!(text.contains("micalg=\"sha-256\""), "{text}");
        let verify = |smime: &[u8]| {
            let (p7, content) = Pkcs7::from_smime(smime).unwrap();
            let mut store = openssl::x509::store::X509StoreBuilder::new().unwrap();
            store.add_cert(ca.cert.clone()).unwrap();
            let store = store.build();
            let certs = Stack::new().unwrap();
            p7.verify(&certs, &store, content.as_deref(), None, Pkcs7Flags::TEXT)
                .is_ok()
        };
        assert!(verify(&signed));
        let tampered = text.replace("<x/>", "<y/>");
        assert!(!verify(tampered.as_bytes()));
    }
}
