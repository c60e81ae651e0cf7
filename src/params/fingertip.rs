//! Fingertip parameters: raw TOML mirror and validated form.
//!
//! Frame (design frame): x runs from the mount face (x = 0) to the tip (x = length), y is lateral,
//! z points to the nail (dorsal) side; the pad is at negative z.

use super::{fields_of, Collector, Schema, SourceFile};
use crate::error::Result;
use serde::Deserialize;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawFingertip {
    pub kind: Option<String>,
    pub name: Option<String>,
    /// The sensor board file the seats are made for.
    pub sensor_board: Option<String>,
    pub body: Option<RawBody>,
    pub sensor: Option<Vec<RawSensor>>,
    pub mount: Option<RawMount>,
    pub print: Option<RawPrint>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBody {
    pub length_mm: Option<f64>,
    pub width_mm: Option<f64>,
    pub thickness_mm: Option<f64>,
    pub pad_longitudinal_radius_mm: Option<f64>,
    pub pad_transverse_radius_mm: Option<f64>,
    pub tip_radius_mm: Option<f64>,
    /// The anatomical form: the length of the rounded end and the cross-sections along the finger.
    pub tip_length_mm: Option<f64>,
    pub station: Option<Vec<RawStation>>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawStation {
    pub from_tip_mm: Option<f64>,
    pub width_mm: Option<f64>,
    pub pad_depth_mm: Option<f64>,
    pub nail_height_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawSensor {
    pub position_from_tip_mm: Option<f64>,
    pub lateral_offset_mm: Option<f64>,
    pub seat_clearance_mm: Option<f64>,
    pub flat_diameter_mm: Option<f64>,
    pub channel_clearance_mm: Option<f64>,
    pub channel_depth_mm: Option<f64>,
    pub channel_offset_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMount {
    pub socket_width_mm: Option<f64>,
    pub socket_height_mm: Option<f64>,
    pub socket_depth_mm: Option<f64>,
    pub socket_center_z_mm: Option<f64>,
    pub hole_diameter_mm: Option<f64>,
    pub holes: Option<Vec<[f64; 2]>>,
    pub head: Option<String>,
    pub head_diameter_mm: Option<f64>,
    pub head_depth_mm: Option<f64>,
    /// A named screw ("ISO 7045 M2") sets the hole and the head recess.
    pub screw: Option<String>,
    pub head_clearance_mm: Option<f64>,
    pub head_sink_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawPrint {
    pub density_g_cm3: Option<f64>,
    pub min_wall_mm: Option<f64>,
    pub chordal_tolerance_mm: Option<f64>,
}

pub static STATION_SCHEMA: Schema = Schema { fields: fields_of::<RawStation>, tables: &[] };
pub static BODY_SCHEMA: Schema = Schema { fields: fields_of::<RawBody>, tables: &[("station", true, &STATION_SCHEMA)] };
pub static SENSOR_SCHEMA: Schema = Schema { fields: fields_of::<RawSensor>, tables: &[] };
pub static MOUNT_SCHEMA: Schema = Schema { fields: fields_of::<RawMount>, tables: &[] };
pub static PRINT_SCHEMA: Schema = Schema { fields: fields_of::<RawPrint>, tables: &[] };
pub static SCHEMA: Schema = Schema {
    fields: fields_of::<RawFingertip>,
    tables: &[("body", false, &BODY_SCHEMA), ("sensor", true, &SENSOR_SCHEMA), ("mount", false, &MOUNT_SCHEMA), ("print", false, &PRINT_SCHEMA)],
};

/// Body shape: its length, its widest and thickest section, and its form.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    pub length_mm: f64,
    /// The widest section (the capsule's constant width; the widest station).
    pub width_mm: f64,
    /// The thickness, pad to nail (anatomical: the highest nail side over the deepest pad).
    pub thickness_mm: f64,
    pub form: Form,
}

/// How the body is shaped.
#[derive(Debug, Clone, PartialEq)]
pub enum Form {
    /// The side view of the pad is a straight run from the mount, an arc of
    /// `pad_longitudinal_radius`, then the tip arc; the cross-section is half an ellipse on each side
    /// of the mid-plane, so the pad's transverse radius sets the pad depth and the rest of the
    /// thickness is the (rounder) dorsal side.
    Capsule { pad_longitudinal_radius_mm: f64, pad_transverse_radius_mm: f64, tip_radius_mm: f64 },
    /// Anatomical: the body is lofted through cross-sections (stations) along the finger, each two
    /// half-ellipses (pad below the mid-plane, nail above) of the station's width, pad depth and nail
    /// height, interpolated between stations without overshoot; the last `tip_length_mm` closes in a
    /// quarter ellipse in every meridian.
    Stations { tip_length_mm: f64, stations: Vec<Station> },
}

/// One cross-section of the anatomical body, `from_tip_mm` along the finger from the tip (as the
/// seats are placed: a shorter finger loses length at the mount, not at its pulp).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Station {
    pub from_tip_mm: f64,
    pub width_mm: f64,
    pub pad_depth_mm: f64,
    pub nail_height_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    pub position_from_tip_mm: f64,
    pub lateral_offset_mm: f64,
    pub seat_diameter_mm: f64,
    pub seat_depth_mm: f64,
    pub flat_diameter_mm: f64,
    pub dome_diameter_mm: f64,
    pub dome_height_mm: f64,
    pub channel_width_mm: f64,
    pub channel_depth_mm: f64,
    pub channel_offset_mm: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Head {
    None,
    Counterbore,
    Countersink,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Mount {
    pub socket_width_mm: f64,
    pub socket_height_mm: f64,
    pub socket_depth_mm: f64,
    pub socket_center_z_mm: f64,
    pub hole_diameter_mm: f64,
    /// (x from the mount face, z height) of each cross hole; a cross hole runs along y through both
    /// side walls and the socket, with a head recess on each flank (one screw from each side).
    pub holes: Vec<[f64; 2]>,
    pub head: Head,
    pub head_diameter_mm: f64,
    pub head_depth_mm: f64,
    /// The screw the hole and recess were sized for, when the file names one.
    pub screw: Option<String>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Print {
    pub density_g_cm3: f64,
    pub min_wall_mm: f64,
    pub chordal_tolerance_mm: f64,
}

/// Validated fingertip parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct FingertipParams {
    pub name: String,
    pub body: Body,
    pub sensors: Vec<Sensor>,
    pub mount: Mount,
    pub print: Print,
}

/// The shortest rounded end (mm) the anatomical form takes (the capsule's tip radius: half of it).
pub const MIN_ROUNDING_MM: f64 = 2.0;

/// How far beyond the mount face a station may lie (mm): a shortened finger keeps its file's
/// stations, and a station there still shapes the body at the mount.
pub const MAX_BEYOND_MOUNT_MM: f64 = 10.0;

/// Allowed chordal tolerance range (mm).
pub const TOLERANCE_RANGE_MM: (f64, f64) = (0.001, 0.05);

pub fn print_params(c: &mut Collector, p: &RawPrint, min_wall_default: f64) -> Option<Print> {
    let density = c.or_within(p.density_g_cm3, 1.24, "print.density_g_cm3", 0.1, 25.0);
    let min_wall = c.or_within(p.min_wall_mm, min_wall_default, "print.min_wall_mm", 0.2, 10.0);
    let tol = c.or_within(p.chordal_tolerance_mm, 0.01, "print.chordal_tolerance_mm", TOLERANCE_RANGE_MM.0, TOLERANCE_RANGE_MM.1);
    Some(Print { density_g_cm3: density?, min_wall_mm: min_wall?, chordal_tolerance_mm: tol? })
}

impl FingertipParams {
    /// Parses and type-checks a fingertip file, collecting every problem. The geometric rules that
    /// need the body shape (seat on the pad, walls, hole clearances) live with the family and are
    /// applied by [`crate::fingertip::load`].
    pub fn from_source(src: &SourceFile, default_name: &str, dir: &std::path::Path) -> Result<FingertipParams> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&SCHEMA));
        if !c.problems.is_empty() {
            return super::finish(None, c.problems);
        }
        let mut problems = Vec::new();
        let body: Option<RawBody> = src.table("body", &mut problems);
        let sensors: Option<Vec<RawSensor>> = src.table("sensor", &mut problems);
        let mount: Option<RawMount> = src.table("mount", &mut problems);
        let print: Option<RawPrint> = src.table("print", &mut problems);
        let name = super::part_name(src, default_name, &mut problems);
        c.problems.extend(problems);
        let (Some(body), Some(sensors), Some(mount), Some(print), Some(name)) = (body, sensors, mount, print, name) else {
            return super::finish(None, c.problems);
        };
        let board = super::board::named(&mut c, src, dir)?;
        let v = validate_raw(&mut c, name, &body, &sensors, &mount, &print, board.as_ref());
        super::finish(v, c.problems)
    }
}

fn validate_raw(c: &mut Collector, name: String, b: &RawBody, sensors: &[RawSensor], m: &RawMount, p: &RawPrint, board: Option<&super::board::Board>) -> Option<FingertipParams> {
    let print = print_params(c, p, 1.2);
    let body = if b.station.is_some() || b.tip_length_mm.is_some() { stations_body(c, b) } else { capsule_body(c, b) };

    if sensors.is_empty() || sensors.len() > 2 {
        c.push("sensor", format!("{} sensor table(s)", sensors.len()), "a fingertip carries 1 or 2 sensors: write one or two `[[sensor]]` sections");
    }
    let mut out_sensors = Vec::new();
    for (i, s) in sensors.iter().enumerate() {
        let k = |f: &str| format!("sensor[{i}].{f}");
        let pos = c.positive(s.position_from_tip_mm, &k("position_from_tip_mm"), "9.0");
        let lat = c.req(Some(s.lateral_offset_mm.unwrap_or(0.0)), &k("lateral_offset_mm"), "0.0");
        // the pocket takes the board with a clearance, as deep as the board is thick; the dome is
        // the board's; the tail channel is the tail with a clearance
        let seat_clear = c.or_within(s.seat_clearance_mm, 0.2, &k("seat_clearance_mm"), 0.0, 2.0);
        let ch_clear = c.or_within(s.channel_clearance_mm, 0.1, &k("channel_clearance_mm"), 0.0, 2.0);
        let seat_d = match (board, seat_clear) {
            (Some(b), Some(cl)) => Some(b.board_diameter_mm + 2.0 * cl),
            _ => None,
        };
        let seat_depth = board.map(|b| b.board_thickness_mm);
        let flat_d = c.positive(s.flat_diameter_mm, &k("flat_diameter_mm"), "10.0");
        let dome_d = board.map(|b| b.dome_diameter_mm);
        let dome_h = board.map(|b| b.dome_height_mm);
        let ch_w = match (board, ch_clear) {
            (Some(b), Some(cl)) => Some(b.tail_width_mm + 2.0 * cl),
            _ => None,
        };
        let ch_d = c.positive(s.channel_depth_mm, &k("channel_depth_mm"), "0.5");
        let ch_off = c.req(Some(s.channel_offset_mm.unwrap_or(lat.unwrap_or(0.0))), &k("channel_offset_mm"), "0.0");
        if let (Some(sd), Some(fd)) = (seat_d, flat_d) {
            if fd < sd {
                c.push(&k("flat_diameter_mm"), fd, format!("the flat region must be at least the seat diameter {sd} mm (the board's diameter + 2 × seat_clearance_mm)"));
            }
        }
        if let (Some(sd), Some(dd)) = (seat_d, dome_d) {
            if dd > sd {
                c.push("sensor_board", dd, format!("the board's dome must fit in the seat ({sd} mm)"));
            }
        }
        if let (Some(sd), Some(w)) = (seat_d, ch_w) {
            if w > sd {
                c.push(&k("channel_clearance_mm"), w, format!("the tail channel ({w} mm: the board's tail + 2 × this) must be narrower than the seat ({sd} mm)"));
            }
        }
        if let (Some(pos), Some(lat), Some(sd), Some(dp), Some(fd), Some(dd), Some(dh), Some(w), Some(d), Some(o)) =
            (pos, lat, seat_d, seat_depth, flat_d, dome_d, dome_h, ch_w, ch_d, ch_off)
        {
            out_sensors.push(Sensor {
                position_from_tip_mm: pos,
                lateral_offset_mm: lat,
                seat_diameter_mm: sd,
                seat_depth_mm: dp,
                flat_diameter_mm: fd,
                dome_diameter_mm: dd,
                dome_height_mm: dh,
                channel_width_mm: w,
                channel_depth_mm: d,
                channel_offset_mm: o,
            });
        }
    }

    let sw = c.positive(m.socket_width_mm, "mount.socket_width_mm", "10.0");
    let sh = c.positive(m.socket_height_mm, "mount.socket_height_mm", "5.0");
    let sdp = c.positive(m.socket_depth_mm, "mount.socket_depth_mm", "8.0");
    let sz = c.req(Some(m.socket_center_z_mm.unwrap_or(0.0)), "mount.socket_center_z_mm", "1.0");
    let holes = m.holes.clone().unwrap_or_default();
    for (i, h) in holes.iter().enumerate() {
        if !h[0].is_finite() || !h[1].is_finite() || h[0].abs() > super::raw::MAX_LENGTH_MM || h[1].abs() > super::raw::MAX_LENGTH_MM {
            c.push(&format!("mount.holes[{i}]"), format!("{h:?}"), "hole positions must be finite [x_mm, y_mm] pairs");
        }
    }
    let (hd, head, hdia, hdepth) = match &m.screw {
        Some(name) => screw_recess(c, m, name),
        None => explicit_recess(c, m),
    };
    if let (Some(hd), Some(hdia), Some(h)) = (hd, hdia, head) {
        if h != Head::None && hdia <= hd {
            c.push("mount.head_diameter_mm", hdia, format!("the screw head recess must be wider than the hole ({hd} mm)"));
        }
    }
    let mount = match (sw, sh, sdp, sz, hd, head, hdia, hdepth) {
        (Some(sw), Some(sh), Some(sdp), Some(sz), Some(hd), Some(head), Some(hdia), Some(hdepth)) => Some(Mount {
            socket_width_mm: sw,
            socket_height_mm: sh,
            socket_depth_mm: sdp,
            socket_center_z_mm: sz,
            hole_diameter_mm: hd,
            holes,
            head,
            head_diameter_mm: hdia,
            head_depth_mm: hdepth,
            screw: m.screw.clone(),
        }),
        _ => None,
    };
    if out_sensors.len() != sensors.len() || sensors.is_empty() || sensors.len() > 2 {
        return None;
    }
    Some(FingertipParams { name, body: body?, sensors: out_sensors, mount: mount?, print: print? })
}

/// The capsule form (no `[[body.station]]`).
fn capsule_body(c: &mut Collector, b: &RawBody) -> Option<Body> {
    let length = c.positive(b.length_mm, "body.length_mm", "28.0");
    let width = c.positive(b.width_mm, "body.width_mm", "16.0");
    let thickness = c.positive(b.thickness_mm, "body.thickness_mm", "14.0");
    let r_long = c.positive(b.pad_longitudinal_radius_mm, "body.pad_longitudinal_radius_mm", "40.0");
    let r_trans = c.positive(b.pad_transverse_radius_mm, "body.pad_transverse_radius_mm", "12.0");
    let r_tip = c.at_least_mm(b.tip_radius_mm, "body.tip_radius_mm", MIN_ROUNDING_MM / 2.0, "too sharp a tip to round and to cast over", "4.5");
    let (Some(l), Some(w), Some(t), Some(rl), Some(rt), Some(rtip)) = (length, width, thickness, r_long, r_trans, r_tip) else { return None };
    let before = c.problems.len();
    let pad_depth = (w / 2.0).powi(2) / rt;
    if pad_depth >= t * 0.5 {
        c.push(
            "body.pad_transverse_radius_mm",
            rt,
            format!(
                "gives a pad depth of {pad_depth:.2} mm, at least half the thickness {t} mm, so the pad would not be flatter than the dorsal side; use more than {:.2} mm",
                (w / 2.0).powi(2) / (t * 0.5)
            ),
        );
    }
    if t - pad_depth > 10.0 * pad_depth {
        c.push(
            "body.thickness_mm",
            t,
            format!(
                "more than 11 times the pad depth {pad_depth:.2} mm: the dorsal side would be a needle; use at most {:.1} or a smaller pad_transverse_radius_mm",
                11.0 * pad_depth
            ),
        );
    }
    if rtip >= pad_depth {
        c.push("body.tip_radius_mm", rtip, format!("must be smaller than the pad depth {pad_depth:.2} mm ((width/2)² / pad_transverse_radius)"));
    }
    if rl <= pad_depth {
        c.push("body.pad_longitudinal_radius_mm", rl, format!("must be larger than the pad depth {pad_depth:.2} mm"));
    }
    if c.problems.len() == before {
        let straight = l - rtip - ((rl - rtip).powi(2) - (rl - pad_depth).powi(2)).sqrt();
        if straight < 0.0 {
            c.push(
                "body.length_mm",
                l,
                format!("too short for the pad arcs: the side profile needs {:.2} mm; lengthen the body or reduce pad_longitudinal_radius_mm", l - straight),
            );
        }
    }
    (c.problems.len() == before).then_some(Body {
        length_mm: l,
        width_mm: w,
        thickness_mm: t,
        form: Form::Capsule { pad_longitudinal_radius_mm: rl, pad_transverse_radius_mm: rt, tip_radius_mm: rtip },
    })
}

/// The anatomical form: `tip_length_mm` and two to eight `[[body.station]]` sections.
fn stations_body(c: &mut Collector, b: &RawBody) -> Option<Body> {
    let before = c.problems.len();
    for (path, given) in [
        ("body.width_mm", b.width_mm),
        ("body.thickness_mm", b.thickness_mm),
        ("body.pad_longitudinal_radius_mm", b.pad_longitudinal_radius_mm),
        ("body.pad_transverse_radius_mm", b.pad_transverse_radius_mm),
        ("body.tip_radius_mm", b.tip_radius_mm),
    ] {
        if let Some(v) = given {
            c.push(
                path,
                v,
                "remove it: with `[[body.station]]` sections the stations give the widths, depths and curvatures (or remove the stations and tip_length_mm for the capsule form)",
            );
        }
    }
    let length = c.positive(b.length_mm, "body.length_mm", "28.0");
    // a rounded end shorter than this is a corner: its curvature radius (length² / half-width)
    // would drive the tessellation of offsets and molds into millions of triangles
    let tip = c.at_least_mm(b.tip_length_mm, "body.tip_length_mm", MIN_ROUNDING_MM, "too sharp a tip to round and to cast over", "7.0");
    let raw = b.station.clone().unwrap_or_default();
    if !(2..=8).contains(&raw.len()) {
        c.push(
            "body.station",
            format!("{} station(s)", raw.len()),
            "the anatomical body needs 2 to 8 `[[body.station]]` sections (3–5 describe a finger: at the mount, the pulp and before the tip)",
        );
    }
    let mut stations = Vec::new();
    let mut index = Vec::new();
    for (i, r) in raw.iter().enumerate() {
        let k = |f: &str| format!("body.station[{i}].{f}");
        let at = c.positive(r.from_tip_mm, &k("from_tip_mm"), "10.0");
        let w = c.positive(r.width_mm, &k("width_mm"), "16.0");
        let pd = c.positive(r.pad_depth_mm, &k("pad_depth_mm"), "6.0");
        let nh = c.positive(r.nail_height_mm, &k("nail_height_mm"), "7.0");
        if let (Some(at), Some(w), Some(pd), Some(nh)) = (at, w, pd, nh) {
            stations.push(Station { from_tip_mm: at, width_mm: w, pad_depth_mm: pd, nail_height_mm: nh });
            index.push(i);
        }
    }
    let (Some(l), Some(tip)) = (length, tip) else { return None };
    if tip >= l * 0.6 {
        c.push("body.tip_length_mm", tip, format!("the rounded end must take less than 60 % of the body ({l} mm): use at most {:.1}", 0.6 * l));
    }
    // each station named by its place in the file (a station that failed above is not here)
    let whole = stations.len() == raw.len();
    for (n, s) in stations.iter().enumerate() {
        let i = index[n];
        let k = |f: &str| format!("body.station[{i}].{f}");
        if s.from_tip_mm > l + MAX_BEYOND_MOUNT_MM {
            c.push(
                &k("from_tip_mm"),
                s.from_tip_mm,
                format!(
                    "more than {MAX_BEYOND_MOUNT_MM} mm beyond the mount face (body length {l} mm): a station there does not shape the body; use at most {}",
                    l + MAX_BEYOND_MOUNT_MM
                ),
            );
        }
        if s.from_tip_mm < tip - 1e-9 {
            c.push(&k("from_tip_mm"), s.from_tip_mm, format!("stations lie before the rounded end: at least tip_length_mm ({tip} mm) from the tip"));
        }
        if whole && n > 0 && s.from_tip_mm >= stations[n - 1].from_tip_mm {
            c.push(
                &k("from_tip_mm"),
                s.from_tip_mm,
                format!("list the stations from the mount face toward the tip: must be less than the previous station's {} mm", stations[n - 1].from_tip_mm),
            );
        }
        if s.width_mm / 2.0 < s.pad_depth_mm.max(s.nail_height_mm) / 4.0 || s.width_mm / 2.0 > 4.0 * s.pad_depth_mm.min(s.nail_height_mm) {
            c.push(&k("width_mm"), s.width_mm, "a section's half-width must lie within 1/4 and 4 times its pad depth and nail height: the section would be a blade");
        }
    }
    if whole && stations.first().is_some_and(|s| s.from_tip_mm < 0.5 * l) {
        c.push(
            "body.station[0].from_tip_mm",
            stations[0].from_tip_mm,
            format!("the first station should describe the mount end: at least half the body's length ({:.1} mm) from the tip", 0.5 * l),
        );
    }
    if c.problems.len() != before || stations.len() != raw.len() || !(2..=8).contains(&stations.len()) {
        return None;
    }
    // the body's envelope over its length (a station beyond the mount face, on a shortened finger,
    // shapes the body there but is not itself part of it): the widest section, the highest nail
    // side over the deepest pad
    let (width, pad, nail) = envelope(&stations, l, tip);
    let thickness = pad + nail;
    Some(Body { length_mm: l, width_mm: width, thickness_mm: thickness, form: Form::Stations { tip_length_mm: tip, stations } })
}

/// The widest section, the deepest pad and the highest nail side of the stations' interpolation
/// over the body (mount face to the start of the rounded end; the end only narrows).
pub fn envelope(stations: &[Station], length_mm: f64, tip_length_mm: f64) -> (f64, f64, f64) {
    let at: Vec<f64> = stations.iter().map(|s| length_mm - s.from_tip_mm).collect();
    let curve = |f: fn(&Station) -> f64| crate::interp::Monotone::new(&at, &stations.iter().map(f).collect::<Vec<_>>());
    let (w, p, n) = (curve(|s| s.width_mm), curve(|s| s.pad_depth_mm), curve(|s| s.nail_height_mm));
    let x_cap = length_mm - tip_length_mm;
    // the values at the stations inside the body and at the ends (monotone pieces: the extremes
    // of each lie at its ends)
    let xs: Vec<f64> = at.iter().copied().filter(|x| (0.0..=x_cap).contains(x)).chain([0.0, x_cap]).collect();
    let max = |c: &crate::interp::Monotone| xs.iter().map(|&x| c.at(x)).fold(0.0, f64::max);
    (max(&w), max(&p), max(&n))
}

type Recess = (Option<f64>, Option<Head>, Option<f64>, Option<f64>);

/// Hole and recess from a named screw: the ISO 273 medium clearance hole; a counterbore of the
/// head's largest diameter plus the clearance, as deep as the head's largest height plus the sink,
/// or a countersink for a countersunk head.
fn screw_recess(c: &mut Collector, m: &RawMount, name: &str) -> Recess {
    let screw = match super::screws::lookup(name) {
        Ok(s) => Some(s),
        Err(msg) => {
            c.push("mount.screw", format!("{name:?}"), msg);
            None
        }
    };
    let set = |v: Option<f64>| v.map(|x| x.to_string());
    for (path, given) in [
        ("mount.hole_diameter_mm", set(m.hole_diameter_mm)),
        ("mount.head", m.head.as_ref().map(|h| format!("{h:?}"))),
        ("mount.head_diameter_mm", set(m.head_diameter_mm)),
        ("mount.head_depth_mm", set(m.head_depth_mm)),
    ] {
        if let Some(v) = given {
            c.push(path, v, format!("remove it: `mount.screw = {name:?}` sets the hole and the head recess (or remove `screw` to size them by hand)"));
        }
    }
    let clearance = c.or_within(m.head_clearance_mm, 0.3, "mount.head_clearance_mm", 0.0, 2.0);
    let sink = c.or_within(m.head_sink_mm, 0.2, "mount.head_sink_mm", 0.0, 5.0);
    let (Some(s), Some(clearance), Some(sink)) = (screw, clearance, sink) else { return (None, None, None, None) };
    let dia = s.head_diameter_mm + 2.0 * clearance;
    match s.head {
        super::screws::HeadKind::Cylindrical => (Some(s.clearance_hole_mm), Some(Head::Counterbore), Some(dia), Some(s.head_height_mm + sink)),
        super::screws::HeadKind::Countersunk => (Some(s.clearance_hole_mm), Some(Head::Countersink), Some(dia), Some(sink)),
    }
}

/// Hole and recess sized by hand (no `screw`).
fn explicit_recess(c: &mut Collector, m: &RawMount) -> Recess {
    for (path, given) in [("mount.head_clearance_mm", m.head_clearance_mm), ("mount.head_sink_mm", m.head_sink_mm)] {
        if let Some(v) = given {
            c.push(path, v, "only used with `mount.screw`: name the screw (e.g. screw = \"ISO 7045 M2\") or size the recess with head_diameter_mm and head_depth_mm");
        }
    }
    let hd = c.at_least_mm(m.hole_diameter_mm, "mount.hole_diameter_mm", super::raw::MIN_HOLE_MM, "the smallest hole a 0.4 mm nozzle prints open", "2.4");
    let head = match m.head.as_deref().unwrap_or("counterbore") {
        "none" => Some(Head::None),
        "counterbore" => Some(Head::Counterbore),
        "countersink" => Some(Head::Countersink),
        other => {
            c.push("mount.head", format!("{other:?}"), "use \"counterbore\", \"countersink\" or \"none\" (or name the screw: screw = \"ISO 7045 M2\")");
            None
        }
    };
    let (hdia, hdepth) = match head {
        Some(Head::None) | None => (Some(0.0), Some(0.0)),
        Some(_) => (
            c.positive(m.head_diameter_mm, "mount.head_diameter_mm", "4.0"),
            if head == Some(Head::Countersink) { Some(m.head_depth_mm.unwrap_or(0.0)) } else { c.positive(m.head_depth_mm, "mount.head_depth_mm", "2.0") },
        ),
    };
    (hd, head, hdia, hdepth)
}
