//! Certificates for a lab without a PKI: one CA, and a certificate per host signed by it
//! (`hrrtc-bridge certs --out DIR --name NAME[=HOST,...]...`).
//!
//! Bridges authenticate each other with mutual TLS: every host presents its certificate and
//! checks the other's against the lab's CA. Zenoh's access control names a peer by its
//! certificate's subject common name (CN); a TLS client (rustls) checks the server's subject
//! alternative names (SANs), never the CN, against the host it dialled. So a host's
//! certificate has CN = NAME and one SAN per HOST it is reached at.
//!
//! [`write_lab_certs`] writes into DIR:
//!
//! | file | what | mode |
//! |---|---|---|
//! | `ca.pem` | the CA's certificate: every host trusts it (Zenoh `root_ca_certificate`) | 0644 |
//! | `ca.key` | the CA's key: signs hosts added later; keep it on the machine that makes certificates, give it to no host | 0600 |
//! | `NAME.pem` | NAME's certificate (`listen_certificate`, `connect_certificate`) | 0644 |
//! | `NAME.key` | NAME's key, PKCS#8 PEM (`listen_private_key`, `connect_private_key`) | 0600 |
//!
//! Decisions:
//!
//! - **The CA is kept and reused.** A DIR that already holds `ca.pem` and `ca.key` signs the
//!   new names with that CA, so a host can be added later without touching the others, and a
//!   lab's own CA (its certificate as `ca.pem`, its PKCS#8 key as `ca.key`) can sign them
//!   instead of a new one. A DIR with only one of the two is refused (a CA is never
//!   replaced, not even with `force`: every host trusts it), and so is a `ca.pem` that does
//!   not hold `ca.key`'s public key. The new certificates' issuer is `ca.pem`'s subject.
//! - **SANs.** `NAME=HOST,...` gets exactly those HOSTs (IP addresses or DNS names). A bare
//!   `NAME` is its own host: a DNS SAN `NAME` (or an IP SAN, if NAME is an IP address), so
//!   the certificate of `planner-1` serves a client that connects to `planner-1`. A bare
//!   NAME that is no host name (`arm_1`) is refused, since every host also listens and a
//!   listener without SANs fails every client's check.
//! - **Validity.** From one hour ago (a host whose clock is a little behind still accepts a
//!   fresh certificate) to 10 years from now for the CA and 2 years from now for hosts.
//!   Renew a host with `force` before it runs out; a host added in the CA's last 2 years
//!   still runs out with the CA.
//! - **Keys.** ECDSA P-256 with SHA-256 (rustls/ring and Zenoh accept it), a new key per
//!   certificate. Key files are created 0600 (never chmod-ed after writing), no file is
//!   overwritten unless `force` is given, and `force` replaces a file by a new one (so a
//!   replaced key is 0600 too, whatever the old file's mode).
//! - **Extensions.** The CA: basic constraints CA with path length 0 (it signs hosts, no
//!   other CA), key usage certificate-sign and CRL-sign. A host: basic constraints not-CA,
//!   key usage digital signature, extended key usage server and client authentication
//!   (every host both listens and connects).

use rcgen::string::Ia5String;
use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa,
    Issuer, KeyPair, KeyUsagePurpose, PublicKeyData, SanType,
};
use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::net::IpAddr;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

/// The CA's subject common name.
pub const CA_COMMON_NAME: &str = "hrrtc lab CA";
/// How long the CA is valid from now, days (10 years).
pub const CA_VALIDITY_DAYS: u64 = 3653;
/// How long a host's certificate is valid from now, days (2 years).
pub const HOST_VALIDITY_DAYS: u64 = 731;
/// How far back certificates are valid from, s (clock differences between hosts).
const BACKDATE_S: u64 = 3600;
/// The longest name: X.509's upper bound on a CN (`ub-common-name`), characters.
const MAX_NAME_LEN: usize = 64;

/// A host's certificate to make: its name (the CN, and the file names `NAME.pem`,
/// `NAME.key`) and the hosts it is reached at (the SANs). Parsed from `NAME` or
/// `NAME=HOST,HOST,...`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CertName {
    /// `[A-Za-z0-9._-]`, 1 to 64 characters, not starting with `.` or `-`, not `ca`.
    pub name: String,
    /// IP addresses (v4 or v6, written canonically) and DNS names; empty: NAME itself is
    /// the host.
    pub hosts: Vec<String>,
}

