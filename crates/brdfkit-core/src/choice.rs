//! Structural choices by name: one parser for every enum that has a `name()` and a list
//! of its variants (distribution, masking, Fresnel kind, normalisation, loss, solver...),
//! so the reverse mapping from names is never written by hand.

use std::fmt;

/// A name that is none of a choice's variants.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownName {
    /// What was being chosen ("distribution", "loss", ...).
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// Every accepted name, in the order of the variants.
    pub known: Vec<&'static str>,
}

impl fmt::Display for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown {} `{}` (expected {})",
            self.what,
            self.given,
            self.known.join(", ")
        )
    }
}

impl std::error::Error for UnknownName {}

/// The variant of `all` whose `name` is `s`.
pub fn parse_named<T: Copy>(
    what: &'static str,
    s: &str,
    all: &[T],
    name: impl Fn(T) -> &'static str,
) -> Result<T, UnknownName> {
    all.iter()
        .copied()
        .find(|&v| name(v) == s)
        .ok_or_else(|| UnknownName {
            what,
            given: s.to_string(),
            known: all.iter().map(|&v| name(v)).collect(),
        })
}

/// Implements `FromStr` (error [`UnknownName`]) and `Display` for a `Copy` enum from its
/// `ALL` list and its `name(self)` method. Given the variants with their names
/// (`{ Variant => "name", ... }`, in declaration order), it writes `ALL` and `name` too.
#[macro_export]
macro_rules! named_choice {
    ($ty:ident, $what:literal, { $($v:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every variant, in declaration order.
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$v),+];

            /// The variant's name in the JSON contract and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$v => $name,)+
                }
            }
        }
        $crate::named_choice!($ty, $what);
    };
    ($ty:ty, $what:literal) => {
        impl ::std::str::FromStr for $ty {
            type Err = $crate::choice::UnknownName;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                $crate::choice::parse_named($what, s, &<$ty>::ALL, |v: $ty| v.name())
            }
        }
        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use crate::scattering::{BeckmannG1, Distribution, Masking};

    #[test]
    fn every_name_parses_back_to_its_variant() {
        for d in Distribution::ALL {
            assert_eq!(d.name().parse::<Distribution>().unwrap(), d);
            assert_eq!(d.to_string(), d.name());
        }
        for m in Masking::ALL {
            assert_eq!(m.name().parse::<Masking>().unwrap(), m);
        }
        for b in BeckmannG1::ALL {
            assert_eq!(b.name().parse::<BeckmannG1>().unwrap(), b);
        }
    }

    #[test]
    fn an_unknown_name_lists_the_known_ones() {
        let e = "ggz".parse::<Distribution>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown distribution `ggz` (expected beckmann, ggx)"
        );
    }
}
