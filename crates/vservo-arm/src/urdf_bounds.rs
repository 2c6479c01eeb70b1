//! What a URDF may be before its parser sees it: a size, a nesting depth and a number of elements that no robot
//! description comes near, found by one flat scan of the text (no recursion the input controls), and no
//! document type declaration (the door to entity expansion). `urdf-rs` deserialises elements recursively: a
//! file of thousands of nested elements would overflow the stack, and one of hundreds of thousands keep a
//! process busy for seconds, deaf to SIGTERM.

/// The largest URDF read (bytes): robot descriptions are tens of kilobytes (the meshes are files of their own).
pub const MAX_URDF_BYTES: usize = 1 << 20;
/// The deepest nesting of elements (a URDF's is about five: robot, joint, limit…).
pub const MAX_URDF_DEPTH: usize = 32;
/// The most elements: the largest robot descriptions (humanoids with collision geometry) have a few thousand.
/// The parser's own structures take about 1.6 kB an element: 180,000 elements (a 4 MB file) took 1.5 s and
/// 290 MB to read, this bound about a tenth of both.
pub const MAX_URDF_ELEMENTS: usize = 20_000;

/// What is out of bounds, for [`crate::urdf::UrdfError::OutOfBounds`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// The text is larger than [`MAX_URDF_BYTES`].
    Bytes(usize),
    /// Elements nest deeper than [`MAX_URDF_DEPTH`] (at this byte).
    Depth(usize),
    /// More than [`MAX_URDF_ELEMENTS`] elements.
    Elements,
    /// A document type declaration (at this byte).
    Doctype(usize),
    /// A markup construct that does not end (at this byte).
    Unterminated(usize),
}

impl std::fmt::Display for Bound {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Bound::Bytes(bytes) => {
                write!(f, "{bytes} bytes, more than the {MAX_URDF_BYTES} a URDF is read up to")
            }
            Bound::Depth(at) => write!(f, "elements nest deeper than {MAX_URDF_DEPTH} (at byte {at})"),
            Bound::Elements => write!(f, "more than {MAX_URDF_ELEMENTS} elements"),
            Bound::Doctype(at) => {
                write!(
                    f,
                    "a document type declaration at byte {at}: a URDF has none (entities are not expanded)"
                )
            }
            Bound::Unterminated(at) => write!(f, "markup that does not end, from byte {at}"),
        }
    }
}

/// Scans `text` once, counting depth and elements; `Err` with the first bound it breaks.
pub fn check(text: &str) -> Result<(), Bound> {
    let bytes = text.as_bytes();
    if bytes.len() > MAX_URDF_BYTES {
        return Err(Bound::Bytes(bytes.len()));
    }
    let (mut depth, mut elements, mut at) = (0usize, 0usize, 0usize);
    while let Some(offset) = bytes[at..].iter().position(|&b| b == b'<') {
        let start = at + offset;
        let rest = &bytes[start..];
        at = if rest.starts_with(b"<!--") {
            end_of(bytes, start, b"-->")?
        } else if rest.starts_with(b"<![CDATA[") {
            end_of(bytes, start, b"]]>")?
        } else if rest.starts_with(b"<!") {
            return Err(Bound::Doctype(start));
        } else if rest.starts_with(b"<?") {
            end_of(bytes, start, b"?>")?
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            end_of(bytes, start, b">")?
        } else {
            let end = end_of_tag(bytes, start)?;
            elements += 1;
            if elements > MAX_URDF_ELEMENTS {
                return Err(Bound::Elements);
            }
            // `<x/>` opens and closes at once
            if bytes[end - 2] != b'/' {
                depth += 1;
                if depth > MAX_URDF_DEPTH {
                    return Err(Bound::Depth(start));
                }
            }
            end
        };
    }
    Ok(())
}

/// The byte after `closing`, searched from `start`.
fn end_of(bytes: &[u8], start: usize, closing: &[u8]) -> Result<usize, Bound> {
    bytes[start..]
        .windows(closing.len())
        .position(|w| w == closing)
        .map(|i| start + i + closing.len())
        .ok_or(Bound::Unterminated(start))
}

/// The byte after the `>` that ends the start tag at `start` (a `>` inside a quoted attribute value does not).
fn end_of_tag(bytes: &[u8], start: usize) -> Result<usize, Bound> {
    let mut quote = None;
    for (i, &b) in bytes.iter().enumerate().skip(start + 1) {
        match (quote, b) {
            (None, b'"' | b'\'') => quote = Some(b),
            (Some(q), _) if b == q => quote = None,
            (None, b'>') => return Ok(i + 1),
            _ => {}
        }
    }
    Err(Bound::Unterminated(start))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_description_passes() {
        let urdf = r#"<?xml version="1.0"?>
<!-- a comment with <tags> -->
<robot name="r"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint><link name="b" note="x>y"/></robot>"#;
        assert_eq!(check(urdf), Ok(()));
    }

    #[test]
    fn nesting_size_elements_and_doctypes_beyond_the_bounds_are_refused() {
        let nested = format!("<robot>{}{}</robot>", "<a>".repeat(40), "</a>".repeat(40));
        assert!(matches!(check(&nested), Err(Bound::Depth(_))));
        let flat = format!("<robot>{}</robot>", "<a/>".repeat(MAX_URDF_ELEMENTS + 1));
        assert_eq!(check(&flat), Err(Bound::Elements));
        let big = " ".repeat(MAX_URDF_BYTES + 1);
        assert_eq!(check(&big), Err(Bound::Bytes(MAX_URDF_BYTES + 1)));
        let entities = r#"<!DOCTYPE robot [<!ENTITY a "aaaa">]><robot>&a;</robot>"#;
        assert_eq!(check(entities), Err(Bound::Doctype(0)));
        assert_eq!(check("<robot><link name=\"a"), Err(Bound::Unterminated(7)));
    }

    /// The bomb of the security review: 12,500 nested elements (90 kB) crashed the parser's stack.
    #[test]
    fn twelve_thousand_nested_elements_are_refused_at_once() {
        let bomb = format!("<robot>{}{}</robot>", "<link>".repeat(12_500), "</link>".repeat(12_500));
        assert!(matches!(check(&bomb), Err(Bound::Depth(_))));
        // refused before the parser recurses: this test process would abort on a stack overflow otherwise
        let refused = crate::urdf::parse(&bomb, "bomb.urdf", None, None).expect_err("refused");
        assert!(refused.to_string().contains("nest deeper than 32"), "{refused}");
    }
}