/// Why a [`CertName`] is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CertNameError {
    /// `""` or `=HOST`.
    #[error("a certificate name is empty (expected NAME or NAME=HOST,...)")]
    EmptyName,
    /// A character outside `[A-Za-z0-9._-]`.
    #[error(
        "name '{name}' has '{ch}': a name names files and is the certificate's CN, so it may \
         hold only A-Z a-z 0-9 . _ -"
    )]
    NameChar {
        /// The name.
        name: String,
        /// The first character refused.
        ch: char,
    },
    /// A name starting with `.` (a hidden file) or `-` (read as an option by tools).
    #[error("name '{name}' starts with '.' or '-'")]
    NameStart {
        /// The name.
        name: String,
    },
    /// More than 64 characters.
    #[error("name '{name}' has {len} characters; a CN has at most 64")]
    NameTooLong {
        /// The name.
        name: String,
        /// Its length, characters.
        len: usize,
    },
    /// `ca` (in any case): the CA's own files are `ca.pem` and `ca.key`.
    #[error("name '{name}' would be the CA's files (ca.pem, ca.key); choose another")]
    NameReserved {
        /// The name.
        name: String,
    },
    /// Nothing between two commas, or after `=`.
    #[error("'{name}' has an empty host (hosts are separated by single commas)")]
    EmptyHost {
        /// The name.
        name: String,
    },
    /// A host that is neither an IP address nor a DNS name.
    #[error("host '{host}' of '{name}' is neither an IP address nor a DNS name")]
    BadHost {
        /// The name.
        name: String,
        /// The host.
        host: String,
    },
    /// A bare NAME that is no host name itself, so the certificate would have no SAN.
    #[error(
        "'{name}' is given no hosts and is no DNS name or IP address itself, so TLS clients \
         could not check it: give its hosts as {name}=HOST,..."
    )]
    NoHost {
        /// The name.
        name: String,
    },
}

impl FromStr for CertName {
    type Err = CertNameError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (name, hosts) = match s.split_once('=') {
            Some((name, hosts)) => (name, Some(hosts)),
            None => (s, None),
        };
        check_name(name)?;
        let mut cert = CertName {
            name: name.to_owned(),
            hosts: Vec::new(),
        };
        for host in hosts.into_iter().flat_map(|h| h.split(',')) {
            let host = host.trim();
            if host.is_empty() {
                return Err(CertNameError::EmptyHost { name: name.into() });
            }
            let san = san(host).ok_or_else(|| CertNameError::BadHost {
                name: name.into(),
                host: host.into(),
            })?;
            let host = match san {
                SanType::IpAddress(ip) => ip.to_string(),
                _ => host.to_owned(),
            };
            if !cert.hosts.contains(&host) {
                cert.hosts.push(host);
            }
        }
        cert.sans()?;
        Ok(cert)
    }
}

impl CertName {
    /// The SANs of its certificate (checking the name and every host again: the fields are
    /// public and name files).
    fn sans(&self) -> Result<Vec<SanType>, CertNameError> {
        check_name(&self.name)?;
        if self.hosts.is_empty() {
            let own = san(&self.name).ok_or_else(|| CertNameError::NoHost {
                name: self.name.clone(),
            })?;
            return Ok(vec![own]);
        }
        self.hosts
            .iter()
            .map(|host| {
                san(host).ok_or_else(|| {
                    if host.is_empty() {
                        CertNameError::EmptyHost {
                            name: self.name.clone(),
                        }
                    } else {
                        CertNameError::BadHost {
                            name: self.name.clone(),
                            host: host.clone(),
                        }
                    }
                })
            })
            .collect()
    }
}

/// Checks a NAME (see [`CertName::name`]).
fn check_name(name: &str) -> Result<(), CertNameError> {
    if name.is_empty() {
        return Err(CertNameError::EmptyName);
    }
    if let Some(ch) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-')))
    {
        return Err(CertNameError::NameChar {
            name: name.into(),
            ch,
        });
    }
    if name.starts_with(['.', '-']) {
        return Err(CertNameError::NameStart { name: name.into() });
    }
    if name.len() > MAX_NAME_LEN {
        return Err(CertNameError::NameTooLong {
            name: name.into(),
            len: name.len(),
        });
    }
    if name.eq_ignore_ascii_case("ca") {
        return Err(CertNameError::NameReserved { name: name.into() });
    }
    Ok(())
}

/// The SAN for `host`: an IP address (v6 also in brackets), or a DNS name; `None` if neither.
fn san(host: &str) -> Option<SanType> {
    if let Some(inner) = host.strip_prefix('[').and_then(|h| h.strip_suffix(']')) {
        return inner
            .parse::<std::net::Ipv6Addr>()
            .ok()
            .map(|ip| SanType::IpAddress(ip.into()));
    }
    if let Ok(ip) = host.parse::<IpAddr>() {
        return Some(SanType::IpAddress(ip));
    }
    is_dns_name(host)
        .then(|| Ia5String::try_from(host).ok().map(SanType::DnsName))
        .flatten()
}

