//! The crate's one error type.

use std::fmt;
use std::path::PathBuf;

pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The operating system refused a read or write.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },

    /// A file's content is malformed; `at` names the line (text) or byte offset (binary).
    #[error("{}{}: {msg}", path.display(), at.as_ref().map(|a| format!(": {a}")).unwrap_or_default())]
    Parse {
        path: PathBuf,
        at: Option<Location>,
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
    Inverted { count: usize, first: Vec<usize> },

    /// Untangling left elements inverted; `reason` says why.
    #[error(
        "untangling failed: {count} element(s) remain inverted (first ids: {}); {reason}",
        fmt_ids(first)
    )]
    Untangle {
        count: usize,
        first: Vec<usize>,
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
    InvalidOption { option: &'static str, message: String },
}

/// Where in a file a parse error happened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Location {
    Line(usize),
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

    pub fn parse(path: impl Into<PathBuf>, at: Option<Location>, msg: impl Into<String>) -> Self {
        Error::Parse {
            path: path.into(),
            at,
            msg: msg.into(),
        }
    }
}

/// Parses a `clap::ValueEnum` in any case; an unknown name is an error that
/// says which option it was for (`what`) and lists the names it takes.
pub fn parse_value_enum<T: clap::ValueEnum>(what: &str, s: &str) -> Result<T> {
    T::from_str(s, true).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| format!("'{}'", p.get_name()))
            .collect();
        Error::InvalidArgument(format!("{what} must be one of {}, got {s:?}", names.join(", ")))
    })
}

/// `FromStr` for option enums through [`parse_value_enum`], as the Python
/// API and configuration files name them.
macro_rules! from_str_by_name {
    ($($t:ty: $what:literal),* $(,)?) => {$(
        impl std::str::FromStr for $t {
            type Err = $crate::Error;
            fn from_str(s: &str) -> $crate::Result<Self> {
                $crate::error::parse_value_enum($what, s)
            }
        }
    )*};
}
pub(crate) use from_str_by_name;
