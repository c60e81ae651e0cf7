//! The flat style: the paper's petri-dish method for comparison. An open tray casts a flat sheet
//! whose size is the pad's developed cover (meridian length × cross-section arc, plus a margin to
//! cut away), with one dome pattern per sensor at its developed position.

use super::{layout, material, notes, Layout, MoldBuild};
use crate::checks::Violation;
use crate::error::{Error, Result};
use crate::mesh::{segments, Solid};
use crate::params::mold::MoldParams;
use crate::part::Part;
use serde_json::{json, Map};

/// Arc length of a plane curve given as points.
fn arc(points: &[[f64; 2]]) -> f64 {
    points.windows(2).map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt()).sum()
}

/// Developed sheet: (meridian length from the cover's end to its edge at the tip, cross-section
/// arc at the cover's end below the parting plane, each dome's developed (u, v)).
pub fn developed(l: &Layout) -> (f64, f64, Vec<[f64; 2]>) {
    let s = &l.shape;
    let ze = l.z_parting;
    let n = 2000;
    // meridian along y = 0 from x_start until the pad bottom rises to the parting plane
    let meridian: Vec<[f64; 2]> =
        (0..=n).map(|i| l.x_start + (s.length - l.x_start) * i as f64 / n as f64).filter(|&x| s.pad_depth_at(x) >= -ze).map(|x| [x, -s.pad_depth_at(x)]).collect();
    let length = arc(&meridian);
    let cross = |x: f64, y_to: Option<f64>| -> f64 {
        let r = s.pad_depth_at(x);
        let phi0 = (-ze / r).clamp(-1.0, 1.0).asin();
        let pts: Vec<[f64; 2]> = (0..=n)
            .map(|i| {
                let phi = phi0 + (std::f64::consts::PI - 2.0 * phi0) * i as f64 / n as f64;
                [s.half_width(x) * phi.cos(), -r * phi.sin()]
            })
            .filter(|p| y_to.is_none_or(|y| (p[0] >= 0.0 && p[0] <= y) || (p[0] < 0.0 && p[0] >= y)))
            .collect();
        arc(&pts)
    };
    let width = cross(l.x_start, None);
    let domes = l
        .seats
        .iter()
        .map(|st| {
            let x = st.surface[0];
            let u = arc(&meridian.iter().copied().filter(|p| p[0] <= x).collect::<Vec<_>>());
            let y = st.surface[1];
            let v = if y.abs() < 1e-9 { 0.0 } else { cross(x, Some(y)) / 2.0 * y.signum() };
            [u, v]
        })
        .collect();
    (length, width, domes)
}

