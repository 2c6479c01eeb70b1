//! The v10 wire formats: packed little-endian layouts read and written at explicit byte offsets.
//!
//! Every struct of libfranka-common (`rbk_types.h`, `service_types.h` @ d96c221) is `#pragma pack(1)` and
//! sent as host (little-endian) bytes. Each layout here is a table of [`FieldLayout`]s (name, type, count,
//! byte offset) checked at compile time to tile its message exactly; decoding reads each field at its offset
//! and refuses short, long or malformed input with a [`DecodeError`] — it never panics.

pub mod command;
pub mod command_layout;
pub mod modes;
pub mod state;
pub mod state_layout;
pub mod tcp;

/// The server protocol version this crate speaks (libfranka-common `kVersion`, libfranka 0.18.0–0.20.4, FR3
/// system ≥ 5.9.0).
pub const PROTOCOL_VERSION: u16 = 10;

/// The scalar type of a field on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireType {
    /// `uint64_t`, 8 bytes.
    U64,
    /// `float`, 4 bytes (IEEE 754 binary32).
    F32,
    /// `double`, 8 bytes (IEEE 754 binary64).
    F64,
    /// `uint8_t` (the state's enums), 1 byte.
    U8,
    /// `bool`, 1 byte, 0 or 1.
    Bool,
}

impl WireType {
    /// Bytes one element takes.
    pub const fn size(self) -> usize {
        match self {
            WireType::U64 | WireType::F64 => 8,
            WireType::F32 => 4,
            WireType::U8 | WireType::Bool => 1,
        }
    }

    /// The type's name in the layout tables (`u64`, `f32`, `f64`, `u8`, `bool`).
    pub const fn name(self) -> &'static str {
        match self {
            WireType::U64 => "u64",
            WireType::F32 => "f32",
            WireType::F64 => "f64",
            WireType::U8 => "u8",
            WireType::Bool => "bool",
        }
    }
}

/// Where one field of a packed message lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldLayout {
    /// libfranka's field name (e.g. `tau_J`).
    pub name: &'static str,
    /// The element type.
    pub ty: WireType,
    /// How many elements (1 for a scalar).
    pub count: usize,
    /// Byte offset of the first element from the start of the message.
    pub offset: usize,
}

impl FieldLayout {
    /// A field of `count` elements of `ty` at `offset`.
    pub const fn new(name: &'static str, ty: WireType, count: usize, offset: usize) -> Self {
        FieldLayout { name, ty, count, offset }
    }

    /// Bytes the field takes.
    pub const fn bytes(&self) -> usize {
        self.ty.size() * self.count
    }

    /// Offset one past the field's last byte.
    pub const fn end(&self) -> usize {
        self.offset + self.bytes()
    }
}

/// True if `fields` follow each other without gap or overlap from offset 0 and end at `size`.
pub const fn tiles_exactly(fields: &[FieldLayout], size: usize) -> bool {
    let mut expected = 0;
    let mut i = 0;
    while i < fields.len() {
        if fields[i].offset != expected {
            return false;
        }
        expected = fields[i].end();
        i += 1;
    }
    expected == size
}

/// A message could not be decoded; names the message, the field and the byte offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The message is not the size protocol v10 gives it.
    #[error("{what}: {got} bytes received, protocol v10 expects {expected} bytes")]
    WrongSize {
        /// The message.
        what: &'static str,
        /// Bytes received.
        got: usize,
        /// Bytes the v10 layout has.
        expected: usize,
    },
    /// The message is shorter than the part of it that must be read.
    #[error("{what}: {got} bytes received, at least {needed} bytes needed")]
    TooShort {
        /// The message.
        what: &'static str,
        /// Bytes received.
        got: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// A field lies past the end of the message (a layout bug, reported rather than panicking).
    #[error("{what}: field {field} at byte {offset} lies past the end ({len} bytes)")]
    OutOfBounds {
        /// The message.
        what: &'static str,
        /// The field.
        field: &'static str,
        /// Its byte offset.
        offset: usize,
        /// The message length.
        len: usize,
    },
    /// A `bool` byte is neither 0 nor 1.
    #[error("{what}: field {field} byte {offset} is {value}, a bool must be 0 or 1")]
    InvalidBool {
        /// The message.
        what: &'static str,
        /// The field.
        field: &'static str,
        /// The offending byte's offset.
        offset: usize,
        /// Its value.
        value: u8,
    },
    /// An enum field holds a value protocol v10 does not define.
    #[error("{what}: field {field} at byte {offset} is {value}, not a value of protocol v10")]
    UnknownValue {
        /// The message.
        what: &'static str,
        /// The field.
        field: &'static str,
        /// Its byte offset.
        offset: usize,
        /// The value found.
        value: u64,
    },
    /// A TCP frame header gives a size smaller than the header itself or absurdly large.
    #[error("{what}: header gives a frame size of {size} bytes, outside {min}..={max}")]
    InvalidFrameSize {
        /// The frame.
        what: &'static str,
        /// The size found in the header.
        size: u32,
        /// The smallest valid size (the header).
        min: usize,
        /// The largest size accepted.
        max: usize,
    },
}

/// Reads fields of a packed message at their offsets; every read is bounds-checked.
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    what: &'static str,
}

