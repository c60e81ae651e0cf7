//! Hand set: the five fingertips of a hand, each from its fingertip file with the hand's overrides,
//! and one print plate (3MF) with all five standing on their mount faces inside the stated bed.
//! `load` applies every fingertip's rules and checks that the plate fits; `build` makes the parts
//! (in parallel) and the plate.

use crate::error::{Problem, Result};
use crate::params::hand::HandParams;
use crate::part::{Assembly, AssemblyObject, Part};
use rayon::prelude::*;
use serde_json::{json, Map, Value};

pub struct HandBuild {
    pub parts: Vec<Part>,
    pub assemblies: Vec<Assembly>,
    /// The `hands` manifest section entry.
    pub manifest: Map<String, Value>,
    pub notes: Vec<String>,
}

/// Reads a hand file (see [`crate::params::hand`]) and applies the rules of each finger's
/// fingertip and the plate's fit on the bed; every problem at once.
pub fn load(src: &crate::params::SourceFile, default_name: &str, dir: &std::path::Path) -> Result<HandParams> {
    let p = HandParams::from_source(src, default_name, dir)?;
    let mut problems: Vec<Problem> = Vec::new();
    for f in &p.fingers {
        if let Err(crate::error::Error::Input(ps)) = crate::fingertip::rules_on(&f.params, &f.src) {
            problems.extend(ps.0.into_iter().map(|pr| crate::params::hand::on_hand_file(pr, src, f.finger, &f.overridden)));
        }
    }
    let footprints: Vec<[f64; 2]> = p.fingers.iter().map(|f| [f.params.body.width_mm, f.params.body.thickness_mm]).collect();
    if let Err(need) = plate_slots(&footprints, p.bed_mm, p.spacing_mm) {
        problems.push(src.problem(
            "bed_mm",
            format!("[{}, {}]", p.bed_mm[0], p.bed_mm[1]),
            format!(
                "the five fingertips with {} mm between them need a bed of at least {:.1} × {:.1} mm: give a larger bed or a smaller spacing_mm",
                p.spacing_mm, need[0], need[1]
            ),
        ));
    }
    crate::params::finish(Some(p), problems)
}

/// Where each footprint (x, y size) goes on the bed: its lower-left corner, in rows along x with
/// `spacing` between parts and from the bed's edges. Err: the bed size the parts would need.
pub fn plate_slots(footprints: &[[f64; 2]], bed: [f64; 2], spacing: f64) -> std::result::Result<Vec<[f64; 2]>, [f64; 2]> {
    let (mut x, mut y, mut row_h, mut width) = (spacing, spacing, 0.0f64, 0.0f64);
    let mut slots = Vec::new();
    for f in footprints {
        if x + f[0] + spacing > bed[0] && x > spacing {
            x = spacing;
            y += row_h + spacing;
            row_h = 0.0;
        }
        slots.push([x, y]);
        x += f[0] + spacing;
        width = width.max(x);
        row_h = row_h.max(f[1]);
    }
    let need = [width.max(footprints.iter().map(|f| f[0] + 2.0 * spacing).fold(0.0, f64::max)), y + row_h + spacing];
    if need[0] > bed[0] + 1e-9 || need[1] > bed[1] + 1e-9 {
        // the smallest bed is one row
        let one_row = [spacing + footprints.iter().map(|f| f[0] + spacing).sum::<f64>(), 2.0 * spacing + footprints.iter().map(|f| f[1]).fold(0.0, f64::max)];
        return Err(if need[0] > bed[0] + 1e-9 { one_row } else { need });
    }
    Ok(slots)
}

/// Builds the five fingertips (in parallel) and the print plate.
pub fn build(p: &HandParams) -> Result<HandBuild> {
    let parts: Vec<Part> = p.fingers.par_iter().map(|f| crate::fingertip::build(&f.params)).collect::<Result<_>>()?;
    let sizes: Vec<([f64; 3], [f64; 3])> = parts.iter().map(|q| q.mesh.bbox()).collect();
    let footprints: Vec<[f64; 2]> = sizes.iter().map(|(lo, hi)| [hi[0] - lo[0], hi[1] - lo[1]]).collect();
    let slots = plate_slots(&footprints, p.bed_mm, p.spacing_mm).map_err(|need| {
        crate::error::Error::geometry(&p.name, format!("the built fingertips need a {:.1} × {:.1} mm bed, more than the footprints checked on loading", need[0], need[1]))
    })?;
    let mut objects = Vec::new();
    let mut layout = Map::new();
    for ((part, (lo, _)), (slot, f)) in parts.iter().zip(&sizes).zip(slots.iter().zip(&p.fingers)) {
        let d = [slot[0] - lo[0], slot[1] - lo[1], -lo[2]];
        objects.push(AssemblyObject::part(part.name.clone(), part.mesh.map(|v| [v[0] + d[0], v[1] + d[1], v[2] + d[2]])));
        layout.insert(f.finger.to_string(), json!({"part": part.name, "fingertip": f.fingertip_file, "overridden": f.overridden, "plate_offset_mm": d}));
    }
    let plate = Assembly { name: format!("{}-plate", p.name), parts: objects };
    let mut manifest = Map::new();
    manifest.insert(
        p.name.clone(),
        json!({"fingers": layout, "plate": format!("{}.3mf", plate.name), "bed_mm": p.bed_mm, "spacing_mm": p.spacing_mm,
               "frame": "each fingertip in its print pose (mount face on the bed), moved in x and y to its place on the plate"}),
    );
    let notes = vec![format!(
        "{}: print plate {}.3mf: {} fingertips on a {} × {} mm bed ({})",
        p.name,
        plate.name,
        parts.len(),
        p.bed_mm[0],
        p.bed_mm[1],
        p.fingers
            .iter()
            .map(|f| format!("{} = {}{}", f.finger, f.fingertip_file, if f.overridden.is_empty() { String::new() } else { format!(" with {}", f.overridden.join(", ")) }))
            .collect::<Vec<_>>()
            .join("; ")
    )];
    Ok(HandBuild { parts, assemblies: vec![plate], manifest, notes })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_wrap_into_rows_and_a_small_bed_says_what_it_needs() {
        let f = [[16.0, 14.0]; 5];
        let s = plate_slots(&f, [250.0, 210.0], 5.0).unwrap();
        assert_eq!(s[0], [5.0, 5.0]);
        assert_eq!(s[4], [5.0 + 4.0 * 21.0, 5.0]);
        let s = plate_slots(&f, [50.0, 100.0], 5.0).unwrap();
        assert_eq!(s[2], [5.0, 24.0], "two per row on a 50 mm bed");
        let need = plate_slots(&f, [20.0, 20.0], 5.0).unwrap_err();
        assert_eq!(need, [110.0, 24.0]);
    }
}
