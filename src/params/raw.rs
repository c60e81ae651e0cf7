//! Shared machinery for reading parameter files: source text with line lookup, the unknown-key
//! scan with "did you mean", and a collector of validation problems.

use crate::error::{Error, Problem, Problems, Result};
use serde::de::DeserializeOwned;

/// A parsed parameter file with its text kept for locating keys.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceFile {
    pub file: String,
    pub text: String,
    pub value: toml::Value,
}

/// The keys a table accepts, and its sub-tables (arrays of tables are marked `array`).
///
/// `fields` is a function so that a table read into a serde struct takes its keys from the struct
/// itself (`fields_of::<RawCover>`): the struct is the one list of keys. Tables read as plain maps
/// list theirs (`|| &["sigma_v"]`).
pub struct Schema {
    pub fields: fn() -> &'static [&'static str],
    pub tables: &'static [(&'static str, bool, &'static Schema)],
}

/// The field names serde derives for struct `T` (what its `Deserialize` passes to
/// `deserialize_struct`, renames included); empty for a type that is not a struct.
pub fn fields_of<T: DeserializeOwned>() -> &'static [&'static str] {
    let mut captured = None;
    let _ = T::deserialize(FieldProbe(&mut captured));
    captured.unwrap_or(&[])
}

/// A deserializer that records the field list of the struct asked of it and then stops.
struct FieldProbe<'a>(&'a mut Option<&'static [&'static str]>);

impl<'de> serde::Deserializer<'de> for FieldProbe<'_> {
    type Error = serde::de::value::Error;

    fn deserialize_any<V: serde::de::Visitor<'de>>(self, _visitor: V) -> std::result::Result<V::Value, Self::Error> {
        Err(serde::de::Error::custom("not a struct"))
    }

    fn deserialize_struct<V: serde::de::Visitor<'de>>(self, _name: &'static str, fields: &'static [&'static str], _visitor: V) -> std::result::Result<V::Value, Self::Error> {
        *self.0 = Some(fields);
        Err(serde::de::Error::custom("fields recorded"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf option unit
        unit_struct newtype_struct seq tuple tuple_struct map enum identifier ignored_any
    }
}

impl SourceFile {
    pub fn parse(file: &str, text: String) -> Result<SourceFile> {
        match text.parse::<toml::Table>() {
            Ok(t) => Ok(SourceFile { file: file.to_string(), text, value: toml::Value::Table(t) }),
            Err(e) => {
                let (line, col) = e.span().map(|s| line_col(&text, s.start)).unwrap_or((1, 1));
                Err(Error::Input(Problems(vec![Problem {
                    file: format!("{file}:{line}:{col}"),
                    line: None,
                    path: "(syntax)".into(),
                    value: text.lines().nth(line - 1).unwrap_or("").trim().to_string(),
                    message: format!("TOML syntax error: {}; fix the line so it reads `key = value`", e.message()),
                }])))
            }
        }
    }

    /// A problem at `path`, with the line of that key when it can be found.
    pub fn problem(&self, path: &str, value: String, message: String) -> Problem {
        Problem { file: self.file.clone(), line: locate(&self.text, path), path: path.to_string(), value, message }
    }

    /// Every key that is not in the schema, each with a suggestion when one is close.
    pub fn unknown_keys(&self, schema: &Schema) -> Vec<Problem> {
        let mut out = Vec::new();
        if let toml::Value::Table(t) = &self.value {
            self.scan(t, schema, "", &mut out);
        }
        out
    }

    fn scan(&self, t: &toml::Table, schema: &Schema, prefix: &str, out: &mut Vec<Problem>) {
        let join = |k: &str| if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
        for (k, v) in t {
            if let Some((_, array, sub)) = schema.tables.iter().find(|(n, _, _)| n == k) {
                match (array, v) {
                    (false, toml::Value::Table(st)) => self.scan(st, sub, &join(k), out),
                    (true, toml::Value::Array(items)) => {
                        for (i, it) in items.iter().enumerate() {
                            if let toml::Value::Table(st) = it {
                                self.scan(st, sub, &format!("{}[{i}]", join(k)), out);
                            }
                        }
                    }
                    _ => out.push(self.problem(
                        &join(k),
                        short(v),
                        if *array {
                            format!("`{k}` must be an array of tables: write `[[{}]]` sections", join(k))
                        } else {
                            format!("`{k}` must be a table: write a `[{}]` section", join(k))
                        },
                    )),
                }
            } else if !(schema.fields)().contains(&k.as_str()) {
                let mut known: Vec<&str> = (schema.fields)().to_vec();
                for (n, _, _) in schema.tables {
                    if !known.contains(n) {
                        known.push(n);
                    }
                }
                let hint = match nearest(k, &known) {
                    Some(s) => format!("unknown key; did you mean `{s}`?"),
                    None => format!("unknown key; allowed here: {}", known.join(", ")),
                };
                out.push(self.problem(&join(k), short(v), hint));
            }
        }
    }

    /// Deserializes the sub-table at `key` (or the whole file for ""), reporting a type error
    /// with the key's path. Missing tables give `Some(default)`.
    pub fn table<T: DeserializeOwned + Default>(&self, key: &str, problems: &mut Vec<Problem>) -> Option<T> {
        let v = if key.is_empty() { Some(&self.value) } else { self.value.get(key) };
        match v {
            None => Some(T::default()),
            Some(v) => match T::deserialize(v.clone()) {
                Ok(t) => Some(t),
                Err(e) => {
                    problems.push(self.problem(key, "(table)".into(), format!("{}; fix the value's type", e.message().trim())));
                    None
                }
            },
        }
    }
}

fn short(v: &toml::Value) -> String {
    let s = v.to_string();
    if s.len() > 40 {
        format!("{}…", &s[..40])
    } else {
        s
    }
}

/// 1-based line and column of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    (line, col)
}

