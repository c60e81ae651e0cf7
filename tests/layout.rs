//! The module layout ARCHITECTURE.md states: `params` parses and type-checks, and never calls a
//! part family; the families' geometric rules are applied by the family (`fingertip::load`,
//! `mold::load`) on the way to `build`.

use std::path::Path;

/// Lines of code (comments and doc comments left out) in `src/params/` that name a module of the
/// part families or of the pipelines above them.
fn upward_calls() -> Vec<String> {
    let forbidden = ["crate::fingertip", "crate::mold", "crate::rig", "crate::build", "crate::export", "crate::checks"];
    let mut out = Vec::new();
    for entry in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/params")).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for f in forbidden {
                if code.contains(f) {
                    out.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
                }
            }
        }
    }
    out
}

#[test]
fn params_does_not_call_the_part_families() {
    let calls = upward_calls();
    assert!(calls.is_empty(), "params must only parse and type-check; these lines call upward (an import circle):\n{}", calls.join("\n"));
}

#[test]
fn geometric_rules_still_apply_through_the_family() {
    // a seat wider than the pad's flat: only the family's rules (which need the body) can see it
    let text = std::fs::read_to_string("params/fingertip-1s.toml").unwrap();
    let bad = text.replacen("flat_diameter_mm = ", "flat_diameter_mm = 30.0 # was ", 1);
    assert_ne!(bad, text, "fixture: params/fingertip-1s.toml has no flat_diameter_mm");
    let src = tipforge::params::SourceFile::parse("bad.toml", bad).unwrap();
    assert!(tipforge::params::fingertip::FingertipParams::from_source(&src, "bad", std::path::Path::new("params")).is_ok(), "params alone type-checks");
    let e = tipforge::fingertip::load(&src, "bad", std::path::Path::new("params")).unwrap_err();
    assert!(e.is_input() && e.to_string().contains("bad.toml:"), "{e}");
}

/// The diagnosis is read by the twin and the advice, never the other way: `sensor::diagnose` and its
/// stages do not name `advice` or `twin` (an import circle), and `cli` joins them.
#[test]
fn the_diagnosis_does_not_call_the_advice_or_the_twin() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/sensor");
    let files: Vec<_> = std::fs::read_dir(root.join("diagnose")).unwrap().map(|e| e.unwrap().path()).collect();
    assert!(files.iter().any(|p| p.ends_with("mod.rs")) && files.len() >= 10, "the diagnosis's stages are files in src/sensor/diagnose/: {files:?}");
    let mut out = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        for (i, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if ["advice::", "twin::"].iter().any(|f| code.contains(f)) {
                out.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(out.is_empty(), "the diagnosis calls downstream:\n{}", out.join("\n"));
}

/// Functions in `src/` longer than `max` lines (from the `fn` line to its closing brace, at the
/// same indentation), as "path:line name (n lines)".
fn long_functions(max: usize) -> Vec<String> {
    fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &mut files);
    files.sort();
    let mut long = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let body = line.trim_start();
            let indent = line.len() - body.len();
            let head = ["pub(crate) fn ", "pub(super) fn ", "pub fn ", "fn ", "const fn ", "pub const fn "].iter().find(|p| body.starts_with(**p));
            let Some(head) = head else { continue };
            if body.ends_with(';') {
                continue;
            }
            let closing = " ".repeat(indent) + "}";
            let Some(end) = lines[i + 1..].iter().position(|l| *l == closing) else { continue };
            let n = end + 2;
            if n > max {
                let name: String = body[head.len()..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                long.push(format!("{}:{} {name} ({n} lines)", path.display(), i + 1));
            }
        }
    }
    long
}

/// Pipelines read top-down: no function in `src/` is over 120 lines (the style guide's "about 120";
/// issue 15, item 8 for the diagnosis).
#[test]
fn no_function_is_over_120_lines() {
    let long = long_functions(120);
    assert!(long.is_empty(), "split these into stages:\n{}", long.join("\n"));
    // the measure can fail: a 30-line bound finds the long ones
    assert!(long_functions(30).len() > 10);
}

/// The diagnosis's shared modules (ARCHITECTURE.md) call no stage: no function a stage file defines
/// is called in them (comments and tests left out).
#[test]
fn the_diagnosiss_shared_modules_call_no_stage() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/sensor/diagnose");
    let code = |name: &str| -> String {
        let text = std::fs::read_to_string(dir.join(format!("{name}.rs"))).unwrap();
        let text = text.split("#[cfg(test)]").next().unwrap_or("").to_string();
        text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
    };
    let shared = ["model", "first_order", "input", "normal", "heldout", "gate", "parameters"];
    let stages = ["baseline", "touch", "locate", "select", "nuisance", "terms", "clip", "alternatives", "through", "spectrum", "refit", "report"];
    let mut defined = Vec::new();
    for s in stages {
        for line in code(s).lines() {
            let t = line.trim_start();
            for head in ["pub(super) fn ", "fn ", "pub fn "] {
                if let Some(rest) = t.strip_prefix(head) {
                    let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    defined.push((s, name));
                }
            }
        }
    }
    assert!(defined.len() > 40, "the stages' functions were found: {}", defined.len());
    let mut calls = Vec::new();
    for m in shared {
        let text = code(m);
        for (s, f) in &defined {
            let call = format!("{f}(");
            let found = text.match_indices(&call).any(|(i, _)| !text[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == '.'));
            if found {
                calls.push(format!("{m}.rs calls {s}::{f}"));
            }
        }
    }
    assert!(calls.is_empty(), "a shared module calls a stage:\n{}", calls.join("\n"));
}
