//! The crate's one error type.

use std::fmt;
use std::path::PathBuf;

/// The crate's result type: `Error` unless said otherwise.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in meshsmooth.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or write.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },

    /// A file's content is malformed; `at` names the line (text) or byte offset (binary).
    #[error("{}{}: {msg}", path.display(), at.as_ref().map(|a| format!(": {a}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line or byte offset, when known.
        at: Option<Location>,
        /// What is wrong.
        msg: String,
    },

    /// The mesh is structurally unusable (bad indices, NaN coordinates, empty, ...).
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),

    /// The mesh has inverted or degenerate elements; optimisation needs a feasible start.
    #[error(
        "mesh has {count} inverted or degenerate element(s) (first ids: {}); it must be untangled first",
        fmt_ids(first)
    )]
    Inverted {
        /// How many elements are inverted or degenerate.
        count: usize,
        /// The first (up to five) of their ids.
        first: Vec<usize>,
    },

    /// Untangling left elements inverted; `reason` says why.
    #[error(
        "untangling failed: {count} element(s) remain inverted (first ids: {}); {reason}",
        fmt_ids(first)
    )]
    Untangle {
        /// How many elements remain inverted.
        count: usize,
        /// The first (up to five) of their ids.
        first: Vec<usize>,
        /// Why untangling stopped.
        reason: String,
    },

    /// Something meshsmooth does not handle (yet), such as pyramids.
    #[error("unsupported: {0}")]
    Unsupported(String),

    /// The GPU backend failed: no usable adapter, a device limit, a lost device.
    #[error("GPU: {0}")]
    Gpu(String),

    /// A caller passed an unusable option.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),

    /// A setting of [`Smoother`](crate::Smoother) is unusable: `option` is its
    /// name (a settings key, a Python keyword), `message` what is wrong and
    /// what it takes.
    #[error("invalid option {option}: {message}")]
    InvalidOption {
        /// The setting's name.
        option: &'static str,
        /// What is wrong and what it takes.
        message: String,
    },
}

/// Where in a file a parse error happened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    /// A 1-based line of a text file.
    Line(usize),
    /// A byte offset into a binary file.
    Byte(u64),
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Line(l) => write!(f, "line {l}"),
            Location::Byte(b) => write!(f, "byte {b}"),
        }
    }
}

fn fmt_ids(ids: &[usize]) -> String {
    ids.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", ")
}

impl Error {
    /// `Io` for this path and OS error.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// `Inverted` for these element ids, the first five named.
    pub fn inverted(bad: Vec<usize>) -> Self {
        Error::Inverted {
            count: bad.len(),
            first: bad.into_iter().take(5).collect(),
        }
    }

    /// `Parse` for this path, location and message.
    pub fn parse(path: impl Into<PathBuf>, at: Option<Location>, msg: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            at,
            msg: msg.into(),
        }
    }
}

/// An option enum that users name by string: on the command line (where,
/// with feature `cli`, it also derives `clap::ValueEnum` with the same
/// names), in the Python API and in configuration files.
pub trait Named: Sized + Copy + 'static {
    /// Every variant that may be named, in declaration order, with its name.
    const NAMES: &'static [(&'static str, Self)];

    /// The variant's name: its `NAMES` entry, or for a variant left out of
    /// `NAMES` (one not offered by name) the name it is shown by.
    fn name(&self) -> &'static str;

    /// The variant called `s`, in any (ASCII) case.
    fn by_name(s: &str) -> Option<Self> {
        Self::NAMES
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(s))
            .map(|&(_, v)| v)
    }
}

/// Parses a [`Named`] enum in any case; an unknown name is an error that
/// says which option it was for (`what`) and lists the names it takes.
pub fn parse_value_enum<T: Named>(what: &str, s: &str) -> Result<T> {
    T::by_name(s).ok_or_else(|| {
        let names: Vec<String> = T::NAMES.iter().map(|(name, _)| format!("'{name}'")).collect();
        Error::InvalidArgument(format!("{what} must be one of {}, got {s:?}", names.join(", ")))
    })
}

