//! Checks of an assembled mold, run before anything is written. Each rule names what it measured;
//! the measurements also go to the manifest.

use super::conforming::Assembled;
use super::Layout;
use crate::checks::Violation;
use crate::fingertip::{self, Shape};
use crate::mesh::{self, add, dot, frame, norm, scale, sub, Solid, P3};
use crate::params::mold::{CoverProfile, Mold, MoldParams};
use serde_json::{json, Value};

/// Largest overlap (mm³) two assembled pieces may have: touching faces, no interference.
pub const MAX_OVERLAP_MM3: f64 = 1e-3;
/// The cover's inner surface must lie on the fingertip within this (mm).
pub const MAX_INNER_GAP_MM: f64 = 0.05;
/// The cover's outer surface over a dome may deviate this much from the undisturbed offset (mm).
pub const MAX_HUMP_MM: f64 = 0.05;
/// A uniform cover's thickness over each sensing area stays within this fraction of the nominal.
pub const UNIFORM_TOLERANCE: f64 = 0.10;

fn v(part: &str, rule: &'static str, measured: String) -> Violation {
    Violation { part: part.to_string(), rule, measured }
}

/// Point of the exact offset surface (pad offset by `t`) on the line q + s·dir, solved by Newton
/// over (x, phi, s) from a start near q. Returns s.
pub fn offset_along(shape: &Shape, t: f64, q: P3, dir: P3, s0: f64) -> Option<f64> {
    let f = |x: f64, phi: f64, s: f64| -> P3 {
        let b = shape.surface_point(x, phi);
        let o = add(b, scale(shape.normal_at(b), t));
        sub(o, add(q, scale(dir, s)))
    };
    let p0 = add(q, scale(dir, s0));
    let (mut x, mut phi, mut s) = (p0[0], (p0[2] / shape.pad_depth_at(p0[0]).max(1e-9)).atan2(p0[1] / shape.half_width(p0[0]).max(1e-9)), s0);
    for _ in 0..40 {
        let r = f(x, phi, s);
        if norm(r) < 1e-10 {
            return Some(s);
        }
        let h = 1e-6;
        let cols = [sub(f(x + h, phi, s), r), sub(f(x, phi + h, s), r), sub(f(x, phi, s + h), r)].map(|c| scale(c, 1.0 / h));
        let m = nalgebra::Matrix3::from_columns(&[cols[0].into(), cols[1].into(), cols[2].into()]);
        let d = m.lu().solve(&nalgebra::Vector3::from(r))?;
        x -= d[0];
        phi -= d[1];
        s -= d[2];
    }
    (norm(f(x, phi, s)) < 1e-6).then_some(s)
}

