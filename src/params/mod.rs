//! Parameter files: raw serde structs that mirror the TOML, and one conversion per part family
//! that turns them into validated parameters while collecting every problem with its TOML path.
//!
//! Flow: text → `toml::Value` (syntax errors with file:line:column) → unknown-key scan over the
//! whole file (all unknown keys at once, with "did you mean"; a table's keys are its serde struct's
//! fields, read by `fields_of`, so no key is listed twice) → serde raw structs, table by table
//! (type errors per table) → `TryFrom`-style validation that collects every semantic problem.

pub mod board;
pub mod fingertip;
pub mod hand;
pub mod mold;
mod raw;
pub mod rig;
pub mod screws;
pub mod sensor;

pub use raw::{fields_of, nearest, part_name, Collector, Schema, SourceFile};

use crate::error::{Error, Problem, Result};
use std::path::Path;

/// What a parameter file describes, from its top-level `kind` key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Fingertip,
    Rig,
    Mold,
    Sensor,
    Protocol,
    Hand,
    SensorBoard,
}

impl Kind {
    pub const NAMES: &'static [&'static str] = &["fingertip", "rig", "mold", "hand", "sensor_board", "sensor", "protocol"];
    fn parse(s: &str) -> Option<Kind> {
        Some(match s {
            "fingertip" => Kind::Fingertip,
            "rig" => Kind::Rig,
            "mold" => Kind::Mold,
            "sensor" => Kind::Sensor,
            "protocol" => Kind::Protocol,
            "hand" => Kind::Hand,
            "sensor_board" => Kind::SensorBoard,
            _ => return None,
        })
    }
    /// Whether `tipforge build` turns files of this kind into printable parts.
    pub fn is_part(self) -> bool {
        matches!(self, Kind::Fingertip | Kind::Rig | Kind::Mold | Kind::Hand)
    }
}

/// Reads a parameter file and parses its TOML (syntax errors carry file:line:column).
pub fn read_source(path: &Path) -> Result<SourceFile> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let file = path.display().to_string();
    let text = utf8_text(&file, bytes)?;
    SourceFile::parse(&file, text)
}

/// A parameter file's bytes as text; bytes that are not UTF-8 are the user's input problem, named
/// with the line they stand on.
fn utf8_text(file: &str, bytes: Vec<u8>) -> Result<String> {
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        let shown = bytes[at..].iter().take(4).map(|b| format!("{b:#04x}")).collect::<Vec<_>>().join(" ");
        Error::Input(crate::error::Problems(vec![Problem {
            file: file.to_string(),
            line: Some(line),
            path: "(text)".into(),
            value: format!("bytes {shown}"),
            message: "not UTF-8 text: save the parameter file as UTF-8 (TOML files must be UTF-8)".into(),
        }]))
    })
}

/// The file's `kind`, or a problem naming the allowed kinds.
pub fn kind_of(src: &SourceFile) -> std::result::Result<Kind, Problem> {
    match src.value.get("kind") {
        Some(toml::Value::String(s)) => Kind::parse(s).ok_or_else(|| src.problem("kind", format!("{s:?}"), format!("unknown kind; use one of {}", Kind::NAMES.join(", ")))),
        Some(v) => Err(src.problem("kind", v.to_string(), "kind must be a string".into())),
        None => Err(src.problem("kind", "missing".into(), format!("add a top-level `kind = \"...\"` line, one of {}", Kind::NAMES.join(", ")))),
    }
}

/// A parameter file another file names (a mold's `fingertip`, a part's `sensor_board`, a hand's
/// digits), read from `dir`, the naming file's folder, and of the kind it must be (`what` names
/// that kind for the messages: "a fingertip file"). Problems are added to `c` at `key`.
pub fn read_named(c: &mut Collector, key: &str, file: &str, dir: &Path, want: Kind, what: &str) -> Result<Option<SourceFile>> {
    let path = dir.join(file);
    let src = match read_source(&path) {
        Ok(s) => s,
        Err(Error::Io { .. }) => {
            c.push(key, file, format!("cannot read {}: name {what} in the same folder as this file", path.display()));
            return Ok(None);
        }
        Err(Error::Input(p)) => {
            c.problems.extend(p.0);
            return Ok(None);
        }
        Err(e) => return Err(e),
    };
    match kind_of(&src) {
        Ok(k) if k == want => Ok(Some(src)),
        Ok(k) => {
            c.push(key, file, format!("{} is a {k:?} file, not {what}", path.display()));
            Ok(None)
        }
        Err(p) => {
            c.problems.push(p);
            Ok(None)
        }
    }
}

/// Turns collected problems into the error type, or passes the value on.
pub fn finish<T>(value: Option<T>, problems: Vec<Problem>) -> Result<T> {
    crate::error::Gather(problems).finish(value)
}

#[cfg(test)]
mod tests {
    #[test]
    fn bytes_that_are_not_utf8_are_an_input_problem_with_their_line() {
        let e = super::utf8_text("f.toml", b"kind = \"rig\"\n# caf\xe9\n".to_vec()).unwrap_err();
        assert!(e.is_input());
        let s = e.to_string();
        assert!(s.contains("f.toml:2:") && s.contains("0xe9") && s.contains("UTF-8"), "{s}");
    }
}
