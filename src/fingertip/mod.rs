//! Fingertip part family: `load` reads a file's parameters and applies `validate`, the rules that
//! need the body shape; `build` makes the part (body from exact surfaces, every feature cut in one
//! boolean).

pub mod section_plot;
pub mod shape;

use crate::error::{Error, Result};
use crate::mesh::{self, add, frame, scale, segments, sub, Solid, P3};
use crate::params::fingertip::{FingertipParams, Head, Sensor};
use crate::part::Part;
use serde_json::json;
pub use shape::Shape;

/// Steepest dorsal slope (degrees) a head recess may break out on: its downhill lip is a wedge of
/// 90° minus that slope.
pub const MAX_RECESS_SLOPE_DEG: f64 = 30.0;

/// A tail channel that opens into another seat's pocket overlaps the pocket's rim by at least this
/// (mm), so that no sliver of wall is left between them.
pub const OPEN_INTO_POCKET_MM: f64 = 0.2;

/// Where a seat ends up: the flat plane and the pocket, in the design frame.
#[derive(Debug, Clone)]
pub struct Seat {
    /// Point of the pad surface over the seat centre.
    pub surface: P3,
    /// Outward normal of the seat plane.
    pub normal: P3,
    /// How far the flat plane lies below the pad surface at the centre.
    pub flat_depth: f64,
    /// Centre of the flat plane.
    pub flat_center: P3,
    /// Centre of the pocket floor.
    pub floor_center: P3,
}

/// Locates the flat seat of a sensor, or says why it does not fit on the pad.
pub fn seat(shape: &Shape, s: &Sensor) -> std::result::Result<Seat, String> {
    let x = shape.length - s.position_from_tip_mm;
    let y = s.lateral_offset_mm;
    if x <= 0.0 {
        return Err(format!("puts the seat centre beyond the mount face (body length {} mm)", shape.length));
    }
    let (Some(z), Some(n)) = (shape.z_pad(x, y), shape.pad_normal(x, y)) else {
        return Err(format!("puts the seat centre off the body (half-width there {:.2} mm)", shape.half_width(x)));
    };
    let p0 = [x, y, z];
    let (u, v, _) = frame(n);
    let rf = s.flat_diameter_mm / 2.0;
    let mut h: f64 = 0.0;
    let reach = 2.0 * (shape.pad_depth + shape.dorsal_height);
    for i in 0..96 {
        let phi = 2.0 * std::f64::consts::PI * i as f64 / 96.0;
        let q = add(p0, add(scale(u, rf * phi.cos()), scale(v, rf * phi.sin())));
        // march inward until inside the body
        let mut d = 0.0;
        while d < reach && !shape.inside(sub(q, scale(n, d))) {
            d += 0.005;
        }
        if d >= reach {
            return Err(format!("leaves the flat region ({} mm across) partly off the body", s.flat_diameter_mm));
        }
        let hit = sub(q, scale(n, d));
        if hit[2] >= -0.05 * shape.pad_depth {
            return Err(format!("lets the flat region ({} mm across) reach the dorsal half: move it toward the pad centre or make it smaller", s.flat_diameter_mm));
        }
        if hit[0] <= 0.0 {
            return Err("lets the flat region run past the mount face".into());
        }
        h = h.max(d);
    }
    let flat_center = sub(p0, scale(n, h));
    let floor_center = sub(p0, scale(n, h + s.seat_depth_mm));
    Ok(Seat { surface: p0, normal: n, flat_depth: h, flat_center, floor_center })
}

/// Plan-view path (x, y) of a sensor's tail channel: from the seat centre, a 45° run to the
/// channel's lateral offset when it differs from the seat's, then straight past the mount face.
pub fn channel_path(shape: &Shape, s: &Sensor) -> Vec<[f64; 2]> {
    let (xs, ys, yc) = (shape.length - s.position_from_tip_mm, s.lateral_offset_mm, s.channel_offset_mm);
    let mut path = vec![[xs, ys]];
    let dy = (yc - ys).abs();
    if dy > 1e-9 {
        path.push([xs - dy, yc]);
    }
    path.push([-1.0, yc]);
    path
}

/// Points along a polyline every `step` (always including the vertices).
fn along(path: &[[f64; 2]], step: f64) -> Vec<([f64; 2], [f64; 2])> {
    let mut out = Vec::new();
    for w in path.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let t = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        let n = (len / step).ceil().max(1.0) as usize;
        for k in 0..=n {
            let f = k as f64 / n as f64;
            out.push(([a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f], t));
        }
    }
    out
}