/// The cover's thickness over each sensing area, along the seat normal: at the centre and on
/// circles at 0.5, 0.9 and 0.98 of the dome's radius (8 points each), from the dome cavity to the
/// outer surface. A uniform cover's window makes it the nominal; a cover that follows the pad (its
/// exact offset) is the nominal plus the flat's recess less the dome's height there, and less
/// toward the dome's edge where the pad curves away.
pub fn cover_over_domes(l: &Layout, a: &Assembled) -> Vec<Value> {
    let mut out = Vec::new();
    for d in &l.domes {
        let n = d.normal;
        let helper = if n[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let u = crate::mesh::unit(crate::mesh::cross(n, helper));
        let v = crate::mesh::cross(n, u);
        let along = |q: P3| -> Option<f64> {
            let from = crate::mesh::sub(q, crate::mesh::scale(n, 0.5));
            let to = crate::mesh::add(q, crate::mesh::scale(n, d.depth + 10.0));
            let hits = a.cover.ray_hits(from, to);
            (hits.len() >= 2).then(|| hits[1] - hits[0])
        };
        let centre = along(d.base);
        let mut ring = Vec::new();
        for frac in [0.5, 0.9, 0.98] {
            for k in 0..8 {
                let t = k as f64 * std::f64::consts::FRAC_PI_4;
                let q = crate::mesh::add(d.base, crate::mesh::add(crate::mesh::scale(u, frac * d.dome_r * t.cos()), crate::mesh::scale(v, frac * d.dome_r * t.sin())));
                if let Some(x) = along(q) {
                    ring.push(x);
                }
            }
        }
        let all: Vec<f64> = centre.into_iter().chain(ring.iter().copied()).collect();
        out.push(json!({
            "centre_mm": centre,
            "min_mm": all.iter().cloned().fold(f64::INFINITY, f64::min),
            "max_mm": all.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            "points": all.len(),
        }));
    }
    out
}

/// Where air leaves the cavity: the sprue and rim vents from the parting plane up, a pocket vent from
/// its pocket's top.
pub fn exits(a: &Assembled) -> Vec<super::trapped_air::Exit> {
    std::iter::once(super::trapped_air::Exit { xy: a.sprue.0, r: a.sprue.1, from_z: a.z_parting }).chain(a.vents.iter().copied()).collect()
}

/// The conforming mold's checks. Returns the violations and the measurements.
pub fn conforming(p: &MoldParams, l: &Layout, a: &Assembled) -> (Vec<Violation>, Value) {
    let name = p.name.as_str();
    let m = &p.mold;
    let mut out = Vec::new();
    let (core_shell, core_cav, shell_cav) = overlap_checks(name, a, &mut out);
    let (key_gaps, key_walls) = key_checks(name, m, a, &mut out);
    let openings_ok = opening_checks(name, a, &mut out);
    let mouth_blocked = sprue_mouth_check(name, m.chordal_tolerance_mm, a, &mut out);
    let AirRegions { open, sealed, reaching_out, enclosed, cavity_vol } = air_region_checks(name, m, a, &mut out);
    let (cover_vol, k3) = cavity_volume_check(name, a, cavity_vol, &mut out);
    let (inner_max, inner_n) = inner_surface_check(p, l, a, &mut out);
    let (dome_overlap, dome_gap, humps) = dome_checks(p, l, a, &mut out);
    let over = cover_over_domes(l, a);
    uniform_cover_check(p, &over, &mut out);
    let (min_slope, wrong, checked) = undercut_checks(name, m, a, &mut out);
    let air = trapped_air_check(name, a, &mut out);
    let measured = json!({
        "trapped_air_pockets": air.iter().map(|q| json!({"apex": q.apex, "depth_mm": q.depth_mm})).collect::<Vec<_>>(),
        "cover_over_sensing_area_mm": over,
        "overlap_core_shell_mm3": core_shell,
        "overlap_core_cavity_mm3": core_cav,
        "overlap_shell_cavity_mm3": shell_cav,
        "key_gaps_mm": key_gaps,
        "key_hole_walls_mm": key_walls,
        "openings_reach_cavity": openings_ok,
        "sprue_mouth_over_pieces_mm2": mouth_blocked,
        "air_regions_open": open.len(),
        "air_regions_sealed": sealed.len(),
        "sealed_air_at_outer_faces_mm3": reaching_out,
        "enclosed_volume_mm3": enclosed,
        "cavity_volume_mm3": cavity_vol,
        "cover_volume_mm3": cover_vol,
        "shrinkage_volume_factor": k3,
        "inner_surface_max_gap_mm": inner_max,
        "inner_surface_faces_checked": inner_n,
        "dome_overlap_mm3": dome_overlap,
        "dome_min_gap_mm": dome_gap,
        "hump_over_dome_mm": humps,
        "min_wall_slope_deg": min_slope,
        "faces_facing_wrong_piece": wrong,
        "cavity_faces_checked": checked,
    });
    (out, measured)
}

/// Check 1: the pieces do not intersect when assembled, nor reach into the cavity. Returns the
/// core/shell, core/cavity and shell/cavity overlaps (mm³).
fn overlap_checks(name: &str, a: &Assembled, out: &mut Vec<Violation>) -> (f64, f64, f64) {
    let core_shell = a.core.intersection(&a.shell).volume();
    let core_cav = a.core.intersection(&a.cavity).volume();
    let shell_cav = a.shell.intersection(&a.cavity).volume();
    for (what, vol) in [("core and shell", core_shell), ("core and cavity", core_cav), ("shell and cavity", shell_cav)] {
        if vol > MAX_OVERLAP_MM3 {
            out.push(v(name, "assembled mold pieces must not intersect", format!("{what} overlap {vol:.4} mm³")));
        }
    }
    (core_shell, core_cav, shell_cav)
}

/// Check 2: keys fit their holes with the stated clearance, and their holes keep a wall to the
/// cavity. Returns each key's gap and each hole's wall (mm).
fn key_checks(name: &str, m: &Mold, a: &Assembled, out: &mut Vec<Violation>) -> (Vec<f64>, Vec<f64>) {
    let c = m.key_clearance_mm;
    let cos_d = m.draft_deg.to_radians().cos();
    let mut key_gaps = Vec::new();
    let mut key_walls = Vec::new();
    for (i, (pin, hole)) in a.pins.iter().zip(&a.holes).enumerate() {
        let below = pin.trim([0.0, 0.0, -1.0], -(a.z_parting - 0.05));
        let gap = below.min_gap(&a.shell, c + 1.0);
        key_gaps.push(gap);
        if !(gap >= 0.9 * c * cos_d - 1e-6 && gap <= c + 0.02) {
            out.push(v(name, "keys must fit their holes with the stated clearance", format!("key {i}: gap {gap:.3} mm for a clearance of {c} mm")));
        }
        let wall = hole.min_gap(&a.cavity, 3.0 * m.min_wall_mm);
        key_walls.push(wall);
        if wall < m.min_wall_mm - 1e-6 {
            out.push(v(name, "key holes must keep the minimum wall to the cavity", format!("key {i}: {wall:.2} mm (minimum {})", m.min_wall_mm)));
        }
    }
    (key_gaps, key_walls)
}

/// Check 3: the sprue and every vent open straight into the cavity: at the rim, or, for a vent
/// from a pocket in the ceiling, at the pocket's top. Returns whether each does.
fn opening_checks(name: &str, a: &Assembled, out: &mut Vec<Violation>) -> Vec<bool> {
    let mut openings_ok = Vec::new();
    for (i, o) in exits(a).iter().enumerate() {
        let what = if i == 0 { "sprue" } else { "vent" };
        let xy = o.xy;
        let top = [xy[0], xy[1], a.z_top + 1.0];
        let bottom = [xy[0], xy[1], a.pocket_top(o).map(|z| z - 0.1).unwrap_or(a.z_parting - 0.02)];
        let clear = a.core.ray_hits(top, bottom).is_empty() && a.shell.ray_hits(top, bottom).is_empty();
        let into = a.cavity.contains(bottom, a.z_top + 2.0) || (i == 0 && a.gate.contains(bottom, a.z_top + 2.0));
        openings_ok.push(clear && into);
        if !(clear && into) {
            out.push(v(
                name,
                "the sprue and vents must open straight into the cavity",
                format!("{what} at ({:.2}, {:.2}): clear {clear}, reaches the cavity {into}", xy[0], xy[1]),
            ));
        }
    }
    openings_ok
}

/// A mouth this much covered by a piece (mm²) is not wholly over the cavity: below it, facets.
pub const MAX_MOUTH_COVERED_MM2: f64 = 0.01;

/// Check 3, continued: the sprue's mouth (its circle just under the parting plane) lies wholly over
/// liquid, the rim and the gate well: no part of it is closed by the core's plug or the shell's
/// face, where the poured PDMS would stand on a ledge. The mouth is measured within the chordal
/// tolerance `tol` of its circle (the well is a polygon whose inner radius is at least r − tol).
/// Returns the area covered by a piece (mm²).
pub fn sprue_mouth_check(name: &str, tol: f64, a: &Assembled, out: &mut Vec<Violation>) -> f64 {
    let (xy, r) = a.sprue;
    let h = 0.02;
    let disc = Solid::cylinder([xy[0], xy[1], a.z_parting - 0.01 - h], [0.0, 0.0, 1.0], h, r - tol, r - tol, 96);
    let covered = (disc.intersection(&a.core).volume() + disc.intersection(&a.shell).volume()) / h;
    if covered > MAX_MOUTH_COVERED_MM2 {
        out.push(v(
            name,
            "the sprue's mouth must lie wholly over the cavity (the rim and the gate well)",
            format!("{covered:.3} mm² of the Ø{:.2} mm mouth at ({:.2}, {:.2}) is over the core's plug or the shell's face", 2.0 * r, xy[0], xy[1]),
        ));
    }
    covered
}

/// What check 4 measured: the air regions inside the mold with its openings open and plugged.
struct AirRegions {
    /// Air regions with the openings open.
    open: Vec<Solid>,
    /// Volumes of the air regions with the openings plugged (mm³).
    sealed: Vec<f64>,
    /// Sealed air at the mold's outer faces (mm³).
    reaching_out: f64,
    /// The one sealed region's volume, NaN unless there is exactly one (mm³).
    enclosed: f64,
    cavity_vol: f64,
}

/// Check 4: exactly one cavity, reachable from outside only through the sprue and the vents. The
/// mold's pieces fill their bounding box but for the cavity and the openings, so the box less
/// the pieces is the air inside the mold: with the openings open it must be one region that
/// reaches the top face; with them plugged, one region inside the box with the cavity's volume.
fn air_region_checks(name: &str, m: &Mold, a: &Assembled, out: &mut Vec<Violation>) -> AirRegions {
    let (lo, hi) = a.bounds;
    let moldbox = Solid::cuboid(lo, hi);
    let mut fill = vec![a.core.clone(), a.shell.clone()];
    fill.extend(a.holes.iter().cloned()); // key clearances are closed pockets, not the cavity
    let fill = Solid::union_all(&fill).expect("pieces");
    let regions = |s: &Solid| -> Vec<Solid> { s.0.decompose().into_iter().map(Solid).filter(|c| c.volume() > 1e-6).collect() };
    let open = regions(&moldbox.difference(&fill));
    let w = a.z_top - a.z_parting;
    let mut plugs = Vec::new();
    let r_sprue = super::conforming::sprue_radius(m, w + 2.0) + 0.2;
    plugs.push(Solid::cylinder([a.sprue.0[0], a.sprue.0[1], a.z_parting], [0.0, 0.0, 1.0], w + 3.0, r_sprue, r_sprue, 48));
    plugs.push(a.gate.clone()); // the gate well beside the rim is the sprue's, not the cover's
    for o in &a.vents {
        plugs.push(Solid::cylinder([o.xy[0], o.xy[1], o.from_z], [0.0, 0.0, 1.0], a.z_top + 1.0 - o.from_z, o.r + 0.2, o.r + 0.2, 24));
    }
    // air "reaches" a face of the mold when it has volume within 0.05 mm of it; the kernel can leave
    // zero-volume films along the faces where the pieces touch, which connect nothing
    let band = |faces: &[(usize, bool)]| -> Solid {
        let parts: Vec<Solid> = faces
            .iter()
            .map(|&(axis, top)| {
                let (mut a, mut b) = (lo, hi);
                if top {
                    a[axis] = hi[axis] - 0.05;
                } else {
                    b[axis] = lo[axis] + 0.05;
                }
                Solid::cuboid(a, b)
            })
            .collect();
        Solid::union_all(&parts).expect("faces")
    };
    let top_band = band(&[(2, true)]);
    let all_faces = band(&[(0, false), (0, true), (1, false), (1, true), (2, false), (2, true)]);
    let sealed_solid = moldbox.difference(&fill.union(&Solid::union_all(&plugs).expect("plugs")));
    let sealed: Vec<f64> = regions(&sealed_solid).iter().map(Solid::volume).collect();
    let reaching_out = sealed_solid.intersection(&all_faces).volume();
    let cavity_vol = a.cavity.volume();
    let open_ok = open.len() == 1 && open[0].intersection(&top_band).volume() > 1e-4;
    if !open_ok {
        out.push(v(
            name,
            "the cavity must reach the outside through the sprue and vents",
            format!("{} air regions inside the mold with the openings open (expected 1 reaching the top face)", open.len()),
        ));
    }
    let enclosed = if sealed.len() == 1 { sealed[0] } else { f64::NAN };
    if sealed.len() != 1 || reaching_out > 1e-4 || ((enclosed - cavity_vol) / cavity_vol).abs() > 1e-3 {
        out.push(v(
            name,
            "the assembled mold must enclose exactly one cavity, closed but for the sprue and vents",
            format!("{} air regions with the openings plugged (expected 1), {reaching_out:.5} mm³ of air at the mold's outer faces; enclosed {enclosed:.3} mm³ vs cavity {cavity_vol:.3} mm³", sealed.len()),
        ));
    }
    AirRegions { open, sealed, reaching_out, enclosed, cavity_vol }
}

/// Check 4, continued: the cavity's volume is the cover's times the shrinkage allowance. Returns
/// the cover's volume (mm³) and the volume factor.
fn cavity_volume_check(name: &str, a: &Assembled, cavity_vol: f64, out: &mut Vec<Violation>) -> (f64, f64) {
    let cover_vol = a.cover.volume();
    let k3 = a.k.powi(3);
    if ((cavity_vol / k3 - cover_vol) / cover_vol).abs() > 1e-6 {
        out.push(v(name, "the cavity's volume must equal the cover's (times the shrinkage allowance)", format!("cavity {cavity_vol:.3} / {k3:.5} vs cover {cover_vol:.3} mm³")));
    }
    (cover_vol, k3)
}

/// Check 5: the cover's inner surface lies on the fingertip. Returns the largest gap (mm) and the
/// number of faces checked.
fn inner_surface_check(p: &MoldParams, l: &Layout, a: &Assembled, out: &mut Vec<Violation>) -> (f64, usize) {
    let (inner_max, inner_n) = inner_gap(p, l, a);
    if inner_max > MAX_INNER_GAP_MM {
        out.push(v(&p.name, "the cover's inner surface must lie on the fingertip's pad", format!("max gap {inner_max:.3} mm over {inner_n} faces (limit {MAX_INNER_GAP_MM})")));
    }
    (inner_max, inner_n)
}

/// Check 5, continued: each dome fits its cavity, and a follow_pad cover does not hump over it.
/// Returns each dome's overlap with the cover (mm³), its gap to it (mm) and the humps (mm).
fn dome_checks(p: &MoldParams, l: &Layout, a: &Assembled, out: &mut Vec<Violation>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let name = p.name.as_str();
    let tol = p.mold.chordal_tolerance_mm;
    let mut dome_overlap = Vec::new();
    let mut dome_gap = Vec::new();
    let mut humps = Vec::new();
    for (i, d) in l.domes.iter().enumerate() {
        let dome = Solid::cylinder(d.base, d.normal, d.depth, d.dome_r, d.dome_r, mesh::segments(d.dome_r, tol));
        let ov = dome.intersection(&a.cover).volume();
        let gap = dome.min_gap(&a.cover, 1.0);
        dome_overlap.push(ov);
        dome_gap.push(gap);
        if ov > 1e-6 {
            out.push(v(name, "each sensor dome must fit its cavity with clearance ≥ 0", format!("sensor[{i}]: dome overlaps the cover by {ov:.5} mm³")));
        }
        // the hump rule is the follow_pad profile's (a uniform cover's window is held by its own rule)
        if p.cover.profile == CoverProfile::FollowPad {
            let hump = hump_mm(&l.shape, p.cover.thickness_mm, &a.cover, d.base, d.normal, d.r_base);
            humps.push(hump);
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // a NaN hump must fail the rule too
            if !(hump <= MAX_HUMP_MM) {
                out.push(v(
                    name,
                    "the cover's outer surface must not hump over a dome",
                    format!("sensor[{i}]: outer surface deviates {hump:.3} mm from the undisturbed offset (limit {MAX_HUMP_MM})"),
                ));
            }
        }
    }
    (dome_overlap, dome_gap, humps)
}

/// Check 5, last: a uniform cover is the nominal thickness ±10 % over each sensing area (`over`,
/// from [`cover_over_domes`]).
fn uniform_cover_check(p: &MoldParams, over: &[Value], out: &mut Vec<Violation>) {
    if p.cover.profile == CoverProfile::Uniform {
        let nominal = p.cover.thickness_mm;
        for (i, c) in over.iter().enumerate() {
            let (lo, hi, n) = (c["min_mm"].as_f64().unwrap_or(f64::NAN), c["max_mm"].as_f64().unwrap_or(f64::NAN), c["points"].as_u64().unwrap_or(0));
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // a NaN (no hit) must fail the rule too
            if n < 25 || !(lo >= (1.0 - UNIFORM_TOLERANCE) * nominal && hi <= (1.0 + UNIFORM_TOLERANCE) * nominal) {
                out.push(v(
                    &p.name,
                    "a uniform cover is the nominal thickness ±10 % over each sensing area",
                    format!(
                        "sensor[{i}]: {lo:.3}-{hi:.3} mm over {n} of 25 points, nominal {nominal} mm (allowed {:.3}-{:.3})",
                        (1.0 - UNIFORM_TOLERANCE) * nominal,
                        (1.0 + UNIFORM_TOLERANCE) * nominal
                    ),
                ));
            }
        }
    }
}

/// Check 6: no undercut: every cavity face slopes by at least the draft and belongs to the piece
/// that leaves in its direction (faces looking up to the core, looking down to the shell).
/// Returns the steepest wall's slope (deg), the faces facing the wrong piece and the faces checked.
fn undercut_checks(name: &str, m: &Mold, a: &Assembled, out: &mut Vec<Violation>) -> (f64, usize, usize) {
    let (min_slope, wrong, checked) = draft_check(a, m.draft_deg);
    if min_slope + 1e-3 < m.draft_deg {
        out.push(v(
            name,
            "cavity walls must have the draft angle against the demolding direction",
            format!("steepest wall {min_slope:.3}° from the demolding direction, draft {}°", m.draft_deg),
        ));
    }
    if wrong > 0 {
        out.push(v(name, "no undercut: each cavity face must belong to the piece that leaves in its direction", format!("{wrong} of {checked} faces face the wrong piece")));
    }
    (min_slope, wrong, checked)
}

/// Check 7: no air trapped in the cavity's ceiling when poured. Returns every pocket found.
fn trapped_air_check(name: &str, a: &Assembled, out: &mut Vec<Violation>) -> Vec<super::trapped_air::Pocket> {
    let air = super::trapped_air::pockets(&a.cavity.to_mesh(), a.z_parting, &exits(a));
    // a pocket the build could not vent is already reported (a warning and the manifest's
    // unvented_pockets); any other is a fault of the mold
    let unexpected: Vec<_> = air.iter().filter(|q| !a.unvented_pockets.iter().any(|u| mesh::norm(sub(q.apex, *u)) < 1.0)).collect();
    if !unexpected.is_empty() {
        out.push(v(
            name,
            "no air may be trapped when the mold is poured: every high point of the cavity needs a way up to the rim or a vent",
            unexpected.iter().map(|q| format!("a pocket {:.2} mm deep at ({:.2}, {:.2}, {:.2})", q.depth_mm, q.apex[0], q.apex[1], q.apex[2])).collect::<Vec<_>>().join("; "),
        ));
    }
    air
}

/// Largest gap (along the exact body's normal at the face's centre) between the cover's inner
/// faces and the finished fingertip, leaving out the faces over the seat pockets, tail channels and dome cavities.
fn inner_gap(p: &MoldParams, l: &Layout, a: &Assembled) -> (f64, usize) {
    let Ok(tip) = fingertip::build(&p.fingertip) else {
        return (f64::INFINITY, 0);
    };
    // back from the fingertip's print frame (y, z, x) to the design frame
    let tip = tip.solid.place([0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0; 3]);
    let cover = a.cover.to_mesh();
    let mut worst: f64 = 0.0;
    let mut n = 0;
    'faces: for t in &cover.triangles {
        let [p0, p1, p2] = t.map(|i| cover.vertices[i as usize]);
        let nrm = mesh::cross(sub(p1, p0), sub(p2, p0));
        if norm(nrm) < 1e-12 {
            continue;
        }
        let nn = mesh::unit(nrm);
        let c = scale(add(add(p0, p1), p2), 1.0 / 3.0);
        // inner faces lie on the core surface
        if a.core_surface.ray_hits(sub(c, scale(nn, 1e-3)), add(c, scale(nn, 1e-3))).is_empty() {
            continue;
        }
        for (st, (s, d)) in l.seats.iter().zip(p.fingertip.sensors.iter().zip(&l.domes)) {
            let rel = sub(c, st.flat_center);
            let h = dot(rel, st.normal);
            let radial = norm(sub(rel, scale(st.normal, h)));
            if radial < s.seat_diameter_mm / 2.0 + 0.05 || (radial < d.r_base + 0.05 && h > 1e-3) {
                continue 'faces;
            }
            let path = fingertip::channel_path(&l.shape, s);
            let band = s.channel_width_mm / 2.0 + 2.0 * s.channel_depth_mm + 0.2; // flared walls break out wider on a slope
            for w in path.windows(2) {
                let (a2, b2) = (w[0], w[1]);
                let dd = [b2[0] - a2[0], b2[1] - a2[1]];
                let l2 = dd[0] * dd[0] + dd[1] * dd[1];
                let tt = (((c[0] - a2[0]) * dd[0] + (c[1] - a2[1]) * dd[1]) / l2).clamp(0.0, 1.0);
                if ((c[0] - a2[0] - tt * dd[0]).powi(2) + (c[1] - a2[1] - tt * dd[1]).powi(2)).sqrt() < band {
                    continue 'faces;
                }
            }
        }
        n += 1;
        // measured along the exact surface's normal there: a sliver face's own normal can lie
        // along the surface, and a ray along it measures nothing
        let en = l.shape.normal_at(c);
        let hits = tip.ray_hits(sub(c, scale(en, 0.2)), add(c, scale(en, 0.2)));
        let gap = hits.iter().map(|h| (h - 0.2).abs()).fold(f64::INFINITY, f64::min);
        worst = worst.max(gap);
    }
    (worst, n)
}

