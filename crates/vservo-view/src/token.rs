//! The live view's secret: a random token (128 bits from the system's random source, as hex) that a viewer
//! must present in its URL (`ws://127.0.0.1:8765/?token=…`). `vservoctl view` draws a new one at each start
//! and keeps the URL with it in the instance's directory, in a file of mode 0600 (readable by the daemon's
//! user only), which `vservoctl view --url` prints. See README.md, "Live view in Foxglove".

use std::fs::OpenOptions;
use std::io::{ErrorKind, Read, Write};
use std::net::SocketAddr;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

use crate::ViewError;

/// The file in an instance's directory that holds the live view's URL with its token.
pub const URL_FILE: &str = "viewer-url";
/// The token's random bytes (128 bits).
const TOKEN_BYTES: usize = 16;

/// The live view's token, as the hex text a viewer gives.
#[derive(Clone, PartialEq, Eq)]
pub struct ViewToken(String);

impl std::fmt::Debug for ViewToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // never printed: it would end up in logs others may read
        f.write_str("ViewToken(…)")
    }
}

impl ViewToken {
    /// A fresh token from `/dev/urandom`.
    pub fn draw() -> Result<Self, ViewError> {
        let mut bytes = [0u8; TOKEN_BYTES];
        std::fs::File::open("/dev/urandom")
            .and_then(|mut random| random.read_exact(&mut bytes))
            .map_err(ViewError::Token)?;
        Ok(Self(bytes.iter().map(|b| format!("{b:02x}")).collect()))
    }

    /// Whether `given` is this token, compared in a time that does not depend on where they differ.
    pub fn matches(&self, given: &str) -> bool {
        let (ours, theirs) = (self.0.as_bytes(), given.as_bytes());
        ours.len() == theirs.len() && ours.iter().zip(theirs).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0
    }

    /// The URL a viewer opens to reach the server bound at `address`: an unspecified address (`0.0.0.0`,
    /// `::`) is written as this machine's loopback address.
    pub fn url(&self, address: SocketAddr) -> String {
        let mut shown = address;
        if address.ip().is_unspecified() {
            shown.set_ip(match address {
                SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        format!("ws://{shown}/?token={}", self.0)
    }
}

/// The token given in a request's URI (`…?token=<hex>`), if any.
pub fn token_in_query(query: Option<&str>) -> Option<&str> {
    query?.split('&').find_map(|pair| pair.strip_prefix("token="))
}

/// The URL file of the instance in `instance_dir`.
pub fn url_file(instance_dir: &Path) -> PathBuf {
    instance_dir.join(URL_FILE)
}

/// The URL file while the viewer serves: written with mode 0600 at start, removed when the viewer ends
/// (unless a viewer started since has replaced it).
pub struct UrlFile {
    path: PathBuf,
    url: String,
}

impl UrlFile {
    /// Writes `url` to `path`, created with mode 0600 (never chmod after: no moment at which another
    /// user could open it) and put in place by a rename, so a reader sees a whole URL or none.
    pub fn write(path: PathBuf, url: String) -> Result<Self, ViewError> {
        let partial = path.with_extension(format!("{}.partial", std::process::id()));
        let _ = std::fs::remove_file(&partial);
        let written = OpenOptions::new()
            .write(true)
            .create_new(true)
            .mode(0o600)
            .custom_flags(nix::libc::O_NOFOLLOW)
            .open(&partial)
            .and_then(|mut file| file.write_all(format!("{url}\n").as_bytes()))
            .and_then(|()| std::fs::rename(&partial, &path));
        if let Err(error) = written {
            let _ = std::fs::remove_file(&partial);
            return Err(ViewError::WriteUrl { path, source: error });
        }
        Ok(Self { path, url })
    }
}

impl Drop for UrlFile {
    fn drop(&mut self) {
        if std::fs::read_to_string(&self.path).is_ok_and(|text| text.trim() == self.url) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// The URL a running viewer of the instance in `instance_dir` serves, with its token.
pub fn read_url(instance_dir: &Path, instance: &str) -> Result<String, ViewError> {
    let path = url_file(instance_dir);
    match std::fs::read_to_string(&path) {
        Ok(text) => Ok(text.trim().to_string()),
        Err(error) if error.kind() == ErrorKind::NotFound => {
            Err(ViewError::NotServing { instance: instance.to_string(), path })
        }
        Err(source) => Err(ViewError::ReadUrl { path, source }),
    }
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt;

    use super::*;

    #[test]
    fn a_token_is_128_random_bits_in_hex_and_only_itself_matches() {
        let token = ViewToken::draw().expect("a token");
        let other = ViewToken::draw().expect("a token");
        assert_eq!(token.0.len(), 32);
        assert!(token.0.bytes().all(|b| b.is_ascii_hexdigit()));
        assert_ne!(token, other);
        assert!(token.matches(&token.0.clone()));
        assert!(!token.matches(&other.0));
        assert!(!token.matches(&token.0[..31]));
        assert!(!token.matches(""));
        assert_eq!(format!("{token:?}"), "ViewToken(…)");
    }

    #[test]
    fn the_token_is_read_from_the_query_and_the_url_names_a_reachable_address() {
        assert_eq!(token_in_query(Some("token=ab12")), Some("ab12"));
        assert_eq!(token_in_query(Some("x=1&token=ab12")), Some("ab12"));
        assert_eq!(token_in_query(Some("x=1")), None);
        assert_eq!(token_in_query(None), None);
        let token = ViewToken("00ff".into());
        assert_eq!(token.url("0.0.0.0:8765".parse().expect("an address")), "ws://127.0.0.1:8765/?token=00ff");
        assert_eq!(token.url("[::]:9".parse().expect("an address")), "ws://[::1]:9/?token=00ff");
    }

    #[test]
    fn the_url_file_is_the_owners_only_and_goes_with_the_viewer() {
        let dir = std::env::temp_dir().join(format!("vservo-view-token-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a directory");
        let path = url_file(&dir);
        let file = UrlFile::write(path.clone(), "ws://127.0.0.1:1/?token=00".into()).expect("written");
        let mode = std::fs::metadata(&path).expect("the file").permissions().mode() & 0o777;
        assert_eq!(mode, 0o600, "mode {mode:o}");
        assert_eq!(read_url(&dir, "x").expect("read"), "ws://127.0.0.1:1/?token=00");
        drop(file);
        assert!(!path.exists());
        assert!(read_url(&dir, "x").is_err_and(|e| e.to_string().contains("no live view")));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