/// The other sensors whose tail channel opens into sensor `j`'s pocket (the crossing rule lets a
/// channel cut into a pocket's rim); the mesh checks measure such a pocket without a closed loop.
fn channels_opening_into(shape: &Shape, p: &FingertipParams, j: usize) -> Vec<usize> {
    let sj = &p.sensors[j];
    (0..p.sensors.len()).filter(|&i| i != j && channel_to_seat(shape, &p.sensors[i], sj) < sj.seat_diameter_mm / 2.0 + p.sensors[i].channel_width_mm / 2.0).collect()
}

/// Plan-view distance from sensor `si`'s tail channel's centre line to sensor `sj`'s seat centre.
fn channel_to_seat(shape: &Shape, si: &Sensor, sj: &Sensor) -> f64 {
    path_distance(&channel_path(shape, si), [shape.length - sj.position_from_tip_mm, sj.lateral_offset_mm])
}

/// Distance from a point to a polyline.
pub fn path_distance(path: &[[f64; 2]], p: [f64; 2]) -> f64 {
    path.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let l2 = d[0] * d[0] + d[1] * d[1];
            let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0);
            ((p[0] - a[0] - t * d[0]).powi(2) + (p[1] - a[1] - t * d[1]).powi(2)).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Floor point of the channel at plan point (x, y): the pad surface raised by the channel depth.
fn floor_point(shape: &Shape, s: &Sensor, x: f64, y: f64) -> Option<P3> {
    Some([x, y, shape.z_pad(x.max(1e-9), y)? + s.channel_depth_mm])
}