/// Finds the line of a TOML path such as `sensor[1].seat_depth_mm` or `body.width_mm` by
/// walking the section headers. Returns the header line when the key itself is absent.
pub fn locate(text: &str, path: &str) -> Option<usize> {
    let mut parts: Vec<&str> = path.split('.').collect();
    let key = parts.pop()?;
    // section name and array index of the table holding the key
    let (section, index) = match parts.last() {
        None => (String::new(), 0usize),
        Some(_) => {
            let joined = parts.join(".");
            match joined.rfind('[') {
                Some(b) if joined.ends_with(']') => (joined[..b].to_string(), joined[b + 1..joined.len() - 1].parse().unwrap_or(0)),
                _ => (joined, 0),
            }
        }
    };
    let key_plain = key.split('[').next().unwrap_or(key);
    let mut current = String::new();
    let mut seen_index: i64 = -1;
    let mut header_line = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.starts_with("[[") {
            current = line.trim_matches(|c| c == '[' || c == ']').trim().to_string();
            if current == section {
                seen_index += 1;
                if seen_index as usize == index {
                    header_line = Some(i + 1);
                }
            }
            continue;
        }
        if line.starts_with('[') {
            current = line.trim_matches(|c| c == '[' || c == ']').trim().to_string();
            if current == section {
                seen_index = 0;
                header_line = Some(i + 1);
            }
            continue;
        }
        let in_place = current == section && (section.is_empty() || seen_index as usize == index);
        if in_place {
            if let Some((k, _)) = line.split_once('=') {
                if k.trim().trim_matches('"') == key_plain {
                    return Some(i + 1);
                }
            }
        }
    }
    header_line
}

/// Damerau-free Levenshtein distance, for suggestions.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The closest known name, when it is close enough to be a typo (or the key lacks a unit suffix).
pub fn nearest<'a>(key: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| {
            let d = distance(key, k);
            let d = if k.starts_with(key) && k.len() > key.len() && k[key.len()..].starts_with('_') { 1 } else { d };
            (d, *k)
        })
        .filter(|(d, k)| *d <= 3.max(k.len() / 4))
        .min()
        .map(|(_, k)| k)
}

/// The file's `name` (it names the output files), or `default_name` when absent. Letters, digits,
/// '-' and '_' only, so a name can never leave the output folder.
pub fn part_name(src: &SourceFile, default_name: &str, problems: &mut Vec<Problem>) -> Option<String> {
    match src.value.get("name") {
        None => Some(default_name.to_string()),
        Some(toml::Value::String(s)) if !s.is_empty() && s.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_') => Some(s.clone()),
        Some(v) => {
            problems.push(src.problem("name", v.to_string(), "name must be letters, digits, '-' or '_' (it names the output files)".into()));
            None
        }
    }
}

/// Largest length (mm) any parameter may have: beyond it a value is a unit or typing mistake
/// (and would make the geometry routines run out of memory).
pub const MAX_LENGTH_MM: f64 = 1000.0;

/// The smallest length tipforge accepts for a positive dimension: a quarter of a 0.2 mm layer.
pub const MIN_FEATURE_MM: f64 = 0.05;
/// The smallest hole a 0.4 mm nozzle prints as a hole.
pub const MIN_HOLE_MM: f64 = 1.0;

/// Collects validation problems for one file; helpers return the value when it is usable.
pub struct Collector<'a> {
    pub src: &'a SourceFile,
    pub problems: Vec<Problem>,
}