/// Builds a flat mold file: the cast sheet, the tray that casts it, their checks, the manifest
/// entry (with the developed cover) and the summary's lines.
pub fn build(p: &MoldParams) -> Result<MoldBuild> {
    let name = p.name.as_str();
    let l = layout(p).map_err(|e| Error::geometry(name, e))?;
    let (m, c) = (&p.mold, &p.cover);
    let tol = m.chordal_tolerance_mm;
    let t = c.thickness_mm;
    let (len, wid, at) = developed(&l);
    let mg = p.flat_margin_mm;
    let k = 1.0 + c.shrinkage_percent / 100.0;
    // the cast sheet (nominal): the developed cover plus the margin, dome patterns from below
    let sheet_box = Solid::cuboid([-mg, -wid / 2.0 - mg, 0.0], [len + mg, wid / 2.0 + mg, t]);
    let dtan = m.draft_deg.to_radians().tan();
    let mut bosses = Vec::new();
    for (d, uv) in l.domes.iter().zip(&at) {
        let r_top = d.r_base - d.depth * dtan;
        bosses.push(Solid::cylinder([uv[0], uv[1], -0.5], [0.0, 0.0, 1.0], d.depth + 0.5, d.r_base + 0.5 * dtan, r_top, segments(d.r_base, tol)));
    }
    let bosses_all = Solid::union_all(&bosses).expect("a mold has at least one sensor");
    let sheet = sheet_box.difference(&bosses_all);
    sheet.ok(name)?;
    // the tray: the sheet grown by the shrinkage, open at the top, walls and floor of wall thickness
    let w = m.wall_thickness_mm;
    let pocket = sheet_box.scale_about(k, [0.0; 3]);
    let (plo, phi) = pocket.bbox();
    let depth = phi[2] + 1.0; // a rim 1 mm above the pour line, which is the sheet's top
    let tray = Solid::cuboid([plo[0] - w, plo[1] - w, -w], [phi[0] + w, phi[1] + w, depth])
        .difference(&Solid::cuboid([plo[0], plo[1], 0.0], [phi[0], phi[1], depth + 1.0]))
        .union(&bosses_all.scale_about(k, [0.0; 3]).intersection(&pocket));
    tray.ok(name)?;

    let (violations, dome_overlap, cast) = tray_checks(p, &l, &at, &sheet, &tray, &pocket);
    // what cutting the sheet out and bending it round the pad costs: outer-fibre strain
    let s = &l.shape;
    let r_min = s.pad_bend_radius();
    let strain = (t / 2.0) / (r_min + t / 2.0);
    let cut_volume = len * wid * t - l.domes.iter().map(|d| std::f64::consts::PI * d.r_base * d.r_base * d.depth).sum::<f64>();
    let mat = material(p, sheet.volume());
    let cover_name = p.cover_name();
    // printed floor down on the bed: the tray's frame is the sheet's lifted by the floor
    let tray = tray.translate([0.0, 0.0, w]);
    let tray_part = Part {
        name: format!("{name}-tray"),
        mesh: tray.to_mesh(),
        solid: tray,
        expected_genus: 0,
        density_g_cm3: m.density_g_cm3,
        process: crate::part::Process::Printed,
        supports: None,
        infill: 1.0,
        write_3mf: true,
        features: json!({"kind": "mold-tray", "mold": name, "min_wall_mm": m.min_wall_mm, "chordal_tolerance_mm": tol, "frame": "floor on the bed (z = 0); the cast sheet's frame lifted by the floor thickness", "sheet_to_tray_mm": [0.0, 0.0, w]}),
        extra: Default::default(),
    };
    let cover = Part {
        name: cover_name.clone(),
        mesh: sheet.to_mesh(),
        solid: sheet,
        expected_genus: 0,
        density_g_cm3: c.density_g_cm3,
        process: crate::part::Process::Cast,
        supports: None,
        infill: 1.0,
        write_3mf: false,
        features: json!({"kind": "cover-flat", "mold": name, "thickness_mm": t}),
        extra: Default::default(),
    };
    let mut entry = Map::new();
    entry.insert("style".into(), json!("flat"));
    entry.insert("fingertip".into(), json!(p.fingertip_file));
    entry.insert("pieces".into(), json!([tray_part.name]));
    entry.insert("cover".into(), json!(cover_name));
    entry.insert("material".into(), mat.clone());
    entry.insert(
        "developed_cover".into(),
        json!({
            "length_mm": len,
            "width_mm": wid,
            "dome_positions_uv_mm": at,
            "cut_out_volume_mm3": cut_volume,
            "bending_strain_outer_fibre": strain,
            "note": "the sheet must be cut to the developed outline and bent round the pad; the rounded tip is doubly curved and cannot be covered without darts or wrinkles",
        }),
    );
    entry.insert("checks".into(), json!({"dome_overlap_mm3": dome_overlap, "tray_cavity_volume_mm3": cast}));
    let mut manifest = Map::new();
    manifest.insert(name.to_string(), serde_json::Value::Object(entry));
    let mut lines = notes(name, &mat);
    lines.push(format!("{name}: the tray casts one sheet per pour: print as many trays as the batch casts covers"));
    lines.push(format!("{name}: flat sheet {:.1} × {:.1} mm (+{mg} mm margin to cut away); bending it round the pad strains its outer face by {:.0} %", len, wid, strain * 100.0));
    Ok(MoldBuild { parts: vec![tray_part, cover], assemblies: vec![], violations, manifest, notes: lines })
}

/// The flat mold's checks: each dome fits its pattern in the sheet, and the tray's cavity
/// (`pocket` less the `tray`) holds the sheet grown by the shrinkage. Returns the violations, each
/// dome's overlap with the sheet (mm³) and the cast volume (mm³).
fn tray_checks(p: &MoldParams, l: &Layout, at: &[[f64; 2]], sheet: &Solid, tray: &Solid, pocket: &Solid) -> (Vec<Violation>, Vec<f64>, f64) {
    let name = p.name.as_str();
    let tol = p.mold.chordal_tolerance_mm;
    let k = 1.0 + p.cover.shrinkage_percent / 100.0;
    let mut violations = Vec::new();
    let mut dome_overlap = Vec::new();
    for (i, (d, uv)) in l.domes.iter().zip(at).enumerate() {
        let dome = Solid::cylinder([uv[0], uv[1], 0.0], [0.0, 0.0, 1.0], d.depth, d.dome_r, d.dome_r, segments(d.dome_r, tol));
        let ov = dome.intersection(sheet).volume();
        dome_overlap.push(ov);
        if ov > 1e-6 {
            violations.push(Violation {
                part: name.to_string(),
                rule: "each sensor dome must fit its pattern with clearance ≥ 0",
                measured: format!("sensor[{i}]: overlap {ov:.5} mm³"),
            });
        }
    }
    let tray_cavity = tray.intersection(pocket).volume();
    let cast = pocket.volume() - tray_cavity;
    let k3 = k.powi(3);
    if ((cast / k3 - sheet.volume()) / sheet.volume()).abs() > 1e-6 {
        violations.push(Violation {
            part: name.to_string(),
            rule: "the tray's cavity volume must equal the sheet's (times the shrinkage allowance)",
            measured: format!("{cast:.3} / {k3:.5} vs {:.3} mm³", sheet.volume()),
        });
    }
    (violations, dome_overlap, cast)
}
