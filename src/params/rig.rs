//! Calibration rig parameters (paper section 2.1): a base with the sensor seat and a sliding
//! guide sleeve, and a plunger whose frustum's small face is the 8 mm sensing area, topped by a
//! flat plate for stacked weights with an engraved centring scale.
//!
//! Frame: z up, the sensor's axis on z = 0 axis, base bottom at z = 0.

use super::fingertip::{print_params, Print, RawPrint};
use super::{fields_of, Collector, Schema, SourceFile};
use crate::error::Result;
use serde::Deserialize;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBase {
    pub width_mm: Option<f64>,
    pub height_mm: Option<f64>,
    pub seat_clearance_mm: Option<f64>,
    pub tail_slot_clearance_mm: Option<f64>,
    pub sleeve_wall_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlunger {
    pub face_diameter_mm: Option<f64>,
    pub frustum_top_diameter_mm: Option<f64>,
    pub frustum_height_mm: Option<f64>,
    pub stem_diameter_mm: Option<f64>,
    pub stem_length_mm: Option<f64>,
    pub plate_diameter_mm: Option<f64>,
    pub plate_thickness_mm: Option<f64>,
    pub weight_diameter_mm: Option<f64>,
    pub clearance_mm: Option<f64>,
    pub stop_gap_mm: Option<f64>,
    pub max_load_g: Option<f64>,
    pub stop_margin_mm: Option<f64>,
    pub max_tilt_deg: Option<f64>,
    pub scale_pitch_mm: Option<f64>,
    pub scale_line_width_mm: Option<f64>,
    pub scale_depth_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawRigPrint {
    pub density_g_cm3: Option<f64>,
    pub infill: Option<f64>,
    pub min_wall_mm: Option<f64>,
    pub chordal_tolerance_mm: Option<f64>,
    pub layer_height_mm: Option<f64>,
}

static BASE_SCHEMA: Schema = Schema { fields: fields_of::<RawBase>, tables: &[] };
static PLUNGER_SCHEMA: Schema = Schema { fields: fields_of::<RawPlunger>, tables: &[] };
static RIG_PRINT_SCHEMA: Schema = Schema { fields: fields_of::<RawRigPrint>, tables: &[] };
pub static SCHEMA: Schema =
    Schema { fields: || &["kind", "name", "sensor_board"], tables: &[("base", false, &BASE_SCHEMA), ("plunger", false, &PLUNGER_SCHEMA), ("print", false, &RIG_PRINT_SCHEMA)] };

#[derive(Debug, Clone, PartialEq)]
pub struct RigSensor {
    pub disc_diameter_mm: f64,
    pub board_thickness_mm: f64,
    pub dome_diameter_mm: f64,
    pub dome_height_mm: f64,
    pub tail_width_mm: f64,
    pub tail_length_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Base {
    pub width_mm: f64,
    pub height_mm: f64,
    pub seat_clearance_mm: f64,
    pub tail_slot_clearance_mm: f64,
    pub sleeve_wall_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Plunger {
    pub face_diameter_mm: f64,
    pub frustum_top_diameter_mm: f64,
    pub frustum_height_mm: f64,
    pub stem_diameter_mm: f64,
    pub stem_length_mm: f64,
    pub plate_diameter_mm: f64,
    pub plate_thickness_mm: f64,
    pub weight_diameter_mm: f64,
    pub clearance_mm: f64,
    /// The overtravel stop: the plate lands on the sleeve after this much travel past rest.
    pub stop_gap_mm: f64,
    /// The heaviest stack of weights the rig is for, and the force it puts on the dome with the
    /// plunger's own weight (an upper bound: the plunger's solid volume without its engraving).
    pub max_load_g: f64,
    pub top_load_n: f64,
    /// How far the dome compresses under the top load, at its stiffness.
    pub dome_compression_mm: f64,
    pub max_tilt_deg: f64,
    pub scale_pitch_mm: f64,
    pub scale_line_width_mm: f64,
    pub scale_depth_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct RigParams {
    pub name: String,
    pub sensor: RigSensor,
    pub base: Base,
    pub plunger: Plunger,
    pub print: Print,
    pub infill: f64,
    /// The printer's layer height: the seat recess and the tail slot are whole layers deep.
    pub layer_height_mm: f64,
}

/// `depth` rounded up to whole layers of `layer` (a recess never shallower than asked: the board
/// never stands proud of the base).
pub fn whole_layers(depth: f64, layer: f64) -> f64 {
    ((depth / layer - 1e-6).ceil() * layer * 1e9).round() / 1e9
}

/// Smallest sliding clearance an FDM printer holds reliably (mm).
pub const MIN_CLEARANCE_MM: f64 = 0.15;

impl RigParams {
    /// Parses and type-checks a rig file and the sensor board file it names (relative to `dir`).
    pub fn from_source(src: &SourceFile, default_name: &str, dir: &std::path::Path) -> Result<RigParams> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&SCHEMA));
        if !c.problems.is_empty() {
            return super::finish(None, c.problems);
        }
        let mut problems = Vec::new();
        let b: Option<RawBase> = src.table("base", &mut problems);
        let p: Option<RawPlunger> = src.table("plunger", &mut problems);
        let pr: Option<RawRigPrint> = src.table("print", &mut problems);
        c.problems.extend(problems);
        let board = super::board::named(&mut c, src, dir)?;
        let (Some(b), Some(p), Some(pr)) = (b, p, pr) else {
            return super::finish(None, c.problems);
        };
        let Some(name) = super::part_name(src, default_name, &mut c.problems) else {
            return super::finish(None, c.problems);
        };
        let Some(s) = board else {
            return super::finish(None, c.problems);
        };
        let v = validate(&mut c, name, &s, &b, &p, &pr);
        super::finish(v, c.problems)
    }
}

/// Standard gravity (m/s²): grams of weight to newtons.
const GRAVITY_M_S2: f64 = 9.80665;

/// The rig's fields (base, plunger, print), each read and range-checked on its own: None where
/// missing or refused.
struct Fields {
    bw: Option<f64>,
    bh: Option<f64>,
    seat_c: Option<f64>,
    slot_c: Option<f64>,
    sleeve_wall: Option<f64>,
    face: Option<f64>,
    ftop: Option<f64>,
    fh: Option<f64>,
    stem_d: Option<f64>,
    stem_l: Option<f64>,
    plate_d: Option<f64>,
    plate_t: Option<f64>,
    weight_d: Option<f64>,
    clear: Option<f64>,
    tilt: Option<f64>,
    pitch: Option<f64>,
    line_w: Option<f64>,
    sdepth: Option<f64>,
    print: Option<Print>,
    infill: Option<f64>,
    layer: Option<f64>,
}

/// Checks a rig file's fields one by one, then their relations (every problem goes into `c`, each
/// with its path); the parameters when every field could be read.
fn validate(c: &mut Collector, name: String, s: &super::board::Board, b: &RawBase, p: &RawPlunger, pr: &RawRigPrint) -> Option<RigParams> {
    let f = read_fields(c, s, b, p, pr);
    whole_layer_rule(c, &f);
    let max_load = c.or_within(p.max_load_g, 1000.0, "plunger.max_load_g", 0.0, 1.0e5);
    let margin = c.or_within(p.stop_margin_mm, 0.2, "plunger.stop_margin_mm", 0.0, 10.0);
    // the stop must not carry load: the plate lands on the sleeve only after the dome has taken the
    // top load (weights plus the plunger itself)
    let top = top_load(&f, max_load, s.dome_stiffness_n_per_mm);
    let stop = stop_gap(c, p.stop_gap_mm, top, margin);

    // cross-field rules: every problem is reported, each with its path
    plunger_rules(c, s, &f, stop, p.stop_gap_mm.is_some());
    base_rules(c, s, &f);
    scale_rules(c, &f);
    Some(RigParams {
        name,
        // the sensor is the board file's
        sensor: RigSensor {
            disc_diameter_mm: s.board_diameter_mm,
            board_thickness_mm: s.board_thickness_mm,
            dome_diameter_mm: s.dome_diameter_mm,
            dome_height_mm: s.dome_height_mm,
            tail_width_mm: s.tail_width_mm,
            tail_length_mm: s.tail_length_mm,
        },
        base: Base { width_mm: f.bw?, height_mm: f.bh?, seat_clearance_mm: f.seat_c?, tail_slot_clearance_mm: f.slot_c?, sleeve_wall_mm: f.sleeve_wall? },
        plunger: Plunger {
            face_diameter_mm: f.face?,
            frustum_top_diameter_mm: f.ftop?,
            frustum_height_mm: f.fh?,
            stem_diameter_mm: f.stem_d?,
            stem_length_mm: f.stem_l?,
            plate_diameter_mm: f.plate_d?,
            plate_thickness_mm: f.plate_t?,
            weight_diameter_mm: f.weight_d?,
            clearance_mm: f.clear?,
            stop_gap_mm: stop?,
            max_load_g: max_load?,
            top_load_n: top?.0,
            dome_compression_mm: top?.1,
            max_tilt_deg: f.tilt?,
            scale_pitch_mm: f.pitch?,
            scale_line_width_mm: f.line_w?,
            scale_depth_mm: f.sdepth?,
        },
        print: f.print?,
        infill: f.infill?,
        layer_height_mm: f.layer?,
    })
}

/// Field stage: reads the base, plunger and print fields one by one, each with its own range.
fn read_fields(c: &mut Collector, s: &super::board::Board, b: &RawBase, p: &RawPlunger, pr: &RawRigPrint) -> Fields {
    let bw = c.positive(b.width_mm, "base.width_mm", "50.0");
    let bh = c.positive(b.height_mm, "base.height_mm", "8.0");
    let seat_c = c.or_within(b.seat_clearance_mm, 0.2, "base.seat_clearance_mm", 0.0, 2.0);
    let slot_c = c.or_within(b.tail_slot_clearance_mm, 0.3, "base.tail_slot_clearance_mm", 0.0, 3.0);
    let sleeve_wall = c.positive(b.sleeve_wall_mm, "base.sleeve_wall_mm", "3.0");
    // the frustum's small face is the sensing area unless the file says otherwise
    let face = c.positive(Some(p.face_diameter_mm.unwrap_or(s.sensing_diameter_mm)), "plunger.face_diameter_mm", "8.0");
    let ftop = c.positive(p.frustum_top_diameter_mm, "plunger.frustum_top_diameter_mm", "14.0");
    let fh = c.positive(p.frustum_height_mm, "plunger.frustum_height_mm", "6.0");
    let stem_d = c.positive(p.stem_diameter_mm, "plunger.stem_diameter_mm", "16.0");
    let stem_l = c.positive(p.stem_length_mm, "plunger.stem_length_mm", "24.0");
    let plate_d = c.positive(p.plate_diameter_mm, "plunger.plate_diameter_mm", "60.0");
    let plate_t = c.positive(p.plate_thickness_mm, "plunger.plate_thickness_mm", "4.0");
    let weight_d = c.positive(p.weight_diameter_mm, "plunger.weight_diameter_mm", "40.0");
    let clear = c.req(Some(p.clearance_mm.unwrap_or(0.3)), "plunger.clearance_mm", "0.3");
    let tilt = c.or_within(p.max_tilt_deg, 2.0, "plunger.max_tilt_deg", 0.05, 10.0);
    let pitch = c.positive(p.scale_pitch_mm, "plunger.scale_pitch_mm", "5.0");
    let line_w = c.positive(p.scale_line_width_mm, "plunger.scale_line_width_mm", "0.6");
    let sdepth = c.positive(p.scale_depth_mm, "plunger.scale_depth_mm", "0.4");
    let print = print_params(c, &RawPrint { density_g_cm3: pr.density_g_cm3, min_wall_mm: pr.min_wall_mm, chordal_tolerance_mm: pr.chordal_tolerance_mm }, 1.2);
    let infill = c.or_within(pr.infill, 1.0, "print.infill", 0.05, 1.0);
    let layer = c.or_within(pr.layer_height_mm, 0.2, "print.layer_height_mm", 0.04, 0.6);
    Fields { bw, bh, seat_c, slot_c, sleeve_wall, face, ftop, fh, stem_d, stem_l, plate_d, plate_t, weight_d, clear, tilt, pitch, line_w, sdepth, print, infill, layer }
}

/// Layer stage: heights that set a recess or an engraving print as whole layers, or the slicer
/// rounds them.
fn whole_layer_rule(c: &mut Collector, f: &Fields) {
    let (bh, sdepth, layer) = (f.bh, f.sdepth, f.layer);
    if let Some(lh) = layer {
        for (path, v) in [("base.height_mm", bh), ("plunger.scale_depth_mm", sdepth)] {
            if let Some(v) = v {
                let n = v / lh;
                if (n - n.round()).abs() > 1e-6 {
                    let (lo, hi) = ((n.floor() * lh * 1e6).round() / 1e6, (n.ceil() * lh * 1e6).round() / 1e6);
                    c.push(
                        path,
                        v,
                        format!(
                            "is not a whole number of {lh} mm layers (print.layer_height_mm), so it would print as {lo} or {hi} mm: use {}{hi}",
                            if lo > 0.0 { format!("{lo} or ") } else { String::new() }
                        ),
                    );
                }
            }
        }
    }
}

/// The top load (N) on the dome, weights plus the plunger itself (an upper bound: its solid volume
/// at the print's density and infill), and the dome's compression under it (mm) at stiffness `k`.
fn top_load(f: &Fields, max_load: Option<f64>, k: f64) -> Option<(f64, f64)> {
    match (f.face, f.ftop, f.fh, f.stem_d, f.stem_l, f.plate_d, f.plate_t, &f.print, f.infill, max_load) {
        (Some(rf), Some(rt), Some(h), Some(sd), Some(sl), Some(pd), Some(pt), Some(pr), Some(inf), Some(ml)) => {
            let (rf, rt) = (rf / 2.0, rt / 2.0);
            let pi = std::f64::consts::PI;
            let vol = pi * h / 3.0 * (rf * rf + rf * rt + rt * rt) + pi * (sd / 2.0).powi(2) * sl + pi * (pd / 2.0).powi(2) * pt;
            let plunger_g = vol / 1000.0 * pr.density_g_cm3 * inf;
            let n = (ml + plunger_g) / 1000.0 * GRAVITY_M_S2;
            Some((n, n / k))
        }
        _ => None,
    }
}

/// Stop stage: the overtravel stop gap, as given (and then no less than the dome's compression
/// under the top load) or computed from that compression plus `margin`.
fn stop_gap(c: &mut Collector, given: Option<f64>, top: Option<(f64, f64)>, margin: Option<f64>) -> Option<f64> {
    match (given, top, margin) {
        (Some(st), Some((n, comp)), _) => {
            let st = c.positive(Some(st), "plunger.stop_gap_mm", "0.7");
            if let Some(st) = st {
                if st < comp {
                    c.push(
                        "plunger.stop_gap_mm",
                        st,
                        format!("the plate would land on the sleeve before the top load ({n:.2} N) is on the dome, which it compresses {comp:.3} mm: the stop would carry part of the load; use at least {comp:.2} mm, or leave stop_gap_mm out to have it computed with stop_margin_mm"),
                    );
                }
            }
            st
        }
        (Some(st), None, _) => c.positive(Some(st), "plunger.stop_gap_mm", "0.7"),
        (None, Some((_, comp)), Some(m)) => Some(comp + m),
        (None, _, _) => None,
    }
}

/// Plunger rules: the frustum presses the sensing area only, fits the guide and widens upward;
/// the plunger slides, carries the weights, clears the seat, stops before the dome is flattened
/// and is held vertical (`stop_given`: the file gave the stop gap).
fn plunger_rules(c: &mut Collector, s: &super::board::Board, f: &Fields, stop: Option<f64>, stop_given: bool) {
    let (disc, dome_d, dome_h) = (Some(s.board_diameter_mm), Some(s.dome_diameter_mm), Some(s.dome_height_mm));
    let (face, ftop, stem_d, stem_l, plate_d, weight_d, clear, tilt, seat_c) = (f.face, f.ftop, f.stem_d, f.stem_l, f.plate_d, f.weight_d, f.clear, f.tilt, f.seat_c);
    if let (Some(f), Some(d)) = (face, dome_d) {
        if f > d + 1e-9 {
            c.push("plunger.face_diameter_mm", f, format!("the frustum face must not be larger than the dome ({d} mm): its force would bypass the sensing area"));
        }
    }
    if let (Some(d), Some(disc)) = (dome_d, disc) {
        if d > disc {
            c.push("sensor_board", d, format!("the board's dome must fit on its disc ({disc} mm)"));
        }
    }
    if let (Some(f), Some(t)) = (face, ftop) {
        if t < f {
            c.push("plunger.frustum_top_diameter_mm", t, format!("the frustum must widen upward from its {f} mm face"));
        }
    }
    if let (Some(t), Some(sd)) = (ftop, stem_d) {
        if t > sd {
            c.push("plunger.frustum_top_diameter_mm", t, format!("must not exceed the stem diameter {sd} mm (the frustum slides inside the guide)"));
        }
    }
    if let Some(cl) = clear {
        if cl < MIN_CLEARANCE_MM {
            c.push("plunger.clearance_mm", cl, format!("a sliding clearance below {MIN_CLEARANCE_MM} mm does not print reliably: the plunger would stick"));
        }
    }
    if let (Some(pd), Some(wd)) = (plate_d, weight_d) {
        if pd < wd {
            c.push("plunger.plate_diameter_mm", pd, format!("the plate must carry the weights: at least their footprint {wd} mm"));
        }
    }
    if let (Some(sd), Some(cl), Some(disc), Some(sc)) = (stem_d, clear, disc, seat_c) {
        if sd + 2.0 * cl < disc + 2.0 * sc {
            c.push(
                "plunger.stem_diameter_mm",
                sd,
                format!("the guide bore ({:.2} mm) must clear the sensor seat ({:.2} mm) so the sensor can be placed", sd + 2.0 * cl, disc + 2.0 * sc),
            );
        }
    }
    if let (Some(st), Some(dh)) = (stop, dome_h) {
        if st >= dh {
            let why = if stop_given {
                String::new()
            } else {
                " (computed: the dome's compression under plunger.max_load_g plus stop_margin_mm; the dome is too soft for this load)".to_string()
            };
            c.push("plunger.stop_gap_mm", st, format!("the overtravel stop must engage before the dome is flattened: less than the dome height {dh} mm{why}"));
        }
    }
    if let (Some(sl), Some(st), Some(cl), Some(t), Some(sd)) = (stem_l, stop, clear, tilt, stem_d) {
        let engage = sl - st;
        let worst = (2.0 * cl / engage.max(1e-9)).atan().to_degrees();
        if engage <= 0.0 || worst > t {
            c.push(
                "plunger.stem_length_mm",
                sl,
                format!("the guide cannot hold the plunger vertical: {:.1} mm of engagement with {cl} mm clearance allows {worst:.2}° of tilt (max {t}°); lengthen the stem to ≥ {:.1} mm", engage, 2.0 * cl / t.to_radians().tan() + st),
            );
        }
        let _ = sd;
    }
}

/// Base rules: the base reaches beyond the guide sleeve, the sleeve and the floor under the seat
/// keep the minimum wall, and the board's tail reaches the base's edge.
fn base_rules(c: &mut Collector, s: &super::board::Board, f: &Fields) {
    let (disc, board, tail_l) = (Some(s.board_diameter_mm), Some(s.board_thickness_mm), Some(s.tail_length_mm));
    let (bw, bh, stem_d, clear, sleeve_wall, slot_c, layer, print) = (f.bw, f.bh, f.stem_d, f.clear, f.sleeve_wall, f.slot_c, f.layer, &f.print);
    if let (Some(bw), Some(sd), Some(cl), Some(wall)) = (bw, stem_d, clear, sleeve_wall) {
        if bw < sd + 2.0 * cl + 2.0 * wall + 10.0 {
            c.push("base.width_mm", bw, format!("the base must extend at least 5 mm beyond the guide sleeve ({:.1} mm across)", sd + 2.0 * cl + 2.0 * wall));
        }
    }
    if let (Some(wall), Some(pr)) = (sleeve_wall, print) {
        if wall < pr.min_wall_mm {
            c.push("base.sleeve_wall_mm", wall, format!("thinner than the minimum wall {} mm", pr.min_wall_mm));
        }
    }
    if let (Some(bh), Some(board), Some(pr), Some(sc), Some(lh)) = (bh, board, print, slot_c, layer) {
        // the tail slot is the deepest cut: board + its clearance, in whole layers
        if bh - whole_layers(board + sc, lh) < pr.min_wall_mm {
            c.push("base.height_mm", bh, format!("leaves less than the minimum wall {} mm under the seat and the tail slot", pr.min_wall_mm));
        }
    }
    if let (Some(tl), Some(bw), Some(disc)) = (tail_l, bw, disc) {
        if tl < bw / 2.0 - disc / 2.0 {
            c.push(
                "sensor_board",
                tl,
                format!("the board's tail ({tl} mm) does not reach the base edge ({:.1} mm from the seat): make the base narrower (base.width_mm)", bw / 2.0 - disc / 2.0),
            );
        }
    }
}

/// Scale rules: the centring scale's lines are narrower than their pitch, and its engraving no
/// deeper than half the plate.
fn scale_rules(c: &mut Collector, f: &Fields) {
    if let (Some(pitch), Some(lw), Some(sd), Some(pt)) = (f.pitch, f.line_w, f.sdepth, f.plate_t) {
        if lw >= pitch {
            c.push("plunger.scale_line_width_mm", lw, format!("scale lines must be narrower than their pitch {pitch} mm"));
        }
        if sd > pt / 2.0 {
            c.push("plunger.scale_depth_mm", sd, format!("engraving deeper than half the plate ({pt} mm) weakens it"));
        }
    }
}
