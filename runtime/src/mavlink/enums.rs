//! The macros generated dialects use to declare enums and flag sets.
//!
//! Both keep values the dialect does not name: an enum gets an `Unknown(raw)` variant and a flag
//! set keeps unknown bits, so decoding never fails on a value from a newer dialect.

/// Declares a MAVLink enum with an `Unknown(raw)` variant.
///
/// ```
/// ferrolink_runtime::mav_enum! {
///     /// Vehicle kinds.
///     pub enum MavType: u8 {
///         /// Generic.
///         Generic = 0,
///         FixedWing = 1,
///     }
/// }
/// assert_eq!(MavType::from_raw(1), MavType::FixedWing);
/// assert_eq!(MavType::from_raw(77), MavType::Unknown(77));
/// assert_eq!(MavType::Unknown(77).raw(), 77);
/// ```
#[macro_export]
macro_rules! mav_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident : $raw:ty {
            $( $(#[$vmeta:meta])* $variant:ident = $value:literal, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        $vis enum $name {
            $( $(#[$vmeta])* $variant, )*
            /// A value this dialect does not name.
            Unknown($raw),
        }

        #[allow(deprecated)]
        impl $name {
            /// The variant for `raw`; values without a name become `Unknown(raw)`.
            pub const fn from_raw(raw: $raw) -> Self {
                match raw {
                    $( $value => Self::$variant, )*
                    other => Self::Unknown(other),
                }
            }

            /// The raw value.
            pub const fn raw(self) -> $raw {
                match self {
                    $( Self::$variant => $value, )*
                    Self::Unknown(raw) => raw,
                }
            }
        }

        impl ::core::default::Default for $name {
            fn default() -> Self {
                Self::from_raw(0)
            }
        }

        impl ::core::convert::From<$raw> for $name {
            fn from(raw: $raw) -> Self {
                Self::from_raw(raw)
            }
        }

        impl ::core::convert::From<$name> for $raw {
            fn from(value: $name) -> Self {
                value.raw()
            }
        }

        impl $crate::wire::Enum for $name {
            #[inline(always)]
            fn from_bits(bits: u64) -> Self {
                Self::from_raw(bits as $raw)
            }
            #[inline(always)]
            fn bits(self) -> u64 {
                self.raw() as u64
            }
        }

        $crate::__serde_raw!($name, $raw);
    };
}

/// Declares a MAVLink bitmask enum as a flag set that keeps unknown bits.
///
/// ```
/// ferrolink_runtime::mav_bitmask! {
///     pub struct ModeFlag: u8 {
///         /// Armed.
///         const SAFETY_ARMED = 128;
///         const TEST_ENABLED = 2;
///     }
/// }
/// let f = ModeFlag::SAFETY_ARMED | ModeFlag::from_raw(1);
/// assert!(f.contains(ModeFlag::SAFETY_ARMED));
/// assert_eq!(f.raw(), 129);
/// ```
#[macro_export]
macro_rules! mav_bitmask {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident : $raw:ty {
            $( $(#[$vmeta:meta])* const $flag:ident = $value:literal; )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
        $vis struct $name(pub $raw);

        #[allow(deprecated)]
        impl $name {
            $( $(#[$vmeta])* pub const $flag: Self = Self($value); )*
            /// Every named flag with its name.
            pub const NAMED: &'static [(&'static str, Self)] = &[ $( (stringify!($flag), Self::$flag), )* ];

            /// The flag set with exactly these bits, named or not.
            pub const fn from_raw(raw: $raw) -> Self {
                Self(raw)
            }
            /// The raw bits.
            pub const fn raw(self) -> $raw {
                self.0
            }
            /// No flags.
            pub const fn empty() -> Self {
                Self(0)
            }
            /// Whether every bit of `other` is set.
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }
            /// Whether no bit is set.
            pub const fn is_empty(self) -> bool {
                self.0 == 0
            }
        }

        impl ::core::ops::BitOr for $name {
            type Output = Self;
            fn bitor(self, rhs: Self) -> Self {
                Self(self.0 | rhs.0)
            }
        }
        impl ::core::ops::BitOrAssign for $name {
            fn bitor_assign(&mut self, rhs: Self) {
                self.0 |= rhs.0;
            }
        }
        impl ::core::ops::BitAnd for $name {
            type Output = Self;
            fn bitand(self, rhs: Self) -> Self {
                Self(self.0 & rhs.0)
            }
        }
        impl ::core::ops::Not for $name {
            type Output = Self;
            fn not(self) -> Self {
                Self(!self.0)
            }
        }

        impl ::core::fmt::Debug for $name {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                let mut rest = self.0;
                let mut first = true;
                write!(f, "{}(", stringify!($name))?;
                for (name, flag) in Self::NAMED {
                    if flag.0 != 0 && self.contains(*flag) && rest & flag.0 != 0 {
                        if !first { f.write_str(" | ")?; }
                        f.write_str(name)?;
                        rest &= !flag.0;
                        first = false;
                    }
                }
                if rest != 0 || first {
                    if !first { f.write_str(" | ")?; }
                    write!(f, "{:#x}", rest)?;
                }
                f.write_str(")")
            }
        }

        impl ::core::convert::From<$raw> for $name {
            fn from(raw: $raw) -> Self {
                Self(raw)
            }
        }

        impl ::core::convert::From<$name> for $raw {
            fn from(value: $name) -> Self {
                value.0
            }
        }

        impl $crate::wire::Enum for $name {
            #[inline(always)]
            fn from_bits(bits: u64) -> Self {
                Self(bits as $raw)
            }
            #[inline(always)]
            fn bits(self) -> u64 {
                self.0 as u64
            }
        }

        $crate::__serde_raw!($name, $raw);
    };
}

/// serde as the raw integer, as pymavlink's `to_dict()` shows enum fields.
#[cfg(feature = "serde")]
#[doc(hidden)]
#[macro_export]
macro_rules! __serde_raw {
    ($name:ident, $raw:ty) => {
        impl $crate::__private::serde::Serialize for $name {
            fn serialize<S: $crate::__private::serde::Serializer>(
                &self,
                s: S,
            ) -> ::core::result::Result<S::Ok, S::Error> {
                $crate::__private::serde::Serialize::serialize(&<$raw>::from(*self), s)
            }
        }
        impl<'de> $crate::__private::serde::Deserialize<'de> for $name {
            fn deserialize<D: $crate::__private::serde::Deserializer<'de>>(
                d: D,
            ) -> ::core::result::Result<Self, D::Error> {
                <$raw as $crate::__private::serde::Deserialize>::deserialize(d).map(Self::from)
            }
        }
    };
}

#[cfg(not(feature = "serde"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __serde_raw {
    ($name:ident, $raw:ty) => {};
}

