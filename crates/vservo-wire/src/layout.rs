//! The payload layouts as docs/PROTOCOL.md prints them: one Markdown table per message, made from the
//! message's one declaration (`crate::declare`), with offsets taken from the compiler (`offset_of!`), so the
//! document cannot drift from the code (a test compares them). [`layouts`] gives the same as data, for the
//! test that checks the Python client's structures against this build.

use std::fmt::Write;
use std::mem::size_of;

use crate::declare::{FieldInfo, WireMessage};
use crate::messages::*;

/// One message's layout.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageLayout {
    /// The title docs/PROTOCOL.md gives its table (the service's name, or what the message is).
    pub title: &'static str,
    /// The iceoryx2 type name.
    pub type_name: &'static str,
    /// Its size (bytes).
    pub size: usize,
    /// Its fields in order.
    pub fields: Vec<FieldInfo>,
}

fn layout<M: WireMessage>(title: &'static str) -> MessageLayout {
    MessageLayout { title, type_name: M::TYPE_NAME, size: size_of::<M>(), fields: M::fields() }
}

/// Every message's layout, in the order docs/PROTOCOL.md lists them.
pub fn layouts() -> Vec<MessageLayout> {
    vec![
        layout::<JointStateMsg>("joint_state"),
        layout::<JointCommandMsg>("joint_command"),
        layout::<SimWorldMsg>("sim_world (simulation only)"),
        layout::<CameraImageHeader>("camera_image (user header; the payload is the image, a slice of u8)"),
        layout::<FeaturesMsg>("features"),
        layout::<CameraTwistMsg>("camera_twist"),
        layout::<TelemetryMsg>("telemetry"),
        layout::<TimingMsg>("Timing (inside telemetry)"),
        layout::<DaemonStatusMsg>("status"),
        layout::<NodeStatusMsg>("NodeStatus (inside status)"),
        layout::<GainsMsg>("gains"),
        layout::<ObjectMsg>("object"),
        layout::<CellModeMsg>("cell_mode"),
        layout::<CommandMsg>("command (request)"),
        layout::<CommandReplyMsg>("command (reply)"),
    ]
}

fn table(out: &mut String, message: &MessageLayout) {
    // writing to a String cannot fail
    let _ = writeln!(
        out,
        "### {}\n\ntype name `{}`, {} bytes, alignment 8\n",
        message.title, message.type_name, message.size
    );
    let _ = writeln!(out, "| offset | field | type | meaning |\n|---:|---|---|---|");
    for f in &message.fields {
        let _ = writeln!(out, "| {} | `{}` | {} | {} |", f.offset, f.name, f.wire_type, f.meaning);
    }
    out.push('\n');
}

/// The tables of docs/PROTOCOL.md's "Payloads" section.
pub fn layout_tables() -> String {
    let mut out = String::new();
    for message in layouts() {
        table(&mut out, &message);
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn protocol_md_shows_the_layouts_of_this_build() {
        let doc = include_str!("../../../docs/PROTOCOL.md");
        let tables = super::layout_tables();
        assert!(
            doc.contains(&tables),
            "docs/PROTOCOL.md is out of date: paste `cargo run -q -p vservo-protocol --example layout` into its Payloads section"
        );
        assert!(
            doc.contains(&format!("(`u32`, currently {};", crate::SCHEMA_VERSION)),
            "docs/PROTOCOL.md's prose names another schema than SCHEMA_VERSION"
        );
        assert!(
            doc.contains(&crate::DriverError::legend()),
            "docs/PROTOCOL.md's \"Driver errors\" lists another legend than `DriverError::legend()`"
        );
    }
}