impl<'a> Collector<'a> {
    pub fn new(src: &'a SourceFile) -> Self {
        Collector { src, problems: Vec::new() }
    }
    pub fn push(&mut self, path: &str, value: impl ToString, message: impl Into<String>) {
        let p = self.src.problem(path, value.to_string(), message.into());
        self.problems.push(p);
    }
    /// A required number.
    pub fn req(&mut self, v: Option<f64>, path: &str, example: &str) -> Option<f64> {
        match v {
            Some(x) if x.is_finite() && path.ends_with("_mm") && x.abs() > MAX_LENGTH_MM => {
                self.push(path, x, format!("larger than any part tipforge makes ({MAX_LENGTH_MM} mm): check the units (millimetres), e.g. {example}"));
                None
            }
            Some(x) if x.is_finite() => Some(x),
            Some(x) => {
                self.push(path, x, "must be a finite number");
                None
            }
            None => {
                self.push(path, "missing", format!("required; add `{} = {example}`", path.rsplit('.').next().unwrap_or(path)));
                None
            }
        }
    }
    /// A required number > 0.
    pub fn positive(&mut self, v: Option<f64>, path: &str, example: &str) -> Option<f64> {
        let x = self.req(v, path, example)?;
        if x <= 0.0 {
            self.push(path, x, format!("must be greater than 0 (for example {example})"));
            return None;
        }
        if path.ends_with("_mm") && x < MIN_FEATURE_MM {
            self.push(path, x, format!("below the smallest feature a printer reproduces ({MIN_FEATURE_MM} mm): check the units (millimetres), e.g. {example}"));
            return None;
        }
        Some(x)
    }
    /// A required length of at least `min` mm (a hole a nozzle can print round, a wall it can
    /// print at all); `why` says where the limit comes from.
    pub fn at_least_mm(&mut self, v: Option<f64>, path: &str, min: f64, why: &str, example: &str) -> Option<f64> {
        let x = self.positive(v, path, example)?;
        if x < min {
            self.push(path, x, format!("below {min} mm, {why}: use at least {min} mm (for example {example})"));
            return None;
        }
        Some(x)
    }
    /// A required number within [lo, hi].
    pub fn within(&mut self, v: Option<f64>, path: &str, lo: f64, hi: f64, example: &str) -> Option<f64> {
        let x = self.req(v, path, example)?;
        if !(lo..=hi).contains(&x) {
            self.push(path, x, format!("must be between {lo} and {hi}"));
            return None;
        }
        Some(x)
    }
    /// An optional number with a default, checked within [lo, hi].
    pub fn or_within(&mut self, v: Option<f64>, default: f64, path: &str, lo: f64, hi: f64) -> Option<f64> {
        let x = v.unwrap_or(default);
        if !x.is_finite() || !(lo..=hi).contains(&x) {
            self.push(path, x, format!("must be between {lo} and {hi} (default {default})"));
            return None;
        }
        Some(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Probed {
        width_mm: Option<f64>,
        #[serde(rename = "depth_mm")]
        depth: Option<f64>,
        inner: Option<Inner>,
    }
    #[derive(serde::Deserialize)]
    #[allow(dead_code)]
    struct Inner {
        a_mm: f64,
    }
    static INNER: Schema = Schema { fields: fields_of::<Inner>, tables: &[] };
    static PROBED: Schema = Schema { fields: fields_of::<Probed>, tables: &[("inner", false, &INNER)] };

    #[test]
    fn schema_keys_come_from_the_serde_struct() {
        assert_eq!(fields_of::<Probed>(), &["width_mm", "depth_mm", "inner"]);
        assert_eq!(fields_of::<Inner>(), &["a_mm"]);
        assert!(fields_of::<f64>().is_empty() && fields_of::<Vec<Inner>>().is_empty());
        let src = SourceFile::parse("t.toml", "width_mm = 1\ndepth = 2\n[inner]\na_mm = 1\nb_mm = 2\n".into()).unwrap();
        let found: Vec<(String, String)> = src.unknown_keys(&PROBED).into_iter().map(|p| (p.path, p.message)).collect();
        assert_eq!(found.len(), 2, "{found:?}");
        assert_eq!(found[0].0, "depth");
        assert!(found[0].1.contains("did you mean `depth_mm`"), "{found:?}");
        assert_eq!(found[1].0, "inner.b_mm");
        assert!(found[1].1.contains("a_mm"), "{found:?}");
    }

    #[test]
    fn locate_finds_keys_in_array_tables() {
        let t = "kind = \"x\"\n[body]\nwidth_mm = 1\n[[sensor]]\na_mm = 1\n[[sensor]]\nb = 2\na_mm = 3\n";
        assert_eq!(locate(t, "kind"), Some(1));
        assert_eq!(locate(t, "body.width_mm"), Some(3));
        assert_eq!(locate(t, "sensor[0].a_mm"), Some(5));
        assert_eq!(locate(t, "sensor[1].a_mm"), Some(8));
        assert_eq!(locate(t, "sensor[1].missing"), Some(6));
    }

    #[test]
    fn nearest_suggests_typos_and_missing_units() {
        let known = ["length_mm", "width_mm", "thickness_mm"];
        assert_eq!(nearest("lenght_mm", &known), Some("length_mm"));
        assert_eq!(nearest("width", &known), Some("width_mm"));
        assert_eq!(nearest("colour", &known), None);
    }

    #[test]
    fn syntax_error_has_line_and_column() {
        let e = SourceFile::parse("f.toml", "a = 1\nb = = 2\n".into()).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("f.toml:2:"), "{s}");
    }
}