#[cfg(test)]
mod tests {
    use crate::wire::{get_enum, put_enum};

    crate::mav_enum! {
        enum Kind: u32 {
            A = 0,
            B = 70000,
        }
    }
    crate::mav_bitmask! {
        struct Flags: u16 {
            const X = 1;
            const Y = 0x100;
        }
    }

    #[test]
    fn unknown_values_round_trip_through_narrower_and_signed_fields() {
        let mut buf = [0u8; 4];
        put_enum::<i8, Kind>(&mut buf, 0, Kind::Unknown(0xFE));
        assert_eq!(buf[0], 0xFE);
        let k: Kind = get_enum::<i8, Kind>(&buf, 0);
        // Sign extension is cut back to the field's width on the way out.
        put_enum::<i8, Kind>(&mut buf, 1, k);
        assert_eq!(buf[1], 0xFE);
        assert_eq!(Kind::from_raw(70000), Kind::B);
    }

    #[test]
    fn flags_keep_unknown_bits_and_print_them() {
        let f = Flags::from_raw(0x8101);
        assert!(f.contains(Flags::X | Flags::Y));
        extern crate std;
        assert_eq!(std::format!("{f:?}"), "Flags(X | Y | 0x8000)");
        assert_eq!(std::format!("{:?}", Flags::empty()), "Flags(0x0)");
    }
}