fn point_box_distance(p: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> f64 {
    let dy = (lo[0] - p[0]).max(p[0] - hi[0]).max(0.0);
    let dz = (lo[1] - p[1]).max(p[1] - hi[1]).max(0.0);
    let d = (dy * dy + dz * dz).sqrt();
    if d > 0.0 {
        d
    } else {
        -((p[0] - lo[0]).min(hi[0] - p[0]).min(p[1] - lo[1]).min(hi[1] - p[1]))
    }
}

fn point_box3_distance(p: P3, lo: P3, hi: P3) -> f64 {
    let d: Vec<f64> = (0..3).map(|k| (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0)).collect();
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Socket box in the design frame.
fn socket_box(p: &FingertipParams) -> (P3, P3) {
    let m = &p.mount;
    (
        [-1.0, -m.socket_width_mm / 2.0, m.socket_center_z_mm - m.socket_height_mm / 2.0],
        [m.socket_depth_mm, m.socket_width_mm / 2.0, m.socket_center_z_mm + m.socket_height_mm / 2.0],
    )
}

/// |y| of the head recess floor of a cross hole at (x, z).
fn head_floor(shape: &Shape, p: &FingertipParams, x: f64, z: f64) -> Option<f64> {
    let side = shape.flank_y(x, z)?;
    let m = &p.mount;
    Some(match m.head {
        Head::None => side,
        Head::Counterbore => side - m.head_depth_mm,
        Head::Countersink => side - (m.head_diameter_mm - m.hole_diameter_mm) / 2.0 - m.head_depth_mm,
    })
}

/// Slope (degrees) of the flank, against the plane square to a cross hole, around the recess rim.
fn rim_slope_deg(shape: &Shape, x: f64, z: f64, rh: f64) -> Option<f64> {
    let mut worst: f64 = 0.0;
    for k in 0..16 {
        let a = 2.0 * std::f64::consts::PI * k as f64 / 16.0;
        let (px, pz) = (x + rh * a.cos(), z + rh * a.sin());
        let e = 0.01;
        let dz = (shape.flank_y(px, pz + e)? - shape.flank_y(px, pz - e)?) / (2.0 * e);
        let dx = (shape.flank_y(px + e, pz)? - shape.flank_y((px - e).max(0.0), pz)?) / (2.0 * e);
        worst = worst.max((dz * dz + dx * dx).sqrt().atan().to_degrees());
    }
    Some(worst)
}

/// A problem a rule found: (path, value, message).
type Problem = (String, String, String);

/// Rules that need the body shape. Returns (path, value, message) for each problem.
pub fn validate(p: &FingertipParams) -> Vec<(String, String, String)> {
    let mut out: Vec<Problem> = Vec::new();
    let shape = Shape::new(&p.body);
    socket_wall_rules(p, &shape, &mut out);
    let mut seats = Vec::new();
    for (i, s) in p.sensors.iter().enumerate() {
        let st = seat_rules(p, &shape, i, s, &mut out);
        let located = st.is_some();
        seats.push(st);
        if located {
            channel_rules(p, &shape, i, s, &mut out);
        }
    }
    sensor_pair_rules(p, &shape, &seats, &mut out);
    cross_hole_rules(p, &shape, &seats, &mut out);
    out
}

/// Socket stage: the socket leaves the minimum wall (plus the tail channels' depth) all round.
fn socket_wall_rules(p: &FingertipParams, shape: &Shape, out: &mut Vec<Problem>) {
    let wall = p.print.min_wall_mm;
    let (sb_lo, sb_hi) = socket_box(p);
    let m = &p.mount;
    let mut push = |path: String, value: String, msg: String| out.push((path, value, msg));
    let max_channel_depth = p.sensors.iter().map(|s| s.channel_depth_mm).fold(0.0, f64::max);
    let socket_rect = ([sb_lo[1], sb_lo[2]], [sb_hi[1], sb_hi[2]]);
    if m.socket_depth_mm + wall >= shape.length {
        push(
            "mount.socket_depth_mm".into(),
            m.socket_depth_mm.to_string(),
            format!("leaves less than the minimum wall {wall} mm before the tip; use less than {:.2}", shape.length - wall),
        );
    } else {
        for (x, need) in [(0.0, wall + max_channel_depth), (m.socket_depth_mm, wall + max_channel_depth), (m.socket_depth_mm + wall, 0.0)] {
            let worst = shape.outline(x, 720).iter().map(|q| point_box_distance(*q, socket_rect.0, socket_rect.1)).fold(f64::INFINITY, f64::min);
            let inside = shape.inside([x.max(1e-6), m.socket_center_z_mm * 0.0, m.socket_center_z_mm]);
            if worst < need || !inside {
                push(
                    "mount.socket_width_mm".into(),
                    format!("{} x {} mm at z {}", m.socket_width_mm, m.socket_height_mm, m.socket_center_z_mm),
                    format!("the socket leaves a wall of {worst:.2} mm at x = {x:.1} mm; at least {need:.2} mm is needed (minimum wall plus tail channel depth): make the socket smaller or move socket_center_z_mm"),
                );
                break;
            }
        }
    }
}

/// Seat stage for sensor `i`: its flat seat is located on the pad, and the pocket floor keeps the
/// minimum wall to the socket and the far side. None when the seat cannot be located.
fn seat_rules(p: &FingertipParams, shape: &Shape, i: usize, s: &Sensor, out: &mut Vec<Problem>) -> Option<Seat> {
    let wall = p.print.min_wall_mm;
    let (sb_lo, sb_hi) = socket_box(p);
    let mut push = |path: String, value: String, msg: String| out.push((path, value, msg));
    let k = |f: &str| format!("sensor[{i}].{f}");
    match seat(shape, s) {
        Err(why) => {
            push(k("position_from_tip_mm"), format!("{} (lateral {})", s.position_from_tip_mm, s.lateral_offset_mm), format!("{why}; the seat must be a flat region of the pad"));
            None
        }
        Ok(st) => {
            // wall under the pocket floor: to the far side of the body and to the socket
            let (u, v, _) = frame(st.normal);
            let rs = s.seat_diameter_mm / 2.0;
            let mut thinnest = f64::INFINITY;
            for j in 0..=24 {
                let q = if j == 24 {
                    st.floor_center
                } else {
                    let a = 2.0 * std::f64::consts::PI * j as f64 / 24.0;
                    add(st.floor_center, add(scale(u, rs * a.cos()), scale(v, rs * a.sin())))
                };
                if !shape.inside(q) {
                    thinnest = 0.0;
                    break;
                }
                thinnest = thinnest.min(shape.exit_distance(q, scale(st.normal, -1.0), 50.0));
                thinnest = thinnest.min(point_box3_distance(q, sb_lo, sb_hi));
            }
            if thinnest < wall {
                push(
                    k("seat_depth_mm"),
                    s.seat_depth_mm.to_string(),
                    format!("the seat pocket leaves a wall of {thinnest:.2} mm (minimum {wall} mm) to the socket or the far side"),
                );
            }
            Some(st)
        }
    }
}

/// Channel stage for sensor `i`: its tail channel stays on the pad and keeps the minimum wall to
/// the socket (the first problem along the channel is reported).
fn channel_rules(p: &FingertipParams, shape: &Shape, i: usize, s: &Sensor, out: &mut Vec<Problem>) {
    let wall = p.print.min_wall_mm;
    let (sb_lo, sb_hi) = socket_box(p);
    let m = &p.mount;
    let mut push = |path: String, value: String, msg: String| out.push((path, value, msg));
    let k = |f: &str| format!("sensor[{i}].{f}");
    let path = channel_path(shape, s);
    for (q, t) in along(&path, 0.25) {
        let x = q[0].max(0.0);
        let mut bad = false;
        for side in [-1.0, 0.0, 1.0] {
            let ex = x - t[1] * side * s.channel_width_mm / 2.0;
            let ey = q[1] + t[0] * side * s.channel_width_mm / 2.0;
            let y_edge = ey.abs();
            if y_edge > 0.85 * shape.half_width(x) {
                push(
                    k("channel_offset_mm"),
                    s.channel_offset_mm.to_string(),
                    format!(
                        "the tail channel runs off the pad at x = {x:.1} mm (its edge at {y_edge:.2} mm, pad usable to {:.2} mm): move it toward the centre or narrow it",
                        0.85 * shape.half_width(x)
                    ),
                );
                bad = true;
                break;
            }
            if ex < 0.0 || ex > m.socket_depth_mm + wall {
                continue;
            }
            if let Some(fp) = floor_point(shape, s, ex, ey) {
                let d = point_box3_distance(fp, sb_lo, sb_hi);
                if d < wall - 1e-9 {
                    push(
                        k("channel_depth_mm"),
                        s.channel_depth_mm.to_string(),
                        format!("the tail channel leaves a wall of {d:.2} mm to the socket at x = {x:.1} mm (minimum {wall} mm)"),
                    );
                    bad = true;
                    break;
                }
            }
        }
        if bad {
            break;
        }
    }
}

/// Sensor-pair stage: seats' flat regions do not overlap, and no tail channel crosses another
/// seat's pocket.
fn sensor_pair_rules(p: &FingertipParams, shape: &Shape, seats: &[Option<Seat>], out: &mut Vec<Problem>) {
    let mut push = |path: String, value: String, msg: String| out.push((path, value, msg));
    for i in 0..p.sensors.len() {
        for j in 0..p.sensors.len() {
            if i == j {
                continue;
            }
            let (si, sj) = (&p.sensors[i], &p.sensors[j]);
            if i < j {
                if let (Some(a), Some(b)) = (&seats[i], &seats[j]) {
                    let d = mesh::norm(sub(a.surface, b.surface));
                    let need = (si.flat_diameter_mm + sj.flat_diameter_mm) / 2.0;
                    if d < need {
                        push(
                            format!("sensor[{j}].position_from_tip_mm"),
                            sj.position_from_tip_mm.to_string(),
                            format!("its flat region overlaps sensor[{i}]'s: centres {d:.2} mm apart, at least {need:.2} mm needed"),
                        );
                    }
                }
            }
            // channel of i vs pocket of j, plan view: either a printable wall between them, or the
            // channel opens into the pocket's rim wide enough to leave no sliver, without running
            // under the sensing area (the dome's footprint)
            let (cy, r, half) = (sj.lateral_offset_mm, sj.seat_diameter_mm / 2.0, si.channel_width_mm / 2.0);
            let d = channel_to_seat(shape, si, sj);
            let clear = r + half + crate::checks::min_feature::MIN_FEATURE_MM;
            let (open_lo, open_hi) = (sj.dome_diameter_mm / 2.0 + half, r + half - OPEN_INTO_POCKET_MM);
            if d < clear && !(d >= open_lo && d <= open_hi) {
                let open =
                    if open_lo <= open_hi { format!(", or let it open into the pocket's rim ({:.2}–{:.2} mm)", cy.abs() + open_lo, cy.abs() + open_hi) } else { String::new() };
                push(
                    format!("sensor[{i}].channel_offset_mm"),
                    si.channel_offset_mm.to_string(),
                    format!(
                        "the tail channel comes {:.2} mm from sensor[{j}]'s seat pocket: a wall under {} mm (two nozzle widths) does not print, and a channel under the sensing area lifts the board; route it beside (|offset| ≥ {:.2} mm){open}",
                        d - r - half,
                        crate::checks::min_feature::MIN_FEATURE_MM,
                        cy.abs() + clear
                    ),
                );
            }
        }
    }
}

/// Cross-hole stage: along y through both side walls and the socket, a head recess on each flank.
/// Each hole passes through the socket, then its recesses, its spacing to the later holes and its
/// wall to the seats and channels are checked.
fn cross_hole_rules(p: &FingertipParams, shape: &Shape, seats: &[Option<Seat>], out: &mut Vec<Problem>) {
    let (sb_lo, sb_hi) = socket_box(p);
    let m = &p.mount;
    let r = m.hole_diameter_mm / 2.0;
    for (i, h) in m.holes.iter().enumerate() {
        let (path, val) = hole_key(p, i);
        let (x, z) = (h[0], h[1]);
        if x - r < 0.0 || x + r > m.socket_depth_mm || z - r < sb_lo[2] || z + r > sb_hi[2] {
            out.push((
                path,
                val,
                format!(
                    "the cross hole ({} mm) must pass through the socket: x from {r} to {}, z from {} to {} mm",
                    m.hole_diameter_mm,
                    m.socket_depth_mm - r,
                    sb_lo[2] + r,
                    sb_hi[2] - r
                ),
            ));
            continue;
        }
        head_recess_rules(p, shape, i, out);
        hole_spacing_rules(p, i, out);
        hole_to_sensor_rules(p, shape, seats, i, out);
    }
}

/// The key and value a problem of hole `i` is reported under.
fn hole_key(p: &FingertipParams, i: usize) -> (String, String) {
    let h = p.mount.holes[i];
    (format!("mount.holes[{i}]"), format!("[{}, {}]", h[0], h[1]))
}

/// Head-recess stage of hole `i`: the recess keeps the minimum wall to the mount face and beside
/// the socket, and breaks out on a flank no steeper than [`MAX_RECESS_SLOPE_DEG`].
fn head_recess_rules(p: &FingertipParams, shape: &Shape, i: usize, out: &mut Vec<Problem>) {
    let wall = p.print.min_wall_mm;
    let m = &p.mount;
    let rr = m.hole_diameter_mm.max(m.head_diameter_mm) / 2.0;
    let (x, z) = (m.holes[i][0], m.holes[i][1]);
    let (path, val) = hole_key(p, i);
    let mut push = |path: String, value: String, msg: String| out.push((path, value, msg));
    if x - rr < wall {
        push(
            path.clone(),
            val.clone(),
            format!("the head recess ({} mm) leaves {:.2} mm to the mount face (minimum {wall} mm): move the hole to x ≥ {:.2}", m.head_diameter_mm, x - rr, rr + wall),
        );
    }
    match (head_floor(shape, p, x, z), rim_slope_deg(shape, x, z, rr)) {
        (Some(fy), Some(slope)) => {
            let grip = fy - m.socket_width_mm / 2.0;
            if grip < wall {
                push(
                    "mount.head_depth_mm".into(),
                    m.head_depth_mm.to_string(),
                    format!("hole {i}: the head recess leaves {grip:.2} mm of side wall beside the socket (minimum {wall} mm): make it shallower or the socket narrower"),
                );
            }
            if m.head != Head::None && slope > MAX_RECESS_SLOPE_DEG {
                push(path.clone(), val.clone(), format!("the head recess breaks out where the flank slopes {slope:.0}° (at most {MAX_RECESS_SLOPE_DEG}°), leaving a sharp, thin lip: move the hole toward the mid-plane (z = 0)"));
            }
        }
        _ => push(path.clone(), val.clone(), "the head recess runs off the flank of the body".into()),
    }
}

/// Spacing stage of hole `i`: every later hole lies at least two recess radii plus the minimum
/// wall away.
fn hole_spacing_rules(p: &FingertipParams, i: usize, out: &mut Vec<Problem>) {
    let wall = p.print.min_wall_mm;
    let m = &p.mount;
    let rr = m.hole_diameter_mm.max(m.head_diameter_mm) / 2.0;
    let (x, z) = (m.holes[i][0], m.holes[i][1]);
    for (j, g) in m.holes.iter().enumerate().skip(i + 1) {
        let d = ((x - g[0]).powi(2) + (z - g[1]).powi(2)).sqrt();
        if d < 2.0 * rr + wall {
            out.push((format!("mount.holes[{j}]"), format!("[{}, {}]", g[0], g[1]), format!("too close to hole {i}: {d:.2} mm apart, at least {:.2} mm", 2.0 * rr + wall)));
        }
    }
}

/// Hole-to-sensor stage: the seats and tail channels keep a minimum wall to hole `i` and its
/// recesses.
fn hole_to_sensor_rules(p: &FingertipParams, shape: &Shape, seats: &[Option<Seat>], i: usize, out: &mut Vec<Problem>) {
    let wall = p.print.min_wall_mm;
    let m = &p.mount;
    let rr = m.hole_diameter_mm.max(m.head_diameter_mm) / 2.0;
    let (x, z) = (m.holes[i][0], m.holes[i][1]);
    let (path, val) = hole_key(p, i);
    for (k, s) in p.sensors.iter().enumerate() {
        let mut pts = Vec::new();
        if let Some(Some(st)) = seats.get(k) {
            let (u, v, _) = frame(st.normal);
            let rf = s.flat_diameter_mm / 2.0;
            for j in 0..32 {
                let a = 2.0 * std::f64::consts::PI * j as f64 / 32.0;
                pts.push(add(st.flat_center, add(scale(u, rf * a.cos()), scale(v, rf * a.sin()))));
            }
            pts.push(st.floor_center);
        }
        for (q, _) in along(&channel_path(shape, s), 0.25) {
            for side in [-1.0, 1.0] {
                if let Some(fp) = floor_point(shape, s, q[0].max(0.0), q[1] + side * s.channel_width_mm / 2.0) {
                    pts.push(fp);
                }
            }
        }
        let near = pts.iter().map(|q| ((q[0] - x).powi(2) + (q[2] - z).powi(2)).sqrt() - rr).fold(f64::INFINITY, f64::min);
        if near < wall {
            out.push((path.clone(), val.clone(), format!("the cross hole and its recesses come within {near:.2} mm of sensor[{k}]'s seat or tail channel (minimum {wall} mm)")));
        }
    }
}

/// The spot-face cutter of a seat: exactly the flat diameter at the seat plane, flaring at 45°
/// above it (the mold's core uses the same cutter, so the cover follows the flat seat).
pub fn spot_face(st: &Seat, s: &Sensor, tol: f64) -> Solid {
    let rf = s.flat_diameter_mm / 2.0;
    let flare_h = st.flat_depth + 2.0;
    Solid::cylinder(st.flat_center, st.normal, flare_h, rf, rf + flare_h, segments(rf + flare_h, tol))
}

/// Output frame: the mount face on the bed (z = 0), the finger pointing up.
pub fn to_print(p: P3) -> P3 {
    [p[1], p[2], p[0]]
}

/// Builds the fingertip.
/// Reads a fingertip file's parameters and its sensor board (relative to `dir`; [`crate::params`]
/// parses and type-checks) and applies the
/// family's geometric rules, every problem named with its line.
pub fn load(src: &crate::params::SourceFile, default_name: &str, dir: &std::path::Path) -> Result<FingertipParams> {
    let p = FingertipParams::from_source(src, default_name, dir)?;
    rules_on(&p, src)?;
    Ok(p)
}

/// The geometric rules as input problems of `src`, the file the parameters came from.
pub(crate) fn rules_on(p: &FingertipParams, src: &crate::params::SourceFile) -> Result<()> {
    let problems: Vec<_> = validate(p)
        .into_iter()
        .map(|(path, value, msg)| match &p.mount.screw {
            // a named screw sized the hole and recess: the problem is the screw's, or its sink
            Some(screw) if ["mount.hole_diameter_mm", "mount.head_diameter_mm", "mount.head_depth_mm"].contains(&path.as_str()) => {
                let (m, h) = (&p.mount, if path == "mount.hole_diameter_mm" { "clearance hole" } else { "head recess" });
                src.problem(
                    "mount.screw",
                    format!("{screw:?}"),
                    format!("{msg} [the {h} this screw needs: hole {} mm, recess {:.2} mm wide and {:.2} mm deep; a smaller screw, a smaller head_sink_mm or another head type may fit]", m.hole_diameter_mm, m.head_diameter_mm, m.head_depth_mm),
                )
            }
            _ => src.problem(&path, value, msg),
        })
        .collect();
    crate::params::finish(Some(()), problems)
}

/// The cap that makes a hole across the finger print without support: the fingertip prints
/// standing on its mount face, so a cross hole is horizontal, and its top would be a flat ceiling.
/// Two 45° faces tangent to the circle, meeting above it toward the tip (+x), turn it into a
/// teardrop whose every overhang is 45°. The cap spans y from `y0` to `y1`.
fn teardrop_cap(x: f64, z: f64, r: f64, y0: f64, y1: f64) -> Solid {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    let (lo, hi) = (y0.min(y1), y0.max(y1));
    let tri = [[x + r * s * 0.999, z + r * s], [x + r * s * 0.999, z - r * s], [x + r * std::f64::consts::SQRT_2, z]];
    let pts: Vec<P3> = tri.iter().flat_map(|&[px, pz]| [[px, lo, pz], [px, hi, pz]]).collect();
    Solid::hull(&pts)
}

/// Builds the fingertip: the body less every seat, channel, socket and cross-hole cutter in one
/// boolean, turned into the print frame.
pub fn build(p: &FingertipParams) -> Result<Part> {
    let name = p.name.as_str();
    let shape = Shape::new(&p.body);
    let tol = p.print.chordal_tolerance_mm;
    let body = Solid::from_mesh(&shape.body_mesh(tol, name)?, name)?;

    let mut cutters = Vec::new();
    let mut seat_features = Vec::new();
    for (i, s) in p.sensors.iter().enumerate() {
        seat_features.push(sensor_cutters(p, &shape, i, s, &mut cutters)?);
    }
    let m = &p.mount;
    let (sb_lo, sb_hi) = socket_box(p);
    cutters.push(Solid::cuboid(sb_lo, sb_hi));
    let hole_features = cross_hole_cutters(p, &shape, &mut cutters)?;
    let cutter = Solid::union_all(&cutters).expect("a fingertip has at least the socket cutter");
    let (solid, _) = body.difference(&cutter).drop_slivers(1e-6);
    solid.ok(name)?;
    // into the print frame: (x, y, z) -> (y, z, x) is a rotation
    let solid = solid.place([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0; 3]);
    let mesh = solid.to_mesh();
    Ok(Part {
        name: name.to_string(),
        mesh,
        solid,
        expected_genus: 2 * m.holes.len() as i32,
        density_g_cm3: p.print.density_g_cm3,
        process: crate::part::Process::Printed,
        // measured (issue 18, item 7): the cross holes and counterbores print as teardrops, but
        // the top of each seat pocket is a 0.3 mm ceiling, and a pad that bulges above its base
        // (the thumb, the 2s's proximal flat) overhangs
        supports: Some("seat pockets' top edges (0.3 mm ceilings) and pad overhangs beside the seats"),
        infill: 1.0,
        write_3mf: true,
        features: json!({
            "kind": "fingertip",
            "frame": "mount face on the bed (z = 0); x lateral, y toward the nail, z toward the tip",
            "seats": seat_features,
            "holes": hole_features,
            "screw": m.screw,
            "head_recess": {"kind": format!("{:?}", m.head).to_lowercase(), "diameter_mm": m.head_diameter_mm, "depth_mm": m.head_depth_mm},
            "width_mm": p.body.width_mm,
            "thickness_mm": p.body.thickness_mm,
            "length_mm": p.body.length_mm,
            "max_channel_depth_mm": p.sensors.iter().map(|s| s.channel_depth_mm).fold(0.0, f64::max),
            "min_wall_mm": p.print.min_wall_mm,
            "chordal_tolerance_mm": tol,
        }),
        extra: Default::default(),
    })
}

/// Seat stage of the build for sensor `i`: the spot face and the pocket, then the tail channel's
/// cutters; returns the seat's entry of the part's features.
fn sensor_cutters(p: &FingertipParams, shape: &Shape, i: usize, s: &Sensor, cutters: &mut Vec<Solid>) -> Result<serde_json::Value> {
    let name = p.name.as_str();
    let tol = p.print.chordal_tolerance_mm;
    let far = p.body.thickness_mm + 4.0;
    let st = seat(shape, s).map_err(|w| Error::geometry(name, format!("sensor[{i}] {w}")))?;
    let rs = s.seat_diameter_mm / 2.0;
    // spot face: exactly rf at the seat plane, flaring at 45° above it so no edge around the flat
    // is sharper than 90°; it only cuts within flat_depth of the rim (the body lies below the
    // tangent plane, flat_depth above the seat plane)
    cutters.push(spot_face(&st, s, tol));
    cutters.push(Solid::cylinder(st.floor_center, st.normal, s.seat_depth_mm + st.flat_depth + far, rs, rs, segments(rs, tol)));
    channel_cutters(p, shape, i, s, cutters)?;
    let cp = channel_path(shape, s);
    let channel_dir = to_print(mesh::unit([cp[1][0] - cp[0][0], cp[1][1] - cp[0][1], 0.0]));
    Ok(json!({
        "flat_center": to_print(st.flat_center),
        "floor_center": to_print(st.floor_center),
        "normal": to_print(st.normal),
        "flat_diameter_mm": s.flat_diameter_mm,
        "seat_diameter_mm": s.seat_diameter_mm,
        "seat_depth_mm": s.seat_depth_mm,
        "flat_depth_mm": st.flat_depth,
        "dome_diameter_mm": s.dome_diameter_mm,
        "dome_height_mm": s.dome_height_mm,
        "channel_dir": channel_dir,
        "opened_by_channels": channels_opening_into(shape, p, i),
    }))
}

/// Channel stage of the build for sensor `i`: the tail channel's pieces along its path, then a
/// joint at each bend.
fn channel_cutters(p: &FingertipParams, shape: &Shape, i: usize, s: &Sensor, cutters: &mut Vec<Solid>) -> Result<()> {
    let name = p.name.as_str();
    let tol = p.print.chordal_tolerance_mm;
    // tail channel: hulls of pieces whose floor follows the pad at the channel depth; a piece
    // grows while its floor stays within tol/2 of the straight chord (few pieces where the pad
    // is straight, short ones where it curves)
    let zb = -shape.pad_depth - 2.0;
    let pts = along(&channel_path(shape, s), 0.25);
    let edge = |q: [f64; 2], t: [f64; 2], side: f64| -> Result<P3> {
        let ex = q[0] - t[1] * side * s.channel_width_mm / 2.0;
        let ey = q[1] + t[0] * side * s.channel_width_mm / 2.0;
        floor_point(shape, s, ex, ey).ok_or_else(|| Error::geometry(name, format!("sensor[{i}] channel leaves the pad")))
    };
    let mut start = 0;
    while start + 1 < pts.len() {
        let mut end = start + 1;
        while end + 1 < pts.len() && pts[end + 1].1 == pts[start].1 {
            let cand = end + 1;
            let mut fits = true;
            for side in [-1.0, 1.0] {
                let (a, b) = (edge(pts[start].0, pts[start].1, side)?, edge(pts[cand].0, pts[cand].1, side)?);
                for mid in start + 1..cand {
                    let m = edge(pts[mid].0, pts[mid].1, side)?;
                    let f = (mid - start) as f64 / (cand - start) as f64;
                    if (a[2] + (b[2] - a[2]) * f - m[2]).abs() > tol / 2.0 {
                        fits = false;
                    }
                }
            }
            if !fits {
                break;
            }
            end = cand;
        }
        let (a, b) = (pts[start], pts[end]);
        start = end;
        if (a.0[0] - b.0[0]).abs() + (a.0[1] - b.0[1]).abs() < 1e-9 {
            continue;
        }
        let mut hull = Vec::with_capacity(8);
        for (q, t) in [a, b] {
            for side in [-1.0, 1.0] {
                let fp = edge(q, t, side)?;
                // walls flare at 45° from the floor, so the channel's edges are never sharp
                let flare = fp[2] - zb;
                hull.push(fp);
                hull.push([fp[0] - t[1] * side * flare, fp[1] + t[0] * side * flare, zb]);
            }
        }
        cutters.push(Solid::hull(&hull));
    }
    // at a bend the pieces end square to their own runs: a joint spanning both ends fills the
    // outer corner, which would otherwise be a 45° spike of wall in the channel
    let cp = channel_path(shape, s);
    for w in cp.windows(3) {
        let unit2 = |a: [f64; 2], b: [f64; 2]| {
            let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            [(b[0] - a[0]) / l, (b[1] - a[1]) / l]
        };
        let mut hull = Vec::with_capacity(8);
        for t in [unit2(w[0], w[1]), unit2(w[1], w[2])] {
            for side in [-1.0, 1.0] {
                let fp = edge(w[1], t, side)?;
                let flare = fp[2] - zb;
                hull.push(fp);
                hull.push([fp[0] - t[1] * side * flare, fp[1] + t[0] * side * flare, zb]);
            }
        }
        cutters.push(Solid::hull(&hull));
    }
    Ok(())
}

/// Cross-hole stage of the build: each hole with its teardrop cap, and the head recesses on both
/// flanks; returns the holes' entries of the part's features (one per flank).
fn cross_hole_cutters(p: &FingertipParams, shape: &Shape, cutters: &mut Vec<Solid>) -> Result<Vec<serde_json::Value>> {
    let name = p.name.as_str();
    let tol = p.print.chordal_tolerance_mm;
    let m = &p.mount;
    let mut hole_features = Vec::new();
    let far = p.body.width_mm / 2.0 + 2.0;
    for (i, h) in m.holes.iter().enumerate() {
        let (x, z) = (h[0], h[1]);
        let r = m.hole_diameter_mm / 2.0;
        cutters.push(Solid::cylinder([x, -far, z], [0.0, 1.0, 0.0], 2.0 * far, r, r, segments(r, tol)));
        cutters.push(teardrop_cap(x, z, r, -far, far));
        let fy = head_floor(shape, p, x, z).ok_or_else(|| Error::geometry(name, format!("hole {i} is off the body")))?;
        let rh = m.head_diameter_mm / 2.0;
        for sgn in [-1.0, 1.0] {
            let dir = [0.0, sgn, 0.0];
            let at = |y: f64| [x, sgn * y, z];
            match m.head {
                Head::None => {}
                Head::Counterbore => {
                    cutters.push(Solid::cylinder(at(fy), dir, far - fy, rh, rh, segments(rh, tol)));
                    cutters.push(teardrop_cap(x, z, rh, sgn * fy, sgn * far));
                }
                Head::Countersink => {
                    let cone_h = rh - r;
                    cutters.push(Solid::cylinder(at(fy), dir, cone_h, r, rh, segments(rh, tol)));
                    cutters.push(Solid::cylinder(at(fy + cone_h - 1e-3), dir, far - fy - cone_h, rh, rh, segments(rh, tol)));
                }
            }
            let wall_mid = 0.5 * (m.socket_width_mm / 2.0 + fy);
            hole_features.push(json!({
                "axis_point": to_print(at(wall_mid)),
                "axis_dir": to_print(dir),
                "diameter_mm": m.hole_diameter_mm,
                "wall_mm": fy - m.socket_width_mm / 2.0,
            }));
        }
    }
    Ok(hole_features)
}