/// A DNS host name as a certificate may carry it: dot-separated labels of 1 to 63 letters,
/// digits and inner hyphens, at most 253 characters, no trailing dot or wildcard, and a
/// last label that is not all digits (so that `10.0.0.256` is refused, not taken as a name).
fn is_dns_name(s: &str) -> bool {
    let label_ok = |l: &str| {
        (1..=63).contains(&l.len())
            && !l.starts_with('-')
            && !l.ends_with('-')
            && l.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'-')
    };
    s.len() <= 253
        && s.split('.').all(label_ok)
        && !s
            .rsplit('.')
            .next()
            .is_some_and(|l| l.bytes().all(|c| c.is_ascii_digit()))
}

/// What [`write_lab_certs`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The CA's certificate, `DIR/ca.pem`, written now or reused.
    pub ca_cert: PathBuf,
    /// `true`: the CA was made now; `false`: the CA already in DIR signed the names.
    pub new_ca: bool,
    /// Every file written, in order: `ca.key` and `ca.pem` if the CA is new, then `NAME.key`
    /// and `NAME.pem` for each name.
    pub files: Vec<PathBuf>,
}

/// Why [`write_lab_certs`] stopped. An error before writing (all but [`CertsError::Io`])
/// leaves the directory as it was; an I/O error while writing leaves the files written
/// before it.
#[derive(Debug, thiserror::Error)]
pub enum CertsError {
    /// A name or host is refused.
    #[error(transparent)]
    Name(#[from] CertNameError),
    /// The same name twice in one call.
    #[error("name '{0}' is given twice")]
    DuplicateName(String),
    /// A host's file exists and `force` was not given (no file was written).
    #[error("{} exists already (not replaced without force)", .0.display())]
    Exists(PathBuf),
    /// One of `ca.pem` and `ca.key` is in DIR, the other is not.
    #[error(
        "{} exists but {} does not: put it back to sign new names with this CA, or use \
         another directory for a new CA",
        found.display(),
        missing.display()
    )]
    IncompleteCa {
        /// The CA file present.
        found: PathBuf,
        /// The CA file missing.
        missing: PathBuf,
    },
    /// `ca.pem` is not a certificate this module made for `ca.key`.
    #[error("{}: {why}", path.display())]
    ForeignCa {
        /// `DIR/ca.pem`.
        path: PathBuf,
        /// What does not match.
        why: &'static str,
    },
    /// `ca.key` is not a PKCS#8 PEM private key rcgen can sign with.
    #[error("{}: not a usable PKCS#8 private key: {source}", path.display())]
    CaKey {
        /// `DIR/ca.key`.
        path: PathBuf,
        /// rcgen's reason.
        source: rcgen::Error,
    },
    /// A key or certificate could not be made.
    #[error("making the key or certificate of {what}: {source}")]
    Make {
        /// `the CA` or the name.
        what: String,
        /// rcgen's reason.
        source: rcgen::Error,
    },
    /// A directory or file could not be made, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The directory or file.
        path: PathBuf,
        /// Why.
        source: io::Error,
    },
}

/// Writes the lab's CA (unless `out` has one, which is then reused) and a certificate and
/// key per name into `out`, creating it (and its parents) if needed; see the module's docs
/// for the files and choices. Refuses, before writing anything, a name given twice and a
/// name whose `NAME.pem` or `NAME.key` exists unless `force`.
pub fn write_lab_certs(out: &Path, names: &[CertName], force: bool) -> Result<Written, CertsError> {
    // 1. Check everything that can be checked before writing.
    let mut sans = Vec::with_capacity(names.len());
    for (i, cert) in names.iter().enumerate() {
        sans.push(cert.sans()?);
        if names[..i].iter().any(|c| c.name == cert.name) {
            return Err(CertsError::DuplicateName(cert.name.clone()));
        }
        for path in [key_path(out, cert), cert_path(out, cert)] {
            if !force && path.symlink_metadata().is_ok() {
                return Err(CertsError::Exists(path));
            }
        }
    }
    fs::create_dir_all(out).map_err(|e| io_error(out, e))?;
    // 2. The CA: the one in `out`, or a new one (written below).
    let ca_cert = out.join("ca.pem");
    let ca_key = out.join("ca.key");
    let (issuer, new_ca) = match (ca_cert.symlink_metadata(), ca_key.symlink_metadata()) {
        (Ok(_), Ok(_)) => (open_ca(&ca_cert, &ca_key)?, None),
        (Err(_), Err(_)) => {
            let key = new_key("the CA")?;
            let cert = ca_params()
                .self_signed(&key)
                .map_err(make_error("the CA"))?;
            let files = (key.serialize_pem(), cert.pem());
            (Issuer::new(ca_params(), key), Some(files))
        }
        (Ok(_), Err(_)) => return Err(incomplete_ca(ca_cert, ca_key)),
        (Err(_), Ok(_)) => return Err(incomplete_ca(ca_key, ca_cert)),
    };
    // 3. The hosts' keys and certificates.
    let mut hosts = Vec::with_capacity(names.len());
    for (cert, sans) in names.iter().zip(sans) {
        let key = new_key(&cert.name)?;
        let mut params = host_params(&cert.name);
        params.subject_alt_names = sans;
        let signed = params
            .signed_by(&key, &issuer)
            .map_err(make_error(&cert.name))?;
        hosts.push((cert, key.serialize_pem(), signed.pem()));
    }
    // 4. The files.
    let mut files = Vec::with_capacity(2 + 2 * names.len());
    if let Some((key_pem, cert_pem)) = &new_ca {
        write_new(&ca_key, key_pem, 0o600, false)?;
        files.push(ca_key);
        write_new(&ca_cert, cert_pem, 0o644, false)?;
        files.push(ca_cert.clone());
    }
    for (cert, key_pem, cert_pem) in hosts {
        let path = key_path(out, cert);
        write_new(&path, &key_pem, 0o600, force)?;
        files.push(path);
        let path = cert_path(out, cert);
        write_new(&path, &cert_pem, 0o644, force)?;
        files.push(path);
    }
    Ok(Written {
        ca_cert,
        new_ca: new_ca.is_some(),
        files,
    })
}

