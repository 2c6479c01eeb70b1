//! Prints the payload tables of docs/PROTOCOL.md (offsets from the compiler).

fn main() {
    print!("{}", vservo_protocol::layout::layout_tables());
}
