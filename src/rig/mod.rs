//! Calibration rig part family: base (sensor seat, tail slot, guide sleeve) and plunger (frustum
//! whose small face is the sensing area, stem, weight plate with an engraved centring scale), with
//! the assembly checks the paper's method depends on.

use crate::checks::Violation;
use crate::error::Result;
use crate::mesh::{segments, Mesh, Solid};
use crate::params::rig::RigParams;
use crate::part::{Assembly, AssemblyObject, Part};
use serde_json::{json, Map, Value};

pub const GRAVITY_M_S2: f64 = 9.80665;

/// Heights of the assembled rig (z up, base bottom at 0), derived once.
#[derive(Debug, Clone)]
pub struct Layout {
    pub base_top: f64,
    pub seat_floor: f64,
    pub dome_top: f64,
    pub frustum_top: f64,
    pub plate_bottom: f64,
    pub plate_top: f64,
    pub sleeve_top: f64,
    pub bore_r: f64,
}

pub use crate::params::rig::whole_layers;

pub fn layout(p: &RigParams) -> Layout {
    let base_top = p.base.height_mm;
    let seat_floor = base_top - whole_layers(p.sensor.board_thickness_mm, p.layer_height_mm);
    // the board lies on the seat's floor; its dome stands on it
    let dome_top = seat_floor + p.sensor.board_thickness_mm + p.sensor.dome_height_mm;
    let frustum_top = dome_top + p.plunger.frustum_height_mm;
    let plate_bottom = frustum_top + p.plunger.stem_length_mm;
    Layout {
        base_top,
        seat_floor,
        dome_top,
        frustum_top,
        plate_bottom,
        plate_top: plate_bottom + p.plunger.plate_thickness_mm,
        sleeve_top: plate_bottom - p.plunger.stop_gap_mm,
        bore_r: p.plunger.stem_diameter_mm / 2.0 + p.plunger.clearance_mm,
    }
}

const UP: [f64; 3] = [0.0, 0.0, 1.0];

fn base_solid(p: &RigParams, l: &Layout) -> Solid {
    let tol = p.print.chordal_tolerance_mm;
    let w = p.base.width_mm;
    let block = Solid::cuboid([-w / 2.0, -w / 2.0, 0.0], [w / 2.0, w / 2.0, l.base_top]);
    let r_out = l.bore_r + p.base.sleeve_wall_mm;
    let tube = Solid::cylinder([0.0, 0.0, l.base_top - 0.5], UP, l.sleeve_top - l.base_top + 0.5, r_out, r_out, segments(r_out, tol)).difference(&Solid::cylinder(
        [0.0, 0.0, l.base_top],
        UP,
        l.sleeve_top - l.base_top + 1.0,
        l.bore_r,
        l.bore_r,
        segments(l.bore_r, tol),
    ));
    let body = block.union(&tube);
    let r_seat = p.sensor.disc_diameter_mm / 2.0 + p.base.seat_clearance_mm;
    let recess = Solid::cylinder([0.0, 0.0, l.seat_floor], UP, p.sensor.board_thickness_mm + 1.0, r_seat, r_seat, segments(r_seat, tol));
    let half = p.sensor.tail_width_mm / 2.0 + p.base.tail_slot_clearance_mm;
    let slot_depth = whole_layers(p.sensor.board_thickness_mm + p.base.tail_slot_clearance_mm, p.layer_height_mm);
    let slot = Solid::cuboid([0.0, -half, l.base_top - slot_depth], [w / 2.0 + 1.0, half, l.base_top]);
    // where the slot runs under the guide sleeve, a 45° gable roof: the sleeve prints over it
    // without a bridge or support
    let roof = Solid::hull(&[
        [0.0, -half, l.base_top - 0.01],
        [0.0, half, l.base_top - 0.01],
        [0.0, 0.0, l.base_top + half],
        [w / 2.0 + 1.0, -half, l.base_top - 0.01],
        [w / 2.0 + 1.0, half, l.base_top - 0.01],
        [w / 2.0 + 1.0, 0.0, l.base_top + half],
    ]);
    let cut = Solid::union_all(&[recess, slot, roof]).expect("three cutters");
    body.difference(&cut)
}

