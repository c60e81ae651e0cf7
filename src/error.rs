//! Typed library errors. Parameter problems are collected, never thrown one by one.

use std::fmt;
use std::path::PathBuf;

/// One problem with an input file: where it is, what value was found, and how to fix it.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// File the problem is in (as given on the command line or found in `params/`).
    pub file: String,
    /// 1-based line of the key, when it could be located.
    pub line: Option<usize>,
    /// TOML path of the offending key, e.g. `sensor[1].seat_diameter_mm`.
    pub path: String,
    /// The value found, rendered as text ("missing" when absent).
    pub value: String,
    /// The rule broken and the fix.
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {} = {}: {}", self.file, l, self.path, self.value, self.message),
            None => write!(f, "{}: {} = {}: {}", self.file, self.path, self.value, self.message),
        }
    }
}

impl Problem {
    /// A problem not tied to a line of a file: a command-line value, a whole file.
    pub fn new(file: impl Into<String>, path: impl Into<String>, value: impl ToString, message: impl Into<String>) -> Problem {
        Problem { file: file.into(), line: None, path: path.into(), value: value.to_string(), message: message.into() }
    }
}

/// A list of problems, shown one per line.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Problems(pub Vec<Problem>);

impl fmt::Display for Problems {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{} problem(s) found:", self.0.len())?;
        for p in &self.0 {
            writeln!(f, "  {p}")?;
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input: every problem found, each with its path, value and fix.
    #[error("{0}")]
    Input(Problems),
    /// Not marked as the error's source, so a printed chain does not repeat the I/O message.
    #[error("{path}: {err}")]
    Io { path: PathBuf, err: std::io::Error },
    /// The geometry kernel or a check refused a part built from valid parameters.
    #[error("part {part}: {message}")]
    Geometry { part: String, message: String },
    /// A result failed a sanity rule of its own stage: a defect in tipforge, never printed as a
    /// result (exit code 1).
    #[error("internal error in {stage}: {message} (a defect in tipforge: please report it with the input)")]
    Internal { stage: &'static str, message: String },
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), err: source }
    }
    pub fn geometry(part: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Geometry { part: part.into(), message: message.into() }
    }
    /// One input problem (see [`Problem::new`]).
    pub fn input(file: impl Into<String>, path: impl Into<String>, value: impl ToString, message: impl Into<String>) -> Self {
        Error::Input(Problems(vec![Problem::new(file, path, value, message)]))
    }
    /// A file or folder the user named that cannot be read is their input problem (exit code 2):
    /// an I/O error becomes one problem at `path` (the option or "(file)") with the fix; any other
    /// error is returned as it is.
    pub fn io_as_input(self, path: &str, fix: &str) -> Self {
        match self {
            Error::Io { path: p, err } => Error::input(p.display().to_string(), path, "unreadable", format!("{err}: {fix}")),
            e => e,
        }
    }
    /// Whether this error is the user's input (exit code 2) rather than an internal failure.
    pub fn is_input(&self) -> bool {
        matches!(self, Error::Input(_))
    }
}

pub type Result<T> = std::result::Result<T, Error>;

/// Gathers the input problems of several steps so the command reports them all at once; any
/// other error stops at once.
#[derive(Default)]
pub struct Gather(pub Vec<Problem>);

impl Gather {
    pub fn take<T>(&mut self, r: Result<T>) -> Result<Option<T>> {
        match r {
            Ok(v) => Ok(Some(v)),
            Err(Error::Input(p)) => {
                self.0.extend(p.0);
                Ok(None)
            }
            Err(e) => Err(e),
        }
    }
    /// The value when no step had a problem.
    pub fn finish<T>(self, v: Option<T>) -> Result<T> {
        match v {
            Some(v) if self.0.is_empty() => Ok(v),
            _ => Err(Error::Input(Problems(self.0))),
        }
    }
}