/// The CA in `ca.pem` and `ca.key`, checked to belong together: an issuer with
/// `ca.pem`'s subject name, signing with `ca.key`.
fn open_ca(ca_cert: &Path, ca_key: &Path) -> Result<Issuer<'static, KeyPair>, CertsError> {
    let read = |path: &Path| fs::read_to_string(path).map_err(|e| io_error(path, e));
    let key = KeyPair::from_pem(&read(ca_key)?).map_err(|source| CertsError::CaKey {
        path: ca_key.into(),
        source,
    })?;
    let foreign = |why| CertsError::ForeignCa {
        path: ca_cert.into(),
        why,
    };
    let pem = read(ca_cert)?;
    let (_, block) = x509_parser::pem::parse_x509_pem(pem.as_bytes())
        .map_err(|_| foreign("not a PEM certificate"))?;
    let cert = block
        .parse_x509()
        .map_err(|_| foreign("not an X.509 certificate"))?;
    if cert.public_key().raw != key.subject_public_key_info().as_slice() {
        return Err(foreign("not the certificate of the key in ca.key"));
    }
    Issuer::from_ca_cert_pem(&pem, key)
        .map_err(|_| foreign("not a certificate rcgen can sign with"))
}

/// The CA's certificate (also its issuer parameters when signing: the subject name, key
/// identifier method and key usages, which are the same every time).
fn ca_params() -> CertificateParams {
    let mut params = CertificateParams::default();
    params.distinguished_name = common_name(CA_COMMON_NAME);
    params.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    params.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    set_validity(&mut params, CA_VALIDITY_DAYS);
    params
}

/// A host's certificate, without its SANs.
fn host_params(name: &str) -> CertificateParams {
    let mut params = CertificateParams::default();
    params.distinguished_name = common_name(name);
    params.is_ca = IsCa::ExplicitNoCa;
    params.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    params.extended_key_usages = vec![
        ExtendedKeyUsagePurpose::ServerAuth,
        ExtendedKeyUsagePurpose::ClientAuth,
    ];
    params.use_authority_key_identifier_extension = true;
    set_validity(&mut params, HOST_VALIDITY_DAYS);
    params
}

fn common_name(cn: &str) -> DistinguishedName {
    let mut dn = DistinguishedName::new();
    dn.push(DnType::CommonName, cn);
    dn
}

/// Valid from [`BACKDATE_S`] ago to `days` from now (whole seconds).
fn set_validity(params: &mut CertificateParams, days: u64) {
    let now_s = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let epoch = rcgen::date_time_ymd(1970, 1, 1);
    params.not_before = epoch + Duration::from_secs(now_s.saturating_sub(BACKDATE_S));
    params.not_after = epoch + Duration::from_secs(now_s + days * 86_400);
}

fn new_key(what: &str) -> Result<KeyPair, CertsError> {
    KeyPair::generate_for(&rcgen::PKCS_ECDSA_P256_SHA256).map_err(make_error(what))
}

fn key_path(out: &Path, cert: &CertName) -> PathBuf {
    out.join(format!("{}.key", cert.name))
}

