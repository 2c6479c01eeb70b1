//! One declaration per message. [`wire_message!`] declares a payload's fields once, each with its wire
//! type, its meaning and, where it is not zero, its default; from that one declaration come the
//! `#[repr(C)]` struct, `Default`, the schema check ([`crate::inbox::Payload`]), the layout table of
//! docs/PROTOCOL.md ([`WireMessage::fields`]), the JSON view ([`WireField::to_json`]) and the bytes a seal is
//! computed over ([`WireMessage::write_sealed_bytes`]).

use serde_json::Value;

/// A value that can stand in a payload: fixed size, no pointers, written in little-endian order.
pub trait WireField: Copy {
    /// Its zero value (every field's default unless the declaration says otherwise).
    const ZERO: Self;

    /// Its type as docs/PROTOCOL.md writes it (`u32`, `f64[6]`, `Timing`).
    fn wire_type() -> String;

    /// Its JSON view (a NaN or an infinity is `null`).
    fn to_json(&self) -> Value;

    /// Its bytes, little-endian, handed to `sink` (no allocation).
    fn write_le(&self, sink: &mut dyn FnMut(&[u8]));
}

macro_rules! integer_field {
    ($($t:ty),*) => {$(
        impl WireField for $t {
            const ZERO: Self = 0;
            fn wire_type() -> String {
                stringify!($t).to_owned()
            }
            fn to_json(&self) -> Value {
                Value::from(*self)
            }
            fn write_le(&self, sink: &mut dyn FnMut(&[u8])) {
                sink(&self.to_le_bytes());
            }
        }
    )*};
}
integer_field!(u8, u16, u32, i32, u64);

impl WireField for f64 {
    const ZERO: Self = 0.0;
    fn wire_type() -> String {
        "f64".to_owned()
    }
    fn to_json(&self) -> Value {
        if self.is_finite() { Value::from(*self) } else { Value::Null }
    }
    fn write_le(&self, sink: &mut dyn FnMut(&[u8])) {
        sink(&self.to_bits().to_le_bytes());
    }
}

impl<T: WireField, const N: usize> WireField for [T; N] {
    const ZERO: Self = [T::ZERO; N];
    fn wire_type() -> String {
        format!("{}[{N}]", T::wire_type())
    }
    fn to_json(&self) -> Value {
        Value::Array(self.iter().map(WireField::to_json).collect())
    }
    fn write_le(&self, sink: &mut dyn FnMut(&[u8])) {
        for value in self {
            value.write_le(sink);
        }
    }
}

/// One field of a payload, as docs/PROTOCOL.md's table shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldInfo {
    /// The field's name.
    pub name: &'static str,
    /// Its offset in the payload (bytes).
    pub offset: usize,
    /// Its size (bytes).
    pub size: usize,
    /// Its wire type (`u32`, `f64[6]`, …).
    pub wire_type: String,
    /// What it means.
    pub meaning: String,
}

/// What every declared message (a payload or a part of one) knows about itself.
pub trait WireMessage: WireField + Default {
    /// The iceoryx2 type name (`vservo::JointState`) or, for a part, its short name (`Timing`).
    const TYPE_NAME: &'static str;

    /// Its fields in order.
    fn fields() -> Vec<FieldInfo>;

    /// The bytes a seal covers: every field but `seal`, in order, little-endian.
    fn write_sealed_bytes(&self, sink: &mut dyn FnMut(&[u8]));
}

/// Joins the lines of a doc comment into one line of text.
pub fn doc_text(lines: &[&str]) -> String {
    lines.iter().map(|line| line.trim()).filter(|line| !line.is_empty()).collect::<Vec<_>>().join(" ")
}

/// Declares a message: see the module's documentation. Each field is written
/// `/// meaning` `name: type [as CodeEnum] [= default],`; `as CodeEnum` appends the code's legend to the
/// meaning. `payload` messages start with `schema` (their default is [`crate::SCHEMA_VERSION`]); `part`
/// messages are carried inside a payload.
macro_rules! wire_message {
    (
        $(#[doc = $sdoc:literal])*
        $kind:ident $name:ident = $type_name:literal {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident: $ty:ty $(as $code:ty)? $(= $default:expr)?,
            )*
        }
    ) => {
        $(#[doc = $sdoc])*
        #[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
        #[type_name($type_name)]
        #[repr(C)]
        pub struct $name {
            $(
                $(#[doc = $fdoc])*
                pub $field: $ty,
            )*
        }

        impl Default for $name {
            fn default() -> Self {
                Self {
                    $( $field: wire_message!(@default $field, $ty $(, $default)?), )*
                }
            }
        }

        impl $crate::declare::WireField for $name {
            const ZERO: Self = Self { $( $field: <$ty as $crate::declare::WireField>::ZERO, )* };

            fn wire_type() -> String {
                $type_name.trim_start_matches("vservo::").to_owned()
            }

            fn to_json(&self) -> serde_json::Value {
                let mut object = serde_json::Map::new();
                $(
                    if stringify!($field) != "seal" {
                        object.insert(stringify!($field).to_owned(), $crate::declare::WireField::to_json(&self.$field));
                    }
                )*
                serde_json::Value::Object(object)
            }

            fn write_le(&self, sink: &mut dyn FnMut(&[u8])) {
                $( $crate::declare::WireField::write_le(&self.$field, sink); )*
            }
        }

        impl $crate::declare::WireMessage for $name {
            const TYPE_NAME: &'static str = $type_name;

            fn fields() -> Vec<$crate::declare::FieldInfo> {
                vec![$(
                    $crate::declare::FieldInfo {
                        name: stringify!($field),
                        offset: std::mem::offset_of!($name, $field),
                        size: std::mem::size_of::<$ty>(),
                        wire_type: <$ty as $crate::declare::WireField>::wire_type(),
                        meaning: wire_message!(@meaning $field [$($fdoc),*] $(, $code)?),
                    },
                )*]
            }

            fn write_sealed_bytes(&self, sink: &mut dyn FnMut(&[u8])) {
                $(
                    if stringify!($field) != "seal" {
                        $crate::declare::WireField::write_le(&self.$field, sink);
                    }
                )*
            }
        }

        wire_message!(@kind $kind $name);
    };

    (@default schema, $ty:ty) => { $crate::SCHEMA_VERSION };
    (@default $field:ident, $ty:ty) => { <$ty as $crate::declare::WireField>::ZERO };
    (@default $field:ident, $ty:ty, $default:expr) => { $default };

    (@meaning schema [$($fdoc:literal),*]) => {
        format!("{} ({})", $crate::declare::doc_text(&[$($fdoc),*]), $crate::SCHEMA_VERSION)
    };
    (@meaning $field:ident [$($fdoc:literal),*]) => { $crate::declare::doc_text(&[$($fdoc),*]) };
    (@meaning $field:ident [$($fdoc:literal),*], $code:ty) => {
        format!("{}: {}", $crate::declare::doc_text(&[$($fdoc),*]), <$code>::legend())
    };

    (@kind payload $name:ident) => {
        impl $crate::inbox::Payload for $name {
            fn schema(&self) -> u32 {
                self.schema
            }
        }
    };
    (@kind part $name:ident) => {};
}

pub(crate) use wire_message;