/// The plunger in its assembled pose.
fn plunger_solid(p: &RigParams, l: &Layout) -> Solid {
    let tol = p.print.chordal_tolerance_mm;
    let q = &p.plunger;
    let (rf, rt, rs, rp) = (q.face_diameter_mm / 2.0, q.frustum_top_diameter_mm / 2.0, q.stem_diameter_mm / 2.0, q.plate_diameter_mm / 2.0);
    let n = segments(rt.max(rs), tol);
    let frustum = Solid::cylinder([0.0, 0.0, l.dome_top], UP, q.frustum_height_mm, rf, rt, n);
    let stem = Solid::cylinder([0.0, 0.0, l.frustum_top - 0.01], UP, q.stem_length_mm + 0.02, rs, rs, segments(rs, tol));
    let plate = Solid::cylinder([0.0, 0.0, l.plate_bottom], UP, q.plate_thickness_mm, rp, rp, segments(rp, tol));
    let body = Solid::union_all(&[frustum, stem, plate]).expect("parts");
    // centring scale: concentric rings and a cross engraved in the top face
    let z = l.plate_top - q.scale_depth_mm;
    let h = q.scale_depth_mm + 1.0;
    let mut cuts = Vec::new();
    let mut k = 1.0;
    while k * q.scale_pitch_mm + q.scale_line_width_mm / 2.0 < rp - 2.0 {
        let (ro, ri) = (k * q.scale_pitch_mm + q.scale_line_width_mm / 2.0, k * q.scale_pitch_mm - q.scale_line_width_mm / 2.0);
        let ring = Solid::cylinder([0.0, 0.0, z], UP, h, ro, ro, segments(ro, tol)).difference(&Solid::cylinder([0.0, 0.0, z - 0.5], UP, h + 1.0, ri, ri, segments(ri, tol)));
        cuts.push(ring);
        k += 1.0;
    }
    let arm = rp - 2.0;
    let lw = q.scale_line_width_mm / 2.0;
    cuts.push(Solid::cuboid([-arm, -lw, z], [arm, lw, z + h]));
    cuts.push(Solid::cuboid([-lw, -arm, z], [lw, arm, z + h]));
    body.difference(&Solid::union_all(&cuts).expect("scale"))
}

/// Plunger print pose: plate face down on the bed. Maps assembled → print: (x, −y, plate_top − z).
fn plunger_to_print(s: &Solid, l: &Layout) -> Solid {
    s.place([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, l.plate_top])
}

/// A stand-in for the sensor (board disc and dome) for the assembly view.
fn sensor_dummy(p: &RigParams, l: &Layout) -> Mesh {
    let tol = p.print.chordal_tolerance_mm.max(0.02);
    let rd = p.sensor.disc_diameter_mm / 2.0;
    let rdome = p.sensor.dome_diameter_mm / 2.0;
    let disc = Solid::cylinder([0.0, 0.0, l.seat_floor], UP, p.sensor.board_thickness_mm, rd, rd, segments(rd, tol));
    let board_top = l.seat_floor + p.sensor.board_thickness_mm;
    let dome = Solid::cylinder([0.0, 0.0, board_top - 0.01], UP, p.sensor.dome_height_mm + 0.01, rdome, rdome * 0.8, segments(rdome, tol));
    disc.union(&dome).to_mesh()
}