fn cert_path(out: &Path, cert: &CertName) -> PathBuf {
    out.join(format!("{}.pem", cert.name))
}

/// Creates `path` with `mode` (never an existing file: with `replace` an existing one is
/// removed first) and writes `text` into it.
fn write_new(path: &Path, text: &str, mode: u32, replace: bool) -> Result<(), CertsError> {
    if replace {
        match fs::remove_file(path) {
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(io_error(path, e)),
            _ => {}
        }
    }
    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(mode)
        .open(path)
        .map_err(|e| match e.kind() {
            io::ErrorKind::AlreadyExists => CertsError::Exists(path.into()),
            _ => io_error(path, e),
        })?;
    file.write_all(text.as_bytes())
        .and_then(|()| file.sync_all())
        .map_err(|e| io_error(path, e))
}

fn io_error(path: &Path, source: io::Error) -> CertsError {
    CertsError::Io {
        path: path.into(),
        source,
    }
}

fn make_error(what: &str) -> impl Fn(rcgen::Error) -> CertsError + '_ {
    move |source| CertsError::Make {
        what: what.into(),
        source,
    }
}

fn incomplete_ca(found: PathBuf, missing: PathBuf) -> CertsError {
    CertsError::IncompleteCa { found, missing }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustls_pki_types::pem::PemObject;
    use rustls_pki_types::{CertificateDer, PrivatePkcs8KeyDer, ServerName, UnixTime};
    use std::os::unix::fs::PermissionsExt;
    use webpki::{EndEntityCert, KeyUsage};

    /// A fresh directory under the system's temp dir, unique to this test and process.
    fn temp_out(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("hrrtc-certs-{}-{test}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn names(args: &[&str]) -> Vec<CertName> {
        args.iter().map(|a| a.parse().unwrap()).collect()
    }

    fn mode(path: &Path) -> u32 {
        fs::metadata(path).unwrap().permissions().mode() & 0o777
    }

    fn pem(path: &Path) -> CertificateDer<'static> {
        CertificateDer::from_pem_file(path).unwrap()
    }

    /// Verifies `leaf` against the CA `ca` as a TLS server and as a client, at `time`.
    fn verify_at(ca: &Path, leaf: &Path, time: UnixTime) -> Result<(), webpki::Error> {
        let ca = pem(ca);
        let anchor = webpki::anchor_from_trusted_cert(&ca).unwrap();
        let leaf = pem(leaf);
        let leaf = EndEntityCert::try_from(&leaf).unwrap();
        for usage in [KeyUsage::server_auth(), KeyUsage::client_auth()] {
            leaf.verify_for_usage(
                &[webpki::ring::ECDSA_P256_SHA256],
                std::slice::from_ref(&anchor),
                &[],
                time,
                usage,
                None,
                None,
            )?;
        }
        Ok(())
    }

    fn verify(ca: &Path, leaf: &Path) -> Result<(), webpki::Error> {
        verify_at(ca, leaf, UnixTime::now())
    }

    /// Whether `leaf` is valid for a client that connected to `host`.
    fn valid_for(leaf: &Path, host: &str) -> bool {
        let der = pem(leaf);
        let name = ServerName::try_from(host).unwrap();
        EndEntityCert::try_from(&der)
            .unwrap()
            .verify_is_valid_for_subject_name(&name)
            .is_ok()
    }

    #[test]
    fn parses_names_and_hosts() {
        let bare: CertName = "planner-1".parse().unwrap();
        assert_eq!(bare.name, "planner-1");
        assert!(bare.hosts.is_empty());
        let arm: CertName = "arm.lab=10.0.0.5,arm.lab,arm-2.lab.example, ::1,[fe80::0:1],10.0.0.5"
            .parse()
            .unwrap();
        assert_eq!(arm.name, "arm.lab");
        assert_eq!(
            arm.hosts,
            ["10.0.0.5", "arm.lab", "arm-2.lab.example", "::1", "fe80::1"]
        );
        // A bare IP address or a name with underscores and hosts.
        assert!("10.0.0.7".parse::<CertName>().is_ok());
        assert_eq!("arm_1=arm1".parse::<CertName>().unwrap().hosts, ["arm1"]);
    }

    #[test]
    fn refuses_bad_names_and_hosts() {
        use CertNameError as E;
        let err = |s: &str| s.parse::<CertName>().unwrap_err();
        assert_eq!(err(""), E::EmptyName);
        assert_eq!(err("=10.0.0.5"), E::EmptyName);
        for (arg, ch) in [
            ("a/b", '/'),
            ("a b", ' '),
            ("../x", '/'),
            ("é", 'é'),
            ("a:1", ':'),
        ] {
            assert!(
                matches!(err(arg), E::NameChar { ch: c, .. } if c == ch),
                "{arg}"
            );
        }
        for arg in [".hidden", "..", "-rf"] {
            assert!(matches!(err(arg), E::NameStart { .. }), "{arg}");
        }
        assert!(matches!(
            err(&"a".repeat(65)),
            E::NameTooLong { len: 65, .. }
        ));
        assert!(
            format!("{}=10.0.0.5", "a".repeat(64))
                .parse::<CertName>()
                .is_ok()
        );
        for arg in ["ca", "CA=10.0.0.5"] {
            assert!(matches!(err(arg), E::NameReserved { .. }), "{arg}");
        }
        for arg in ["x=", "x=a.lab,,b.lab", "x=a.lab,", "x= "] {
            assert!(matches!(err(arg), E::EmptyHost { .. }), "{arg}");
        }
        for host in [
            "foo_bar",
            "-a.lab",
            "a-.lab",
            "a..b",
            "a.lab.",
            "*.lab",
            "10.0.0.256",
            "[10.0.0.5]",
            "fe80::1%eth0",
            "a b",
            "ä.lab",
        ] {
            let e = err(&format!("x={host}"));
            assert_eq!(
                e,
                E::BadHost {
                    name: "x".into(),
                    host: host.into()
                },
                "{host}"
            );
            assert!(e.to_string().contains(host));
        }
        assert!(matches!(
            err(&format!("x={}", "a".repeat(64))),
            E::BadHost { .. }
        ));
        for arg in ["arm_1", "123", "a..b"] {
            assert!(matches!(err(arg), E::NoHost { .. }), "{arg}");
        }
    }

    #[test]
    fn writes_the_files_with_private_keys_0600() {
        let out = temp_out("files");
        let written = write_lab_certs(
            &out.join("sub"),
            &names(&["planner-1", "arm=10.0.0.5"]),
            false,
        )
        .unwrap();
        let out = out.join("sub");
        assert!(written.new_ca);
        assert_eq!(written.ca_cert, out.join("ca.pem"));
        let expected: Vec<PathBuf> = [
            "ca.key",
            "ca.pem",
            "planner-1.key",
            "planner-1.pem",
            "arm.key",
            "arm.pem",
        ]
        .iter()
        .map(|f| out.join(f))
        .collect();
        assert_eq!(written.files, expected);
        for key in ["ca.key", "planner-1.key", "arm.key"] {
            assert_eq!(mode(&out.join(key)), 0o600, "{key}");
            PrivatePkcs8KeyDer::from_pem_file(out.join(key)).unwrap();
        }
        for cert in ["ca.pem", "planner-1.pem", "arm.pem"] {
            assert_eq!(mode(&out.join(cert)) & 0o600, 0o600, "{cert}");
        }
        fs::remove_dir_all(out.parent().unwrap()).unwrap();
    }

    #[test]
    fn leaves_verify_against_their_ca_for_their_hosts() {
        let out = temp_out("verify");
        write_lab_certs(
            &out,
            &names(&["planner-1", "arm=10.0.0.5,arm.lab,::1"]),
            false,
        )
        .unwrap();
        let ca = out.join("ca.pem");
        for leaf in ["planner-1.pem", "arm.pem"] {
            verify(&ca, &out.join(leaf)).unwrap();
        }
        // SANs: exactly the hosts asked for; a bare name is its own host.
        let arm = out.join("arm.pem");
        for host in ["10.0.0.5", "arm.lab", "ARM.lab", "::1"] {
            assert!(valid_for(&arm, host), "{host}");
        }
        for host in ["arm", "10.0.0.6", "planner-1", "127.0.0.1"] {
            assert!(!valid_for(&arm, host), "{host}");
        }
        assert!(valid_for(&out.join("planner-1.pem"), "planner-1"));
        assert!(!valid_for(&out.join("planner-1.pem"), "arm.lab"));
        // CN: the name; issuer: the CA's subject, CN=hrrtc lab CA.
        let cn_of = |name: &x509_parser::x509::X509Name<'_>| -> String {
            name.iter_common_name()
                .next()
                .and_then(|cn| cn.as_str().ok())
                .unwrap_or_default()
                .to_owned()
        };
        for (leaf, cn) in [("planner-1.pem", "planner-1"), ("arm.pem", "arm")] {
            let der = pem(&out.join(leaf));
            let (_, cert) = x509_parser::parse_x509_certificate(&der).unwrap();
            assert_eq!(cn_of(cert.subject()), cn, "{leaf}");
            assert_eq!(cn_of(cert.issuer()), CA_COMMON_NAME, "{leaf}");
            assert!(!cert.is_ca(), "{leaf}");
        }
        let ca_der = pem(&ca);
        let (_, ca_cert) = x509_parser::parse_x509_certificate(&ca_der).unwrap();
        assert_eq!(cn_of(ca_cert.subject()), CA_COMMON_NAME);
        assert_eq!(ca_cert.issuer(), ca_cert.subject());
        assert!(ca_cert.is_ca());
        fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn validity_is_backdated_an_hour_and_lasts_two_years() {
        let out = temp_out("validity");
        write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap();
        let (ca, leaf) = (out.join("ca.pem"), out.join("arm.pem"));
        let now = SystemTime::now().duration_since(UNIX_EPOCH).unwrap();
        let at = |d: Duration| UnixTime::since_unix_epoch(d);
        let day = Duration::from_secs(86_400);
        verify_at(&ca, &leaf, at(now - Duration::from_secs(1800))).unwrap();
        verify_at(&ca, &leaf, at(now + 730 * day)).unwrap();
        let early = verify_at(&ca, &leaf, at(now - Duration::from_secs(7200)));
        assert!(
            matches!(early, Err(webpki::Error::CertNotValidYet { .. })),
            "{early:?}"
        );
        let late = verify_at(&ca, &leaf, at(now + 732 * day));
        assert!(
            matches!(late, Err(webpki::Error::CertExpired { .. })),
            "{late:?}"
        );
        fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn a_leaf_of_another_ca_does_not_verify() {
        let (one, two) = (temp_out("ca-one"), temp_out("ca-two"));
        write_lab_certs(&one, &names(&["arm=10.0.0.5"]), false).unwrap();
        write_lab_certs(&two, &names(&["arm=10.0.0.5"]), false).unwrap();
        // Same CA subject name, other key: only the signature tells them apart.
        verify(&two.join("ca.pem"), &two.join("arm.pem")).unwrap();
        let bad_signature = Err(webpki::Error::InvalidSignatureForPublicKey);
        assert_eq!(
            verify(&one.join("ca.pem"), &two.join("arm.pem")),
            bad_signature
        );
        assert_eq!(
            verify(&two.join("ca.pem"), &one.join("arm.pem")),
            bad_signature
        );
        fs::remove_dir_all(&one).unwrap();
        fs::remove_dir_all(&two).unwrap();
    }

    #[test]
    fn a_leaf_cannot_sign_certificates() {
        let out = temp_out("not-ca");
        write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap();
        // Sign a certificate with arm's key as if arm were a CA.
        let arm_key = KeyPair::from_pem(&fs::read_to_string(out.join("arm.key")).unwrap()).unwrap();
        let arm = Issuer::new(host_params("arm"), arm_key);
        let key = new_key("evil").unwrap();
        let mut params = host_params("evil");
        params.subject_alt_names = "evil=10.0.0.9".parse::<CertName>().unwrap().sans().unwrap();
        let evil = params.signed_by(&key, &arm).unwrap();
        let ca = pem(&out.join("ca.pem"));
        let anchor = webpki::anchor_from_trusted_cert(&ca).unwrap();
        let evil = EndEntityCert::try_from(evil.der()).unwrap();
        let intermediates = [pem(&out.join("arm.pem"))];
        let result = evil
            .verify_for_usage(
                &[webpki::ring::ECDSA_P256_SHA256],
                std::slice::from_ref(&anchor),
                &intermediates,
                UnixTime::now(),
                KeyUsage::server_auth(),
                None,
                None,
            )
            .map(|_| ());
        assert_eq!(result, Err(webpki::Error::EndEntityUsedAsCa));
        fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn a_second_run_adds_names_signed_by_the_same_ca() {
        let out = temp_out("add");
        write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap();
        let ca_before = fs::read(out.join("ca.pem")).unwrap();
        let ca_key_before = fs::read(out.join("ca.key")).unwrap();
        let written = write_lab_certs(&out, &names(&["planner-1"]), false).unwrap();
        assert!(!written.new_ca);
        assert_eq!(
            written.files,
            [out.join("planner-1.key"), out.join("planner-1.pem")]
        );
        assert_eq!(fs::read(out.join("ca.pem")).unwrap(), ca_before);
        assert_eq!(fs::read(out.join("ca.key")).unwrap(), ca_key_before);
        verify(&out.join("ca.pem"), &out.join("arm.pem")).unwrap();
        verify(&out.join("ca.pem"), &out.join("planner-1.pem")).unwrap();
        // No names: the CA alone is checked and kept.
        let written = write_lab_certs(&out, &[], false).unwrap();
        assert!(!written.new_ca && written.files.is_empty());
        fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn refuses_to_overwrite_a_name_without_force() {
        let out = temp_out("force");
        write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap();
        let key_before = fs::read(out.join("arm.key")).unwrap();
        // Nothing is written when one of the names exists, not even the new ones.
        let err = write_lab_certs(&out, &names(&["planner-1", "arm=10.0.0.5"]), false).unwrap_err();
        assert!(
            matches!(&err, CertsError::Exists(p) if *p == out.join("arm.key")),
            "{err}"
        );
        assert!(err.to_string().contains("arm.key"));
        assert!(!out.join("planner-1.key").exists());
        assert_eq!(fs::read(out.join("arm.key")).unwrap(), key_before);
        // Only the certificate left: still refused.
        fs::remove_file(out.join("arm.key")).unwrap();
        let err = write_lab_certs(&out, &names(&["arm"]), false).unwrap_err();
        assert!(
            matches!(&err, CertsError::Exists(p) if *p == out.join("arm.pem")),
            "{err}"
        );
        // With force: new files, the key 0600 even where the old one was readable by all.
        fs::write(out.join("arm.key"), &key_before).unwrap();
        fs::set_permissions(out.join("arm.key"), fs::Permissions::from_mode(0o644)).unwrap();
        let written = write_lab_certs(&out, &names(&["arm=10.0.0.6"]), true).unwrap();
        assert_eq!(written.files, [out.join("arm.key"), out.join("arm.pem")]);
        assert_ne!(fs::read(out.join("arm.key")).unwrap(), key_before);
        assert_eq!(mode(&out.join("arm.key")), 0o600);
        verify(&out.join("ca.pem"), &out.join("arm.pem")).unwrap();
        assert!(valid_for(&out.join("arm.pem"), "10.0.0.6"));
        fs::remove_dir_all(&out).unwrap();
    }

    #[test]
    fn refuses_an_incomplete_or_foreign_ca() {
        let (out, other) = (temp_out("bad-ca"), temp_out("bad-ca-other"));
        write_lab_certs(&out, &[], false).unwrap();
        write_lab_certs(&other, &[], false).unwrap();
        // ca.key of another CA.
        fs::copy(other.join("ca.key"), out.join("ca.key")).unwrap();
        let err = write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap_err();
        assert!(matches!(err, CertsError::ForeignCa { .. }), "{err}");
        assert!(!out.join("arm.pem").exists());
        // A lab's own CA (another subject name, made elsewhere) signs new hosts, which chain
        // to it.
        let key = KeyPair::from_pem(&fs::read_to_string(other.join("ca.key")).unwrap()).unwrap();
        fs::copy(other.join("ca.key"), out.join("ca.key")).unwrap();
        let mut params = ca_params();
        params.distinguished_name = common_name("the lab's own CA");
        fs::write(out.join("ca.pem"), params.self_signed(&key).unwrap().pem()).unwrap();
        write_lab_certs(&out, &names(&["arm=10.0.0.5"]), false).unwrap();
        verify(&out.join("ca.pem"), &out.join("arm.pem")).unwrap();
        // ca.pem not a certificate.
        fs::write(out.join("ca.pem"), "hello").unwrap();
        let err = write_lab_certs(&out, &[], false).unwrap_err();
        assert!(matches!(err, CertsError::ForeignCa { .. }), "{err}");
        // ca.key missing: never replaced by a new CA.
        fs::remove_file(out.join("ca.key")).unwrap();
        let err = write_lab_certs(&out, &names(&["arm=10.0.0.5"]), true).unwrap_err();
        assert!(
            matches!(&err, CertsError::IncompleteCa { missing, .. } if *missing == out.join("ca.key")),
            "{err}"
        );
        // ca.key not a key.
        fs::write(out.join("ca.key"), "hello").unwrap();
        let err = write_lab_certs(&out, &[], false).unwrap_err();
        assert!(matches!(err, CertsError::CaKey { .. }), "{err}");
        fs::remove_dir_all(&out).unwrap();
        fs::remove_dir_all(&other).unwrap();
    }

    #[test]
    fn refuses_duplicate_and_unchecked_names() {
        let out = temp_out("dup");
        let err =
            write_lab_certs(&out, &names(&["arm=10.0.0.5", "arm=10.0.0.6"]), false).unwrap_err();
        assert!(
            matches!(&err, CertsError::DuplicateName(n) if n == "arm"),
            "{err}"
        );
        // The fields are public: a name built without parsing is checked too.
        for bad in [
            CertName {
                name: "../evil".into(),
                hosts: vec!["10.0.0.5".into()],
            },
            CertName {
                name: "arm".into(),
                hosts: vec!["not a host".into()],
            },
        ] {
            let err = write_lab_certs(&out, &[bad], false).unwrap_err();
            assert!(matches!(err, CertsError::Name(_)), "{err}");
        }
        assert!(!out.exists());
    }
}