/// Largest deviation of the cover's outer surface over a dome (within the cavity's radius) from
/// the exact offset surface, measured along the seat normal.
fn hump_mm(shape: &Shape, t: f64, cover: &Solid, base: P3, normal: P3, radius: f64) -> f64 {
    let (u, w, _) = frame(normal);
    let mut worst: f64 = 0.0;
    for i in -6..=6 {
        for j in -6..=6 {
            let (a, b) = (radius * i as f64 / 6.0, radius * j as f64 / 6.0);
            if a * a + b * b > radius * radius {
                continue;
            }
            let q = add(base, add(scale(u, a), scale(w, b)));
            let far = 10.0;
            let hits = cover.ray_hits(add(q, scale(normal, far)), q);
            let Some(first) = hits.first() else {
                return f64::INFINITY;
            };
            let measured = far - first;
            let Some(exact) = offset_along(shape, t, q, normal, t) else {
                return f64::INFINITY;
            };
            worst = worst.max((measured - exact).abs());
        }
    }
    worst
}

/// Smallest angle between any cavity face and the demolding direction (deg), how many faces face
/// a piece that cannot leave in their direction, and how many faces were checked.
fn draft_check(a: &Assembled, _draft: f64) -> (f64, usize, usize) {
    let cav = a.cavity.to_mesh();
    let openings = exits(a);
    let mut min_slope = 90.0f64;
    let mut wrong = 0;
    let mut n = 0;
    for t in &cav.triangles {
        let [p0, p1, p2] = t.map(|i| cav.vertices[i as usize]);
        let nrm = mesh::cross(sub(p1, p0), sub(p2, p0));
        let area2 = norm(nrm);
        if area2 < 1e-10 {
            continue;
        }
        let nn = scale(nrm, 1.0 / area2);
        n += 1;
        min_slope = min_slope.min(nn[2].abs().asin().to_degrees());
        let c = scale(add(add(p0, p1), p2), 1.0 / 3.0);
        // the piece whose surface the face lies on: a short segment across the face meets it there
        let on = |piece: &Solid| piece.ray_hits(sub(c, scale(nn, 1e-4)), add(c, scale(nn, 1e-4))).iter().any(|h| (h - 1e-4).abs() < 5e-5);
        let (on_core, on_shell) = (on(&a.core), on(&a.shell));
        if !on_core && !on_shell {
            // where the sprue or a vent opens onto the cavity, the face looks into the opening's air
            let in_opening = openings.iter().any(|o| (c[0] - o.xy[0]).hypot(c[1] - o.xy[1]) < o.r + 0.05 + (a.z_top - a.z_parting));
            if !in_opening {
                wrong += 1;
            }
            continue;
        }
        // faces looking up lie on the core, looking down on the shell; a wall parallel to the
        // opening direction (draft 0) may lie on either
        let owner_ok = if nn[2].abs() < 1e-6 {
            true
        } else if nn[2] > 0.0 {
            on_core
        } else {
            on_shell
        };
        if !owner_ok {
            wrong += 1;
        }
    }
    (min_slope, wrong, n)
}