fn polygon_centroid_area(cs_polys: &[Vec<[f64; 2]>]) -> ([f64; 2], f64) {
    let (mut a, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for poly in cs_polys {
        for i in 0..poly.len() {
            let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
            let c = p[0] * q[1] - q[0] * p[1];
            a += c / 2.0;
            cx += (p[0] + q[0]) * c / 6.0;
            cy += (p[1] + q[1]) * c / 6.0;
        }
    }
    ([cx / a, cy / a], a)
}

/// The assembly checks: no intersection, sliding clearance along the travel, the face resting on
/// the dome on the seat's axis with the nominal area, the stop gap, the scale concentric.
pub fn assembly_checks(p: &RigParams, base: &Solid, plunger: &Solid, l: &Layout) -> Vec<Violation> {
    let mut v = Vec::new();
    let mut bad = |rule: &'static str, measured: String| v.push(Violation { part: format!("{}-assembly", p.name), rule, measured });
    let inter = base.intersection(plunger).volume();
    if inter > 1e-6 {
        bad("assembled parts must not intersect", format!("{inter:.6} mm³ shared"));
    }
    let slider = plunger.trim([0.0, 0.0, -1.0], -(l.plate_bottom - 1e-3));
    let want = p.plunger.clearance_mm - 0.02;
    let mut worst = f64::INFINITY;
    let steps = 8;
    for k in 0..=steps {
        // from lifted off the dome by its height down to the overtravel stop
        let dz = -p.sensor.dome_height_mm + (p.sensor.dome_height_mm + p.plunger.stop_gap_mm) * k as f64 / steps as f64;
        let g = slider.translate([0.0, 0.0, -dz]).min_gap(base, 2.0 * p.plunger.clearance_mm + 1.0);
        worst = worst.min(g);
    }
    if worst < want {
        bad("sliding clearance must hold along the whole travel", format!("minimum gap {worst:.4} mm, need ≥ {want:.3} mm"));
    }
    let stop = plunger.translate([0.0, 0.0, -p.plunger.stop_gap_mm]);
    let stop_inter = base.intersection(&stop).volume();
    let rest_gap = plunger.min_gap(base, p.plunger.stop_gap_mm + 1.0);
    if stop_inter > 1e-6 || (rest_gap - p.plunger.stop_gap_mm.min(p.plunger.clearance_mm)).abs() > 0.02 {
        bad("the overtravel stop must engage after stop_gap_mm", format!("rest gap {rest_gap:.4} mm, overlap at the stop {stop_inter:.6} mm³"));
    }
    let face_z = plunger.0.bounding_box().min.z;
    if (face_z - l.dome_top).abs() > 0.05 {
        bad("the frustum face must rest on the dome's top plane", format!("gap {:.4} mm", face_z - l.dome_top));
    }
    let cs = plunger.0.slice(l.dome_top + 1e-4);
    let polys: Vec<Vec<[f64; 2]>> = cs.to_polygons().iter().map(|pl| pl.iter().map(|q| [q.x, q.y]).collect()).collect();
    let (c, area) = polygon_centroid_area(&polys);
    let nominal = std::f64::consts::PI * (p.plunger.face_diameter_mm / 2.0).powi(2);
    if (area / nominal - 1.0).abs() > 1e-3 {
        bad("the frustum's small face must have the sensing area within 0.1 %", format!("{area:.4} mm² vs {nominal:.4} mm²"));
    }
    if (c[0] * c[0] + c[1] * c[1]).sqrt() > 0.01 {
        bad("the frustum axis must be on the seat axis within 0.01 mm", format!("offset {:.4} mm", (c[0] * c[0] + c[1] * c[1]).sqrt()));
    }
    let zs = l.plate_top - p.plunger.scale_depth_mm / 2.0;
    let polys: Vec<Vec<[f64; 2]>> = plunger.0.slice(zs).to_polygons().iter().map(|pl| pl.iter().map(|q| [q.x, q.y]).collect()).collect();
    let (cr, _) = polygon_centroid_area(&polys);
    if (cr[0] * cr[0] + cr[1] * cr[1]).sqrt() > 0.01 {
        bad("the centring scale must be concentric with the frustum", format!("offset {:.4} mm", (cr[0] * cr[0] + cr[1] * cr[1]).sqrt()));
    }
    v
}

pub struct Built {
    pub parts: Vec<Part>,
    pub assemblies: Vec<Assembly>,
    pub violations: Vec<Violation>,
    pub manifest: Map<String, Value>,
}

/// The plunger alone in its print pose (what the peer benchmark compares).
pub fn plunger_print(p: &RigParams) -> Solid {
    let l = layout(p);
    plunger_to_print(&plunger_solid(p, &l), &l)
}

pub fn build(p: &RigParams) -> Result<Built> {
    let l = layout(p);
    let base = base_solid(p, &l);
    base.ok(&format!("{}-base", p.name))?;
    let plunger = plunger_solid(p, &l);
    plunger.ok(&format!("{}-plunger", p.name))?;
    let violations = assembly_checks(p, &base, &plunger, &l);
    let plunger_print = plunger_to_print(&plunger, &l);
    let r_seat = p.sensor.disc_diameter_mm / 2.0 + p.base.seat_clearance_mm;
    let mut extra = Map::new();
    let vol = plunger.volume();
    let preload_g = vol / 1000.0 * p.print.density_g_cm3 * p.infill;
    extra.insert("preload_g".into(), json!((preload_g * 1e4).round() / 1e4));
    extra.insert("preload_n".into(), json!((preload_g / 1000.0 * GRAVITY_M_S2 * 1e6).round() / 1e6));
    let base_part = Part {
        name: format!("{}-base", p.name),
        mesh: base.to_mesh(),
        solid: base.clone(),
        expected_genus: 1,
        density_g_cm3: p.print.density_g_cm3,
        process: crate::part::Process::Printed,
        supports: None,
        infill: p.infill,
        write_3mf: true,
        features: json!({
            "kind": "rig-base",
            "frame": "print pose = assembled pose: base bottom on the bed, seat axis on x = y = 0",
            "seat_axis": [0.0, 0.0],
            "seat_diameter_mm": 2.0 * r_seat,
            "seat_floor_z_mm": l.seat_floor,
            "seat_depth_mm": ((l.base_top - l.seat_floor) * 1e6).round() / 1e6,
            "layer_height_mm": p.layer_height_mm,
            "guide_bore_diameter_mm": 2.0 * l.bore_r,
            "min_wall_mm": p.print.min_wall_mm,
            "chordal_tolerance_mm": p.print.chordal_tolerance_mm,
            "holes": [{"tunnel": "tail slot under the guide sleeve"}],
        }),
        extra: Map::new(),
    };
    let plunger_part = Part {
        name: format!("{}-plunger", p.name),
        mesh: plunger_print.to_mesh(),
        solid: plunger_print,
        expected_genus: 0,
        density_g_cm3: p.print.density_g_cm3,
        process: crate::part::Process::Printed,
        supports: None,
        infill: p.infill,
        write_3mf: true,
        features: json!({
            "kind": "rig-plunger",
            "frame": "print pose: weight plate face down on the bed; assembled = (x, -y, plate_top - z)",
            "face_diameter_mm": p.plunger.face_diameter_mm,
            "min_wall_mm": p.print.min_wall_mm,
            "chordal_tolerance_mm": p.print.chordal_tolerance_mm,
            "holes": [],
        }),
        extra,
    };
    let assembly = Assembly {
        name: format!("{}-assembly", p.name),
        parts: vec![
            AssemblyObject::part(base_part.name.clone(), base_part.mesh.clone()),
            // assembled pose = print pose turned over: shown, not printed from this file
            AssemblyObject::reference(format!("{} (reference, assembled pose)", plunger_part.name), plunger.to_mesh()),
            AssemblyObject::reference("sensor (reference)", sensor_dummy(p, &l)),
        ],
    };
    let mut manifest = Map::new();
    manifest.insert(
        p.name.clone(),
        json!({
            "base": base_part.name,
            "plunger": plunger_part.name,
            "assembly": format!("{}.3mf", assembly.name),
            "plunger_print_to_assembled": {"x": [1, 0, 0, 0], "y": [0, -1, 0, 0], "z": [0, 0, -1, l.plate_top]},
            "dome_top_z_mm": l.dome_top,
            "board_thickness_mm": p.sensor.board_thickness_mm,
            "base_top_z_mm": l.base_top,
            "layer_height_mm": p.layer_height_mm,
            "dome_height_mm": p.sensor.dome_height_mm,
            "clearance_mm": p.plunger.clearance_mm,
            "stop_gap_mm": p.plunger.stop_gap_mm,
            "top_load_n": p.plunger.top_load_n,
            "dome_compression_at_top_load_mm": p.plunger.dome_compression_mm,
            "plate_top_z_mm": l.plate_top,
            "plate_bottom_z_mm": l.plate_bottom,
            "density_g_cm3": p.print.density_g_cm3,
            "infill": p.infill,
            "scale_depth_mm": p.plunger.scale_depth_mm,
            "face_diameter_mm": p.plunger.face_diameter_mm,
            "preload_g": (preload_g * 1e4).round() / 1e4,
            "preload_n": (preload_g / 1000.0 * GRAVITY_M_S2 * 1e6).round() / 1e6,
        }),
    );
    Ok(Built { parts: vec![base_part, plunger_part], assemblies: vec![assembly], violations, manifest })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{rig::RigParams, SourceFile};

    fn params() -> RigParams {
        let text = std::fs::read_to_string("params/rig.toml").unwrap();
        RigParams::from_source(&SourceFile::parse("rig.toml", text).unwrap(), "rig", std::path::Path::new("params")).unwrap()
    }

    #[test]
    fn default_rig_passes_assembly_checks_and_reports_preload() {
        let p = params();
        let b = build(&p).unwrap();
        assert!(b.violations.is_empty(), "{:?}", b.violations);
        let plunger = &b.parts[1];
        let expected = plunger.volume_mm3() / 1000.0 * 1.24;
        assert!((plunger.extra["preload_g"].as_f64().unwrap() - expected).abs() < 1e-3);
        assert!((plunger.extra["preload_n"].as_f64().unwrap() - expected / 1000.0 * GRAVITY_M_S2).abs() < 1e-5);
        for part in &b.parts {
            assert!(crate::checks::run(part).is_empty());
        }
    }

    #[test]
    fn assembly_checks_catch_an_offset_or_sunk_plunger() {
        let p = params();
        let l = layout(&p);
        let base = base_solid(&p, &l);
        let plunger = plunger_solid(&p, &l);
        let shifted = plunger.translate([0.2, 0.0, 0.0]);
        let v = assembly_checks(&p, &base, &shifted, &l);
        assert!(v.iter().any(|x| x.rule.contains("axis")), "{v:?}");
        assert!(v.iter().any(|x| x.rule.contains("clearance")), "{v:?}");
        let lifted = plunger.translate([0.0, 0.0, 0.2]);
        let v = assembly_checks(&p, &base, &lifted, &l);
        assert!(v.iter().any(|x| x.rule.contains("rest on the dome")), "{v:?}");
    }

    /// Issue 18, item 4: the seat recess and the tail slot are whole layers deep, never shallower
    /// than the board (it must not stand proud), and the dome rests where the board does.
    #[test]
    fn recesses_are_whole_layers_and_the_board_never_stands_proud() {
        for layer in [0.2, 0.15, 0.1, 0.3] {
            let mut p = params();
            p.layer_height_mm = layer;
            let l = layout(&p);
            let depth = l.base_top - l.seat_floor;
            let n = depth / layer;
            assert!((n - n.round()).abs() < 1e-9, "layer {layer}: depth {depth}");
            assert!(depth >= p.sensor.board_thickness_mm - 1e-9 && depth < p.sensor.board_thickness_mm + layer, "layer {layer}: depth {depth}");
            assert!((l.dome_top - (l.seat_floor + p.sensor.board_thickness_mm + p.sensor.dome_height_mm)).abs() < 1e-12);
            // the slot, measured on the built base: a probe at the slot's floor plus half a layer
            // is in the cut, half a layer lower is in the solid
            let base = base_solid(&p, &l);
            let slot_floor = l.base_top - whole_layers(p.sensor.board_thickness_mm + p.base.tail_slot_clearance_mm, layer);
            let sd = (l.base_top - slot_floor) / layer;
            assert!((sd - sd.round()).abs() < 1e-9);
            let probe = |z: f64| base.contains([p.base.width_mm / 2.0 - 1.0, 0.0, z], 100.0);
            assert!(!probe(slot_floor + layer / 2.0) && probe(slot_floor - layer / 2.0), "layer {layer}: slot floor {slot_floor}");
        }
        // at 0.2 mm the 0.3 mm board gets a 0.4 mm recess
        let p = params();
        let l = layout(&p);
        assert!((l.base_top - l.seat_floor - 0.4).abs() < 1e-9);
    }

    #[test]
    fn small_face_has_the_sensing_area() {
        let p = params();
        let l = layout(&p);
        let plunger = plunger_solid(&p, &l);
        let area = plunger.slice_area(l.dome_top + 1e-6);
        let nominal = std::f64::consts::PI * 16.0;
        assert!((area / nominal - 1.0).abs() < 1e-4, "{area}");
    }
}
