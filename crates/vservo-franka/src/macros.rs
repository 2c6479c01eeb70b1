//! Crate-internal macros.

/// Defines a fieldless enum carried on the wire as one integer, with `from_wire`, `to_wire` and `name`.
macro_rules! wire_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident : $repr:ty {
            $( $(#[$vmeta:meta])* $variant:ident = $value:literal => $text:literal, )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $name {
            $( $(#[$vmeta])* $variant, )+
        }

        impl $name {
            /// Every value, in wire order.
            pub const ALL: &'static [$name] = &[$( $name::$variant, )+];

            /// The value a wire integer stands for, or `None` if the protocol defines none.
            pub const fn from_wire(value: $repr) -> Option<Self> {
                match value {
                    $( $value => Some($name::$variant), )+
                    _ => None,
                }
            }

            /// The integer this value is sent as.
            pub const fn to_wire(self) -> $repr {
                match self {
                    $( $name::$variant => $value, )+
                }
            }

            /// libfranka's name of this value (e.g. `kReflexAborted`).
            pub const fn name(self) -> &'static str {
                match self {
                    $( $name::$variant => $text, )+
                }
            }
        }

        impl ::std::fmt::Display for $name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}
