//! `out/manifest.json`: per part, its source and checksum, volume, mass, box, triangles, genus.

use crate::part::Part;
use serde_json::{json, Map, Value};
use sha2::{Digest, Sha256};

pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

/// The manifest entry of one part.
pub fn entry(part: &Part, source: &str, source_sha256: &str, files: &[String]) -> Value {
    let (lo, hi) = part.mesh.bbox();
    let mut m = Map::new();
    m.insert("source".into(), json!(source));
    m.insert("source_sha256".into(), json!(source_sha256));
    m.insert("files".into(), json!(files));
    m.insert("volume_mm3".into(), json!(round(part.volume_mm3(), 3)));
    m.insert("mass_g".into(), json!(round(part.mass_g(), 4)));
    m.insert("density_g_cm3".into(), json!(part.density_g_cm3));
    m.insert("infill".into(), json!(part.infill));
    m.insert("process".into(), json!(part.process.name()));
    if part.process == crate::part::Process::Printed {
        // "none": the part prints without support in the orientation it is written in, and the
        // slicer check holds it to that; otherwise where it needs support
        m.insert("supports".into(), json!(part.supports.map(|w| format!("needed: {w}")).unwrap_or_else(|| "none".into())));
    }
    m.insert(
        "bbox_mm".into(),
        json!({"min": lo.map(|v| round(v, 4)), "max": hi.map(|v| round(v, 4)), "size": [round(hi[0]-lo[0], 4), round(hi[1]-lo[1], 4), round(hi[2]-lo[2], 4)]}),
    );
    m.insert("triangles".into(), json!(part.mesh.triangles.len()));
    m.insert("genus".into(), json!(part.solid.genus()));
    m.insert("features".into(), part.features.clone());
    for (k, v) in &part.extra {
        m.insert(k.clone(), v.clone());
    }
    Value::Object(m)
}

/// Adds to `parts` and the sections every entry of an earlier manifest (`tipforge.manifest/1`)
/// that the new build does not replace; anything else in it is dropped.
pub fn keep_others(old: &Value, parts: &mut Map<String, Value>, sections: &mut Map<String, Value>) {
    if old.get("schema").and_then(Value::as_str) != Some("tipforge.manifest/1") {
        return;
    }
    let Some(top) = old.as_object() else { return };
    for (key, value) in top {
        let Some(old_entries) = value.as_object() else { continue };
        let target = match key.as_str() {
            "parts" => &mut *parts,
            "tool" | "units" => continue,
            _ => match sections.entry(key.clone()).or_insert_with(|| Value::Object(Map::new())) {
                Value::Object(o) => o,
                _ => continue,
            },
        };
        for (name, entry) in old_entries {
            target.entry(name.clone()).or_insert_with(|| entry.clone());
        }
    }
}

pub fn document(parts: Map<String, Value>, extra: Map<String, Value>) -> Vec<u8> {
    let mut top = Map::new();
    top.insert("schema".into(), json!("tipforge.manifest/1"));
    top.insert("tool".into(), json!({"name": "tipforge", "version": env!("CARGO_PKG_VERSION")}));
    top.insert("units".into(), json!({"length": "mm", "mass": "g", "force": "N"}));
    top.insert("parts".into(), Value::Object(parts));
    for (k, v) in extra {
        top.insert(k, v);
    }
    let mut s = serde_json::to_string_pretty(&Value::Object(top)).expect("json");
    s.push('\n');
    s.into_bytes()
}
