//! vservo's live view, the room that shows a running cell to a viewer (README.md, "Live view in Foxglove"):
//!
//! - [`drawing`]: vservo's messages as Foxglove's well-known schemas (the camera's image, the marks found and
//!   wanted on it, the arm's and the board's frames), pure conversions that `vservoctl record` writes to MCAP
//!   and the live view serves;
//! - [`server`]: Foxglove's WebSocket protocol, served on threads (no async runtime), with the gate the SDK's
//!   server has no hook for: a viewer must give the view's token;
//! - [`token`]: that token, and the owner-only file in the instance's directory that holds the view's URL.
//!
//! `vservoctl view` (and the viewer vservod starts with `[viewer] enabled = true`) connects the instance's
//! streams to a [`server::Hub`]; nothing here reads iceoryx2 or a configuration.

pub mod drawing;
pub mod obstacles;
pub mod server;
pub mod token;

use std::collections::BTreeMap;
use std::path::PathBuf;

/// A channel as a sink declares it (an MCAP file's channel, a live view's advertised channel): topic, schema
/// and encodings, and metadata.
#[derive(Debug, Clone)]
pub struct ChannelSpec<'a> {
    /// The channel's topic (an iceoryx2 service name, or a Foxglove topic such as `/camera/image`).
    pub topic: &'a str,
    /// The schema's name (a vservo payload's type name, or Foxglove's, e.g. `foxglove.RawImage`).
    pub schema_name: &'a str,
    /// How the schema is written: `jsonschema` or `protobuf`.
    pub schema_encoding: &'a str,
    /// The schema itself.
    pub schema: &'a [u8],
    /// How each message is written: `json` or `protobuf`.
    pub message_encoding: &'a str,
    /// What else a reader should know of the channel (a vservo payload's layout).
    pub metadata: BTreeMap<String, String>,
}

/// What the live view refuses or fails at, naming what and where.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// A channel's schema, declared as text, is not UTF-8.
    #[error("{topic}: the schema is not UTF-8 text")]
    SchemaNotText {
        /// The channel.
        topic: String,
    },
    /// The system's random source gave no token.
    #[error("drawing the live view's token from /dev/urandom: {0}")]
    Token(#[source] std::io::Error),
    /// The URL file could not be written.
    #[error("writing the live view's URL to {}: {source}", path.display())]
    WriteUrl {
        /// The URL file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
    /// No live view of the instance serves: its URL file is absent.
    #[error(
        "no live view of instance \"{instance}\" is serving (no {}): vservod starts one with [viewer] \
         enabled = true, or run `vservoctl view`",
        path.display()
    )]
    NotServing {
        /// The instance named.
        instance: String,
        /// Its URL file, absent.
        path: PathBuf,
    },
    /// The URL file is there but could not be read.
    #[error("reading {}: {source}", path.display())]
    ReadUrl {
        /// The URL file.
        path: PathBuf,
        /// The system's reason.
        source: std::io::Error,
    },
}
