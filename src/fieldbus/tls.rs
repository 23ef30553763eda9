//! Modbus/TCP Security (MODBUS/TCP Security Protocol Specification, 2018): Modbus TCP inside
//! TLS 1.2 or 1.3 on port 802, with mutual authentication. The node presents its certificate;
//! every client must present one signed by the configured CA, or the handshake fails (counted,
//! logged). The client's role, the ModbusRole X.509 v3 extension (OID
//! 1.3.6.1.4.1.50316.802.1, a UTF8String), is read from its certificate and becomes part of its
//! [`crate::modbus::access::Source`]: the write allowlist may name roles (`"role:operator"`) or
//! admit any authenticated client (`"tls"`).
//!
//! rustls with the ring provider; certificates and keys are PEM files named in the board file
//! (`[modbus.tls]`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rustls::RootCertStore;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::server::WebPkiClientVerifier;
use tokio_rustls::TlsAcceptor;

/// The PEM files of a TLS listener.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    /// The node's certificate chain (PEM).
    pub cert: PathBuf,
    /// The node's private key (PEM, PKCS#8, PKCS#1 or SEC1).
    pub key: PathBuf,
    /// The CA that signs client certificates (PEM, one or more).
    pub client_ca: PathBuf,
}

/// Why a TLS listener could not be set up.
#[derive(Debug, thiserror::Error)]
#[error("modbus tls: {0}")]
pub struct TlsError(pub String);

/// A TLS acceptor ready to serve.
#[derive(Clone)]
pub struct TlsServer {
    acceptor: TlsAcceptor,
    files: TlsFiles,
}

impl std::fmt::Debug for TlsServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TlsServer")
            .field("files", &self.files)
            .finish()
    }
}

fn pem_certs(path: &Path, what: &str) -> Result<Vec<CertificateDer<'static>>, TlsError> {
    let certs = CertificateDer::pem_file_iter(path)
        .map_err(|e| TlsError(format!("{what} {}: {e}", path.display())))?
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| TlsError(format!("{what} {}: {e}", path.display())))?;
    if certs.is_empty() {
        return Err(TlsError(format!(
            "{what} {}: no certificate in the file",
            path.display()
        )));
    }
    Ok(certs)
}

impl TlsServer {
    /// Loads the files and builds the acceptor: TLS 1.2 and 1.3, client certificates required.
    pub fn load(files: &TlsFiles) -> Result<Self, TlsError> {
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let certs = pem_certs(&files.cert, "cert")?;
        let key = PrivateKeyDer::from_pem_file(&files.key)
            .map_err(|e| TlsError(format!("key {}: {e}", files.key.display())))?;
        let mut roots = RootCertStore::empty();
        for ca in pem_certs(&files.client_ca, "client_ca")? {
            roots
                .add(ca)
                .map_err(|e| TlsError(format!("client_ca {}: {e}", files.client_ca.display())))?;
        }
        let verifier =
            WebPkiClientVerifier::builder_with_provider(Arc::new(roots), provider.clone())
                .build()
                .map_err(|e| TlsError(format!("client_ca: {e}")))?;
        let config = rustls::ServerConfig::builder_with_provider(provider)
            .with_protocol_versions(&[&rustls::version::TLS12, &rustls::version::TLS13])
            .map_err(|e| TlsError(e.to_string()))?
            .with_client_cert_verifier(verifier)
            .with_single_cert(certs, key)
            .map_err(|e| TlsError(format!("cert and key: {e}")))?;
        Ok(Self {
            acceptor: TlsAcceptor::from(Arc::new(config)),
            files: files.clone(),
        })
    }

    /// The acceptor.
    pub fn acceptor(&self) -> &TlsAcceptor {
        &self.acceptor
    }

    /// The files it was loaded from.
    pub fn files(&self) -> &TlsFiles {
        &self.files
    }
}

/// The DER of the ModbusRole OID, 1.3.6.1.4.1.50316.802.1.
const ROLE_OID: [u8; 13] = [
    0x06, 0x0B, 0x2B, 0x06, 0x01, 0x04, 0x01, 0x83, 0x89, 0x0C, 0x86, 0x22, 0x01,
];

/// A DER length at `b[*i..]`; advances `i`. At most 4 length bytes.
fn der_len(b: &[u8], i: &mut usize) -> Option<usize> {
    let first = *b.get(*i)?;
    *i += 1;
    if first < 0x80 {
        return Some(usize::from(first));
    }
    let n = usize::from(first & 0x7F);
    if n == 0 || n > 4 {
        return None;
    }
    let mut len = 0usize;
    for _ in 0..n {
        len = (len << 8) | usize::from(*b.get(*i)?);
        *i += 1;
    }
    Some(len)
}

/// The ModbusRole of a certificate (DER), if it has one: the extension's OID, an optional
/// `critical` BOOLEAN, then an OCTET STRING holding a UTF8String. Bounds-checked on any input
/// (fuzzed with the other decoders).
pub fn modbus_role(cert_der: &[u8]) -> Option<String> {
    let at = cert_der
        .windows(ROLE_OID.len())
        .position(|w| w == ROLE_OID)?;
    let mut i = at + ROLE_OID.len();
    if cert_der.get(i) == Some(&0x01) {
        // critical: BOOLEAN, length 1
        i += 3;
    }
    if *cert_der.get(i)? != 0x04 {
        return None;
    }
    i += 1;
    let outer = der_len(cert_der, &mut i)?;
    let inner = cert_der.get(i..i.checked_add(outer)?)?;
    let mut j = 0;
    if *inner.first()? != 0x0C {
        return None;
    }
    j += 1;
    let n = der_len(inner, &mut j)?;
    let s = inner.get(j..j.checked_add(n)?)?;
    let role = std::str::from_utf8(s).ok()?;
    (!role.is_empty() && role.len() <= 64).then(|| role.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_role_is_read_from_its_extension_and_garbage_is_none() {
        // SEQUENCE { OID ModbusRole, OCTET STRING { UTF8String "operator" } }
        let mut ext = ROLE_OID.to_vec();
        ext.extend([0x04, 0x0A, 0x0C, 0x08]);
        ext.extend(b"operator");
        let mut cert = vec![0x30, 0x82, 0x01, 0x00, 0xAA, 0xBB];
        cert.extend(&ext);
        cert.extend([0x30, 0x00]);
        assert_eq!(modbus_role(&cert).as_deref(), Some("operator"));
        // critical flag
        let mut crit = ROLE_OID.to_vec();
        crit.extend([0x01, 0x01, 0xFF, 0x04, 0x06, 0x0C, 0x04]);
        crit.extend(b"view");
        assert_eq!(modbus_role(&crit).as_deref(), Some("view"));
        // truncated at every byte: never a panic, never a role
        for k in 0..ext.len() {
            assert_eq!(modbus_role(&ext[..k]), None, "{k}");
        }
        assert_eq!(modbus_role(b"no extension here"), None);
        let mut long = ROLE_OID.to_vec();
        long.extend([0x04, 0x84, 0xFF, 0xFF, 0xFF, 0xFF]);
        assert_eq!(modbus_role(&long), None);
    }
}