/// [`Named`] and `Display` (the name) for an option enum from its variants'
/// names (clap's spelling: kebab-case unless `#[value(name = ...)]` says
/// otherwise; a `#[value(skip)]` variant goes in the trailing `unnamed { ... }`
/// list, which is displayed but not parsed) and, given the option's name
/// (`Type: "what" { ... }`), `FromStr` through [`parse_value_enum`], as the
/// Python API and configuration files name them. A unit test checks every
/// table against clap's derive (feature `cli`).
macro_rules! by_name {
    ($t:ty { $($v:ident = $name:literal),* $(,)? } $(unnamed { $($u:ident = $uname:literal),* $(,)? })?) => {
        impl $crate::error::Named for $t {
            const NAMES: &'static [(&'static str, Self)] = &[$(($name, <$t>::$v)),*];

            fn name(&self) -> &'static str {
                match self {
                    $(Self::$v => $name,)*
                    $($(Self::$u => $uname,)*)?
                }
            }
        }
        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str($crate::error::Named::name(self))
            }
        }
    };
    ($t:ty: $what:literal { $($v:ident = $name:literal),* $(,)? } $(unnamed { $($u:ident = $uname:literal),* $(,)? })?) => {
        $crate::error::by_name!($t { $($v = $name),* } $(unnamed { $($u = $uname),* })?);
        impl std::str::FromStr for $t {
            type Err = $crate::Error;
            fn from_str(s: &str) -> $crate::Result<Self> {
                $crate::error::parse_value_enum($what, s)
            }
        }
    };
}
pub(crate) use by_name;

/// The error of a solver whose accepted step inverted an element.
pub(crate) fn accepted_step_inverted() -> Error {
    Error::InvalidMesh("an accepted step inverted an element (solver bug)".into())
}

#[cfg(all(test, feature = "cli"))]
mod tests {
    use super::Named;
    use clap::ValueEnum;

    /// The by-name table of `T` and clap's derive name the same variants, in
    /// the same order, with the same names and no aliases.
    fn same_names<T: Named + ValueEnum + PartialEq + std::fmt::Debug>() {
        let clap: Vec<(String, T)> = T::value_variants()
            .iter()
            .filter_map(|v| {
                let p = v.to_possible_value()?;
                assert_eq!(p.get_name_and_aliases().count(), 1, "{v:?} has aliases");
                Some((p.get_name().to_string(), *v))
            })
            .collect();
        let ours: Vec<(String, T)> = T::NAMES.iter().map(|(n, v)| (n.to_string(), *v)).collect();
        assert_eq!(ours, clap, "{}", std::any::type_name::<T>());
        for (name, v) in &ours {
            assert_eq!(T::by_name(&name.to_uppercase()), Some(*v));
            assert_eq!(v.name(), name);
            assert_eq!(<T as ValueEnum>::from_str(&name.to_uppercase(), true).ok(), Some(*v));
        }
        assert_eq!(T::by_name("no-such-name"), None);
    }

    #[test]
    fn by_name_tables_match_the_clap_derives() {
        use crate::generate::HorseshoeKind;
        use crate::metric::corner_model::Template;
        use crate::metric::smetric::MetricKind;
        use crate::partition::Partitioner;
        use crate::problem::BoundaryMode;
        use crate::solve::Method;
        use crate::solve::pcg::{NegativeCurvature, Preconditioner};
        same_names::<Template>();
        same_names::<crate::generate::LayerKind>();
        same_names::<MetricKind>();
        same_names::<Partitioner>();
        same_names::<HorseshoeKind>();
        same_names::<BoundaryMode>();
        same_names::<NegativeCurvature>();
        same_names::<Preconditioner>();
        same_names::<Method>();
        #[cfg(feature = "gpu")]
        {
            use crate::backend::gpu::{DeviceLayout, KernelForms, Precision};
            same_names::<Precision>();
            same_names::<KernelForms>();
            same_names::<DeviceLayout>();
        }
    }
}