impl<'a> Reader<'a> {
    /// A reader over `bytes`, the message called `what` in errors.
    pub(crate) fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Reader { bytes, what }
    }

    /// The message length must be exactly `expected`.
    pub(crate) fn exact(bytes: &'a [u8], what: &'static str, expected: usize) -> Result<Self, DecodeError> {
        if bytes.len() == expected {
            Ok(Reader::new(bytes, what))
        } else {
            Err(DecodeError::WrongSize { what, got: bytes.len(), expected })
        }
    }

    fn take<const N: usize>(&self, field: &'static str, offset: usize) -> Result<[u8; N], DecodeError> {
        offset
            .checked_add(N)
            .and_then(|end| self.bytes.get(offset..end))
            .and_then(|s| <[u8; N]>::try_from(s).ok())
            .ok_or(DecodeError::OutOfBounds { what: self.what, field, offset, len: self.bytes.len() })
    }

    pub(crate) fn u64(&self, f: &FieldLayout) -> Result<u64, DecodeError> {
        self.take::<8>(f.name, f.offset).map(u64::from_le_bytes)
    }

    pub(crate) fn u32_at(&self, field: &'static str, offset: usize) -> Result<u32, DecodeError> {
        self.take::<4>(field, offset).map(u32::from_le_bytes)
    }

    pub(crate) fn u16_at(&self, field: &'static str, offset: usize) -> Result<u16, DecodeError> {
        self.take::<2>(field, offset).map(u16::from_le_bytes)
    }

    pub(crate) fn u8_at(&self, field: &'static str, offset: usize) -> Result<u8, DecodeError> {
        self.take::<1>(field, offset).map(|[b]| b)
    }

    /// An enum byte, mapped by `from_wire`; an undefined value is an error naming the field.
    pub(crate) fn enum_u8<T>(
        &self,
        f: &FieldLayout,
        from_wire: fn(u8) -> Option<T>,
    ) -> Result<T, DecodeError> {
        let value = self.u8_at(f.name, f.offset)?;
        from_wire(value).ok_or(DecodeError::UnknownValue {
            what: self.what,
            field: f.name,
            offset: f.offset,
            value: u64::from(value),
        })
    }

    pub(crate) fn bool_at(&self, field: &'static str, offset: usize) -> Result<bool, DecodeError> {
        match self.u8_at(field, offset)? {
            0 => Ok(false),
            1 => Ok(true),
            value => Err(DecodeError::InvalidBool { what: self.what, field, offset, value }),
        }
    }

    pub(crate) fn bool(&self, f: &FieldLayout) -> Result<bool, DecodeError> {
        self.bool_at(f.name, f.offset)
    }

    /// `N` packed `f32`s, widened (exactly) to `f64`.
    pub(crate) fn f32s<const N: usize>(&self, f: &FieldLayout) -> Result<[f64; N], DecodeError> {
        let mut out = [0.0; N];
        for (i, v) in out.iter_mut().enumerate() {
            let offset = f.offset + 4 * i;
            *v = f64::from(f32::from_le_bytes(self.take::<4>(f.name, offset)?));
        }
        Ok(out)
    }

    pub(crate) fn f32(&self, f: &FieldLayout) -> Result<f64, DecodeError> {
        self.f32s::<1>(f).map(|[v]| v)
    }

    pub(crate) fn f64s<const N: usize>(&self, f: &FieldLayout) -> Result<[f64; N], DecodeError> {
        let mut out = [0.0; N];
        for (i, v) in out.iter_mut().enumerate() {
            *v = f64::from_le_bytes(self.take::<8>(f.name, f.offset + 8 * i)?);
        }
        Ok(out)
    }
}

/// Writes fields of a packed message at their offsets into a zeroed buffer.
///
/// The layouts are checked at compile time to fit their buffers, so no write can fall outside; one that
/// did would be dropped rather than panic (and the fixture tests would show it).
pub(crate) struct Writer<'a> {
    bytes: &'a mut [u8],
}

impl<'a> Writer<'a> {
    pub(crate) fn new(bytes: &'a mut [u8]) -> Self {
        Writer { bytes }
    }

    pub(crate) fn put_at(&mut self, offset: usize, src: &[u8]) {
        if let Some(dst) = offset.checked_add(src.len()).and_then(|end| self.bytes.get_mut(offset..end)) {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = *s;
            }
        }
    }

    pub(crate) fn u64(&mut self, f: &FieldLayout, v: u64) {
        self.put_at(f.offset, &v.to_le_bytes());
    }

    pub(crate) fn u8(&mut self, f: &FieldLayout, v: u8) {
        self.put_at(f.offset, &[v]);
    }

    pub(crate) fn bool(&mut self, f: &FieldLayout, v: bool) {
        self.put_at(f.offset, &[u8::from(v)]);
    }

    /// Narrows each value to `f32` (round to nearest), as the robot would send it.
    pub(crate) fn f32s(&mut self, f: &FieldLayout, values: &[f64]) {
        for (i, v) in values.iter().enumerate() {
            // The v10 state carries f32: narrowing is the format, not an accident.
            #[allow(clippy::cast_possible_truncation)]
            let narrow = *v as f32;
            self.put_at(f.offset + 4 * i, &narrow.to_le_bytes());
        }
    }

    pub(crate) fn f64s(&mut self, f: &FieldLayout, values: &[f64]) {
        for (i, v) in values.iter().enumerate() {
            self.put_at(f.offset + 8 * i, &v.to_le_bytes());
        }
    }
}
