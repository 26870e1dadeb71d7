//! The macros generated dialects use to declare enums and flag sets, and messages' `Debug`.
//!
//! Both keep values the dialect does not name: an enum gets an `Unknown(raw)` variant and a flag
//! set keeps unknown bits, so decoding never fails on a value from a newer dialect.

/// Implements a MAVLink enum declared with an `Unknown(raw)` variant: conversions from and to
/// the raw value, `Default` (the value 0), the wire trait and, with the `serde` feature, serde
/// as the raw integer.
///
/// ```
/// /// Vehicle kinds.
/// #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
/// pub enum MavType {
///     Generic,
///     FixedWing,
///     /// A value without a name.
///     Unknown(u8),
/// }
/// ferrolink_runtime::mav_enum!(MavType: u8 { Generic = 0, FixedWing = 1 });
///
/// assert_eq!(MavType::from_raw(1), MavType::FixedWing);
/// assert_eq!(MavType::from_raw(77), MavType::Unknown(77));
/// assert_eq!(MavType::Unknown(77).raw(), 77);
/// ```
#[macro_export]
macro_rules! mav_enum {
    ($name:ident : $raw:ty { $( $variant:ident = $value:literal ),* $(,)? }) => {
        #[allow(deprecated)]
        impl $name {
            /// The variant for `raw`; values without a name become `Unknown(raw)`.
            #[inline]
            pub const fn from_raw(raw: $raw) -> Self {
                match raw {
                    $( $value => Self::$variant, )*
                    other => Self::Unknown(other),
                }
            }

            /// The raw value.
            #[inline]
            pub const fn raw(self) -> $raw {
                match self {
                    $( Self::$variant => $value, )*
                    Self::Unknown(raw) => raw,
                }
            }
        }

        impl ::core::default::Default for $name {
            #[inline]
            fn default() -> Self {
                Self::from_raw(0)
            }
        }

        impl ::core::convert::From<$raw> for $name {
            #[inline]
            fn from(raw: $raw) -> Self {
                Self::from_raw(raw)
            }
        }

        impl ::core::convert::From<$name> for $raw {
            #[inline]
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

/// Implements a MAVLink bitmask declared as `struct Name(pub raw)` with one associated const per
/// flag: set operations, `Debug` that names known flags and shows unknown bits, conversions,
/// the wire trait and serde as the raw integer.
///
/// ```
/// #[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
/// pub struct ModeFlag(pub u8);
/// impl ModeFlag {
///     /// Armed.
///     pub const SAFETY_ARMED: Self = Self(128);
///     pub const TEST_ENABLED: Self = Self(2);
/// }
/// ferrolink_runtime::mav_bitmask!(ModeFlag: u8 { SAFETY_ARMED, TEST_ENABLED });
///
/// let f = ModeFlag::SAFETY_ARMED | ModeFlag::from_raw(1);
/// assert!(f.contains(ModeFlag::SAFETY_ARMED));
/// assert_eq!(f.raw(), 129);
/// assert_eq!(format!("{f:?}"), "ModeFlag(SAFETY_ARMED | 0x1)");
/// ```
#[macro_export]
macro_rules! mav_bitmask {
    ($name:ident : $raw:ty { $( $flag:ident ),* $(,)? }) => {
        #[allow(deprecated)]
        impl $name {
            /// Every named flag with its name.
            pub const NAMED: &'static [(&'static str, Self)] = &[ $( (stringify!($flag), Self::$flag), )* ];

            /// The flag set with exactly these bits, named or not.
            #[inline]
            pub const fn from_raw(raw: $raw) -> Self {
                Self(raw)
            }
            /// The raw bits.
            #[inline]
            pub const fn raw(self) -> $raw {
                self.0
            }
            /// No flags.
            #[inline]
            pub const fn empty() -> Self {
                Self(0)
            }
            /// Whether every bit of `other` is set.
            #[inline]
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }
            /// Whether no bit is set.
            #[inline]
            pub const fn is_empty(self) -> bool {
                self.0 == 0
            }
        }

        impl ::core::ops::BitOr for $name {
            type Output = Self;
            #[inline]
            fn bitor(self, rhs: Self) -> Self {
                Self(self.0 | rhs.0)
            }
        }
        impl ::core::ops::BitOrAssign for $name {
            #[inline]
            fn bitor_assign(&mut self, rhs: Self) {
                self.0 |= rhs.0;
            }
        }
        impl ::core::ops::BitAnd for $name {
            type Output = Self;
            #[inline]
            fn bitand(self, rhs: Self) -> Self {
                Self(self.0 & rhs.0)
            }
        }
        impl ::core::ops::Not for $name {
            type Output = Self;
            #[inline]
            fn not(self) -> Self {
                Self(!self.0)
            }
        }

        impl ::core::fmt::Debug for $name {
            #[inline]
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                $crate::mavlink::fmt_flags(f, stringify!($name), self.0 as u64, Self::NAMED.iter().map(|(n, v)| (*n, v.0 as u64)))
            }
        }

        impl ::core::convert::From<$raw> for $name {
            #[inline]
            fn from(raw: $raw) -> Self {
                Self(raw)
            }
        }

        impl ::core::convert::From<$name> for $raw {
            #[inline]
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

/// Implements `Debug` for a message struct exactly as `#[derive(Debug)]` would print it, with
/// the field names given as written (without `r#`), but `#[inline]`: a dialect crate then
/// compiles no formatting code for its hundreds of messages unless it prints them.
///
/// ```
/// #[derive(Clone, Copy, PartialEq)]
/// pub struct Ping {
///     pub seq: u32,
///     pub r#type: u8,
/// }
/// ferrolink_runtime::mav_debug!(Ping { seq: "seq", r#type: "type" });
///
/// assert_eq!(format!("{:?}", Ping { seq: 7, r#type: 1 }), "Ping { seq: 7, type: 1 }");
/// ```
#[macro_export]
macro_rules! mav_debug {
    ($name:ident { $( $field:ident : $label:literal ),* $(,)? }) => {
        #[allow(deprecated)]
        impl ::core::fmt::Debug for $name {
            #[inline]
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                f.debug_struct(stringify!($name))
                    $( .field($label, &self.$field) )*
                    .finish()
            }
        }
    };
}

/// `Debug` for flag sets, shared by every generated bitmask: `Name(A | B | 0x80)`.
#[doc(hidden)]
pub fn fmt_flags(
    f: &mut core::fmt::Formatter<'_>,
    name: &str,
    bits: u64,
    named: impl Iterator<Item = (&'static str, u64)>,
) -> core::fmt::Result {
    let mut rest = bits;
    let mut first = true;
    write!(f, "{name}(")?;
    for (flag, value) in named {
        if value != 0 && bits & value == value && rest & value != 0 {
            if !first {
                f.write_str(" | ")?;
            }
            f.write_str(flag)?;
            rest &= !value;
            first = false;
        }
    }
    if rest != 0 || first {
        if !first {
            f.write_str(" | ")?;
        }
        write!(f, "{rest:#x}")?;
    }
    f.write_str(")")
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

    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    enum Kind {
        A,
        B,
        Unknown(u32),
    }
    crate::mav_enum!(Kind: u32 { A = 0, B = 70000 });

    #[derive(Clone, Copy, PartialEq, Eq)]
    struct Flags(u16);
    impl Flags {
        const X: Self = Self(1);
        const Y: Self = Self(0x100);
    }
    crate::mav_bitmask!(Flags: u16 { X, Y });

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
        assert_eq!(f.raw(), 0x8101);
        assert!(Flags::empty().is_empty() && !f.is_empty());
        extern crate std;
        assert_eq!(std::format!("{f:?}"), "Flags(X | Y | 0x8000)");
        assert_eq!(std::format!("{:?}", Flags::empty()), "Flags(0x0)");
    }
}
