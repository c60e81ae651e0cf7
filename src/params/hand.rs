//! Hand set parameters (`kind = "hand"`): the fingertip file of the thumb and of each of the four
//! fingers, per-finger overrides of those files, and the print bed the plate must fit.
//!
//! ```toml
//! kind = "hand"
//! bed_mm = [250.0, 210.0]
//! [thumb]
//! fingertip = "fingertip-thumb.toml"
//! [little]
//! fingertip = "fingertip-1s.toml"
//! [little.set.body]          # merged into the fingertip file's [body] for this finger only
//! length_mm = 26.0
//! ```
//!
//! An override is merged into the named file's TOML before it is read, so every rule of a fingertip
//! applies to the finger as built; a problem with an overridden key is named on the hand file's line.

use super::fingertip::FingertipParams;
use super::{Collector, SourceFile};
use crate::error::{Error, Problem, Result};
use std::path::Path;

/// The five digits, in the order they are laid out on the plate.
pub const FINGERS: [&str; 5] = ["thumb", "index", "middle", "ring", "little"];

/// One finger of the set: the fingertip file as written, the merged source it was read from, and
/// its parameters (named `<hand>-<finger>`).
#[derive(Debug, Clone, PartialEq)]
pub struct Finger {
    pub finger: &'static str,
    pub fingertip_file: String,
    pub overridden: Vec<String>,
    pub src: SourceFile,
    pub params: FingertipParams,
}

#[derive(Debug, Clone, PartialEq)]
pub struct HandParams {
    pub name: String,
    pub fingers: Vec<Finger>,
    /// Print bed (x, y) the plate must fit, and the gap between parts on it.
    pub bed_mm: [f64; 2],
    pub spacing_mm: f64,
}

impl HandParams {
    /// Parses a hand file and the fingertip files it names (relative to `dir`), with each finger's
    /// overrides merged in. The fingertips' geometric rules are applied by [`crate::hand::load`].
    pub fn from_source(src: &SourceFile, default_name: &str, dir: &Path) -> Result<HandParams> {
        let mut c = Collector::new(src);
        let Some(top) = src.value.as_table() else { return super::finish(None, c.problems) };
        for key in top.keys() {
            if !["kind", "name", "bed_mm", "spacing_mm"].contains(&key.as_str()) && !FINGERS.contains(&key.as_str()) {
                let known: Vec<&str> = ["kind", "name", "bed_mm", "spacing_mm"].into_iter().chain(FINGERS).collect();
                let hint = super::nearest(key, &known).map(|s| format!("did you mean `{s}`?")).unwrap_or_else(|| format!("known keys: {}", known.join(", ")));
                c.push(key, "(key)", format!("unknown key; {hint}"));
            }
        }
        let name = super::part_name(src, default_name, &mut c.problems);
        let bed = match src.value.get("bed_mm") {
            None => Some([250.0, 210.0]),
            Some(toml::Value::Array(a))
                if a.len() == 2 && a.iter().all(|v| v.as_float().or(v.as_integer().map(|i| i as f64)).is_some_and(|x| x.is_finite() && x > 0.0 && x <= 2000.0)) =>
            {
                let f = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64)).unwrap_or(0.0);
                Some([f(&a[0]), f(&a[1])])
            }
            Some(v) => {
                c.push("bed_mm", v, "the print bed as [x_mm, y_mm], each above 0 and at most 2000, e.g. bed_mm = [250.0, 210.0]");
                None
            }
        };
        let spacing = c.or_within(src.value.get("spacing_mm").and_then(|v| v.as_float().or(v.as_integer().map(|i| i as f64))), 5.0, "spacing_mm", 1.0, 100.0);
        let mut fingers = Vec::new();
        for finger in FINGERS {
            if let Some(f) = read_finger(&mut c, src, finger, dir)? {
                fingers.push(f);
            }
        }
        let v = match (name, bed, spacing) {
            (Some(name), Some(bed_mm), Some(spacing_mm)) if fingers.len() == FINGERS.len() => Some(HandParams { name, fingers, bed_mm, spacing_mm }),
            _ => None,
        };
        super::finish(v, c.problems)
    }
}

/// One finger's table: its fingertip file, read with the `set` overrides merged in.
fn read_finger(c: &mut Collector, src: &SourceFile, finger: &'static str, dir: &Path) -> Result<Option<Finger>> {
    let Some(table) = src.value.get(finger).and_then(|v| v.as_table()) else {
        c.push(finger, "missing", format!("a hand names a fingertip file for each of {}: add `[{finger}]` with `fingertip = \"fingertip-1s.toml\"`", FINGERS.join(", ")));
        return Ok(None);
    };
    for key in table.keys().filter(|k| !["fingertip", "set"].contains(&k.as_str())) {
        c.push(&format!("{finger}.{key}"), "(key)", "unknown key; a finger takes `fingertip` (a file) and `set` (overrides of that file's keys)");
    }
    let Some(file) = table.get("fingertip").and_then(|v| v.as_str()) else {
        c.push(&format!("{finger}.fingertip"), "missing", "name the fingertip file, e.g. fingertip = \"fingertip-1s.toml\"");
        return Ok(None);
    };
    let Some(fsrc) = super::read_named(c, &format!("{finger}.fingertip"), file, dir, super::Kind::Fingertip, "a fingertip file")? else {
        return Ok(None);
    };
    let mut merged = fsrc;
    let mut overridden = Vec::new();
    if let Some(set) = table.get("set") {
        match set.as_table() {
            Some(t) => merge(&mut merged.value, t, "", &mut overridden),
            None => c.push(&format!("{finger}.set"), set, "overrides are a table of the fingertip file's keys, e.g. [little.set.body] then length_mm = 26.0"),
        }
    }
    // the finger is named after the hand and the digit, whatever the file calls itself
    if let Some(t) = merged.value.as_table_mut() {
        t.remove("name");
    }
    let stem = format!("{}-{finger}", src.value.get("name").and_then(|v| v.as_str()).unwrap_or("hand"));
    match FingertipParams::from_source(&merged, &stem, dir) {
        Ok(params) => Ok(Some(Finger { finger, fingertip_file: file.to_string(), overridden, src: merged, params })),
        Err(Error::Input(p)) => {
            c.problems.extend(p.0.into_iter().map(|pr| on_hand_file(pr, src, finger, &overridden)));
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Deep-merges `set` into `into` (tables merged key by key, other values replaced), recording the
/// dotted path of every value set.
fn merge(into: &mut toml::Value, set: &toml::Table, prefix: &str, paths: &mut Vec<String>) {
    for (k, v) in set {
        let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        let Some(t) = into.as_table_mut() else { return };
        match (t.get_mut(k), v) {
            (Some(existing @ toml::Value::Table(_)), toml::Value::Table(sub)) => merge(existing, sub, &path, paths),
            _ => {
                t.insert(k.clone(), v.clone());
                collect_leaves(v, &path, paths);
            }
        }
    }
}

fn collect_leaves(v: &toml::Value, path: &str, paths: &mut Vec<String>) {
    match v {
        toml::Value::Table(t) => t.iter().for_each(|(k, v)| collect_leaves(v, &format!("{path}.{k}"), paths)),
        _ => paths.push(path.to_string()),
    }
}

/// A problem with a key the hand file set is the hand file's, named on its line there.
pub fn on_hand_file(p: Problem, hand: &SourceFile, finger: &str, overridden: &[String]) -> Problem {
    let key = p.path.split('[').next().unwrap_or(&p.path).to_string();
    if overridden.iter().any(|o| o == &p.path || o == &key) {
        let mut q = hand.problem(&format!("{finger}.set.{}", p.path), p.value, p.message);
        q.message = format!("{} (set for the {finger} in this hand file)", q.message);
        q
    } else {
        p
    }
}
