//! PDMS cover molds. `load` reads a mold file and its fingertip and applies both families' rules
//! (`validate` here checks the rules that need the fingertip's shape); `build` makes the
//! pieces and the cast cover; `checks` proves the assembled mold before anything is written.
//!
//! Conforming style: the cavity lies between a core (the fingertip's pad with its flat seats and
//! the sensor domes in place) and a shell (the pad's exact offset surface at the cover thickness),
//! below a parting plane under the fingertip's mid-plane. The mold opens along z: the shell comes
//! off downward, the core (a flange carrying the pad-shaped plug) upward.
//! Flat style: the paper's petri-dish method, a tray that casts a flat sheet with dome patterns.

pub mod checks;
pub mod conforming;
pub mod flat;
pub mod trapped_air;

use crate::fingertip::{self, Seat, Shape};
use crate::mesh::{self, P3};
use crate::params::mold::{MoldParams, Style};
use crate::part::{Assembly, Part};
use serde_json::{json, Map, Value};

/// What building one mold file gives.
pub struct MoldBuild {
    pub parts: Vec<Part>,
    pub assemblies: Vec<Assembly>,
    pub violations: Vec<crate::checks::Violation>,
    /// The `molds` manifest section entry (material estimate, checks' measurements).
    pub manifest: Map<String, Value>,
    /// Plain-words lines for the build summary.
    pub notes: Vec<String>,
}

/// The mold's frame: the fingertip's design frame turned about the y axis (through a point of the
/// finger's axis over the cover's middle) so the opening direction is +z. With no tilt it is the
/// design frame.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Tilt of the core's opening direction from the design frame's +z, toward the tip (rad). The
    /// parameter `demolding_tilt_deg` tilts the shell's (the pad's side) toward the tip: alpha = −it.
    pub alpha: f64,
    pub pivot: P3,
}

impl Frame {
    fn turn(theta: f64, p: P3) -> P3 {
        let (s, c) = theta.sin_cos();
        [p[0] * c + p[2] * s, p[1], -p[0] * s + p[2] * c]
    }
    pub fn to_mold(&self, p: P3) -> P3 {
        mesh::add(Self::turn(-self.alpha, mesh::sub(p, self.pivot)), self.pivot)
    }
    pub fn to_design(&self, p: P3) -> P3 {
        mesh::add(Self::turn(self.alpha, mesh::sub(p, self.pivot)), self.pivot)
    }
    pub fn dir_to_mold(&self, n: P3) -> P3 {
        Self::turn(-self.alpha, n)
    }
    /// (images of x, y, z, origin) of design → mold, for `Solid::place`.
    pub fn to_mold_columns(&self) -> (P3, P3, P3, P3) {
        let o = self.to_mold([0.0; 3]);
        (mesh::sub(self.to_mold([1.0, 0.0, 0.0]), o), mesh::sub(self.to_mold([0.0, 1.0, 0.0]), o), mesh::sub(self.to_mold([0.0, 0.0, 1.0]), o), o)
    }
    pub fn to_design_columns(&self) -> (P3, P3, P3, P3) {
        let o = self.to_design([0.0; 3]);
        (mesh::sub(self.to_design([1.0, 0.0, 0.0]), o), mesh::sub(self.to_design([0.0, 1.0, 0.0]), o), mesh::sub(self.to_design([0.0, 0.0, 1.0]), o), o)
    }
    /// The 3×4 row matrix of design → mold (for the manifest).
    pub fn rows_to_mold(&self) -> [[f64; 4]; 3] {
        let (ex, ey, ez, o) = self.to_mold_columns();
        [[ex[0], ey[0], ez[0], o[0]], [ex[1], ey[1], ez[1], o[1]], [ex[2], ey[2], ez[2], o[2]]]
    }
}

/// Where things are, derived once from the parameters: the shape, seats and domes in the design
/// frame; the parting plane and the cover's end in the mold frame.
#[derive(Debug, Clone)]
pub struct Layout {
    pub shape: Shape,
    pub frame: Frame,
    /// Parting plane height in the mold frame (negative: below the mid-plane).
    pub z_parting: f64,
    /// The cover starts here (toward the mount, design frame) and runs to the tip.
    pub x_start: f64,
    /// The cover's end plane in the mold frame (x of the pad's bottom there).
    pub x_start_m: f64,
    pub seats: Vec<Seat>,
    pub domes: Vec<Dome>,
}

/// One dome cavity on the cover's inner side, over a seat.
#[derive(Debug, Clone)]
pub struct Dome {
    /// Centre of the board's top face = the flat seat plane's centre.
    pub base: P3,
    /// Outward seat normal (away from the fingertip).
    pub normal: P3,
    /// Cavity radius at the board and at its top (its wall is drafted for demolding).
    pub r_base: f64,
    pub r_top: f64,
    pub depth: f64,
    /// The sensor dome's own size.
    pub dome_r: f64,
    /// Angle between the seat normal and the demolding direction (deg).
    pub tilt_deg: f64,
    /// Wall taper of the cavity (deg) = draft + tilt.
    pub taper_deg: f64,
    /// A follow_pad cover's thinnest skin over the dome (mm); a uniform cover's is its thickness.
    pub skin: Option<f64>,
}

pub fn layout(p: &MoldParams) -> std::result::Result<Layout, String> {
    let shape = Shape::new(&p.fingertip.body);
    let x_start0 = p.fingertip.body.length_mm - p.cover.from_tip_mm;
    let frame = Frame { alpha: -p.mold.demolding_tilt_deg.to_radians(), pivot: [(x_start0 + shape.length) / 2.0, 0.0, 0.0] };
    let mut seats = Vec::new();
    let mut domes = Vec::new();
    for (i, s) in p.fingertip.sensors.iter().enumerate() {
        let st = fingertip::seat(&shape, s).map_err(|w| format!("sensor[{i}] {w}"))?;
        let tilt = (-frame.dir_to_mold(st.normal)[2]).clamp(-1.0, 1.0).acos().to_degrees();
        let taper = p.mold.draft_deg + tilt;
        let r_base = (s.dome_diameter_mm + p.cover.dome_clearance_mm) / 2.0;
        let r_top = r_base - s.dome_height_mm * taper.to_radians().tan();
        let skin = match p.cover.profile {
            // the window lies at the nominal thickness over the cavity's top; its slopes only add
            crate::params::mold::CoverProfile::Uniform => None,
            crate::params::mold::CoverProfile::FollowPad => Some(follow_pad_skin(&shape, &st, s, r_base, r_top, p.cover.thickness_mm)),
        };
        domes.push(Dome {
            base: st.flat_center,
            normal: st.normal,
            r_base,
            r_top,
            depth: s.dome_height_mm,
            dome_r: s.dome_diameter_mm / 2.0,
            tilt_deg: tilt,
            taper_deg: taper,
            skin,
        });
        seats.push(st);
    }
    let x_start = x_start0;
    let x_start_m = frame.to_mold([x_start, 0.0, -shape.pad_depth_at(x_start)])[0];
    Ok(Layout { z_parting: -p.mold.parting_below_midplane_mm, x_start, x_start_m, frame, shape, seats, domes })
}

/// A follow_pad cover left over a dome cavity: the pad's surface curves away from the flat seat, so
/// the skin is thinnest toward the cavity's rim, not at its centre.
fn follow_pad_skin(shape: &Shape, st: &fingertip::Seat, s: &crate::params::fingertip::Sensor, r_base: f64, r_top: f64, t: f64) -> f64 {
    let (u, v, _) = mesh::frame(st.normal);
    let mut skin = f64::INFINITY;
    for ri in 0..=10 {
        let r = r_base * ri as f64 / 10.0;
        let height = if r <= r_top { s.dome_height_mm } else { s.dome_height_mm * (r_base - r) / (r_base - r_top).max(1e-9) };
        for k in 0..24 {
            let a = 2.0 * std::f64::consts::PI * k as f64 / 24.0;
            let q = mesh::add(st.flat_center, mesh::add(mesh::scale(u, r * a.cos()), mesh::scale(v, r * a.sin())));
            let depth = if shape.inside(q) { shape.exit_distance(q, st.normal, 20.0) } else { 0.0 };
            skin = skin.min(t + depth - height);
        }
    }
    skin
}

/// The pad point on the y ≥ 0 flank at design x whose `lift` along the normal (0: the pad itself,
/// t: its offset) lands on the parting plane, by bisection over the cross-section angle.
fn at_plane(shape: &Shape, f: &Frame, z_e: f64, x: f64, lift: f64) -> Option<P3> {
    let g = |phi: f64| {
        let q = shape.surface_point(x, phi);
        f.to_mold(mesh::add(q, mesh::scale(shape.normal_at(q), lift)))[2] - z_e
    };
    let (lo, hi) = (-std::f64::consts::FRAC_PI_2, 0.0);
    if g(lo) > 0.0 || g(hi) < 0.0 {
        return None;
    }
    Some(shape.surface_point(x, mesh::bisect(lo, hi, 60, |phi| g(phi) < 0.0)))
}

/// Downward tilt (deg below the plane square to the opening direction) of the exact normal along
/// the cover's edge, on the pad (the core's side) and on the offset surface (the shell's side),
/// minimised over the edge. None when the pad does not reach below the parting plane.
pub fn edge_tilt_deg(shape: &Shape, f: &Frame, z_e: f64, x_start: f64, t: f64) -> Option<f64> {
    let mut worst = f64::INFINITY;
    let mut any = false;
    let n = 200;
    for i in 0..=n {
        let x = x_start + (shape.length - x_start) * i as f64 / n as f64;
        for lift in [0.0, t] {
            if let Some(q) = at_plane(shape, f, z_e, x, lift) {
                let nm = f.dir_to_mold(shape.normal_at(q));
                any = true;
                worst = worst.min((-nm[2]).clamp(-1.0, 1.0).asin().to_degrees());
            }
        }
    }
    any.then_some(worst)
}

/// One point of the cavity's rim at the parting plane (mold frame, plan): the band's mid-line
/// point, its outward normal (away from the pad) and its width there.
#[derive(Debug, Clone, Copy)]
pub struct RimPoint {
    pub mid: [f64; 2],
    pub outward: [f64; 2],
    pub width_mm: f64,
}

/// Mid-line of the cavity's rim at the parting plane (plan points of the mold frame), from the
/// mount end on the −y flank round the tip to the +y flank.
pub fn rim_midline(l: &Layout, t: f64) -> Vec<[f64; 2]> {
    rim_band(l, t).iter().map(|r| r.mid).collect()
}

/// The cavity's rim at the parting plane, point by point, in the order of `rim_midline`. The rim
/// is the band between the pad and its offset; its horizontal width is t / cos(tilt) for the
/// local normal tilt.
pub fn rim_band(l: &Layout, t: f64) -> Vec<RimPoint> {
    let s = &l.shape;
    let f = &l.frame;
    let z = l.z_parting;
    let at = |q: P3| -> RimPoint {
        let qm = f.to_mold(q);
        let nv = f.dir_to_mold(s.normal_at(q));
        let hn = (nv[0] * nv[0] + nv[1] * nv[1]).sqrt();
        let w = t / hn.max(1e-3);
        // the outward direction in plan, a unit vector even where the normal is nearly vertical
        let o = if hn > 1e-12 { [nv[0] / hn, nv[1] / hn] } else { [1.0, 0.0] };
        RimPoint { mid: [qm[0] + o[0] * w / 2.0, qm[1] + o[1] * w / 2.0], outward: o, width_mm: w }
    };
    // the pad's bottom (y = 0) meets the parting plane here: the rim's tip end
    let bottom = |x: f64| f.to_mold([x, 0.0, -s.pad_depth_at(x)])[2] - z;
    let x_tip = if bottom(l.x_start) < 0.0 { mesh::bisect(l.x_start, s.length, 60, |x| bottom(x) < 0.0) } else { l.x_start };
    let n = 120;
    let side: Vec<RimPoint> = (0..n)
        .filter_map(|i| {
            let x = l.x_start + 1.0 + (x_tip - l.x_start - 1.0) * i as f64 / n as f64;
            at_plane(s, f, z, x, 0.0).filter(|q| q[1] > 1e-6).map(at)
        })
        .filter(|r| r.mid[0] > l.x_start_m + 0.5)
        .collect();
    let tip = at([x_tip, 0.0, -s.pad_depth_at(x_tip)]);
    let mirror = |r: &RimPoint| RimPoint { mid: [r.mid[0], -r.mid[1]], outward: [r.outward[0], -r.outward[1]], width_mm: r.width_mm };
    let mut out: Vec<RimPoint> = side.iter().map(mirror).collect();
    out.push(tip);
    out.extend(side.iter().rev().copied());
    out
}

/// The sprue's mouth keeps this clear of the core's plug (mm): its circle lies over the rim and
/// the gate well beside it, wholly over the cavity.
pub const SPRUE_PLUG_CLEARANCE_MM: f64 = 0.2;

/// Sprue axis (plan) and vent axes. The sprue pours at the rim point the file names (the one
/// nearest it) or at the tip; its axis stands outward of that point so that its mouth starts
/// `SPRUE_PLUG_CLEARANCE_MM` outside the plug and reaches past the rim into a gate well cut in the
/// shell (issue 18: the pour cup lies wholly over the cavity). Vents stand on the rim points
/// farthest from the sprue's and from each other (where the last air is pushed).
pub fn openings(p: &MoldParams, l: &Layout) -> ([f64; 2], Vec<[f64; 2]>) {
    let band = rim_band(l, p.cover.thickness_mm);
    let d2 = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
    let at = match p.mold.sprue_xy_mm {
        Some(xy) => *band.iter().min_by(|a, b| d2(a.mid, xy).total_cmp(&d2(b.mid, xy))).expect("rim has points"),
        None => band[band.len() / 2],
    };
    let out = p.mold.sprue_diameter_mm / 2.0 + SPRUE_PLUG_CLEARANCE_MM - at.width_mm / 2.0;
    let sprue = [at.mid[0] + at.outward[0] * out, at.mid[1] + at.outward[1] * out];
    let mut chosen = vec![at.mid];
    let mut vents = Vec::new();
    for _ in 0..p.mold.vent_count {
        let best = band
            .iter()
            .map(|r| (chosen.iter().map(|c| d2(r.mid, *c).sqrt()).fold(f64::INFINITY, f64::min), r.mid))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, q)| q)
            .expect("rim has points");
        chosen.push(best);
        vents.push(best);
    }
    (sprue, vents)
}

/// Whether a point of the parting plane lies inside the cavity's rim (between the pad and its
/// offset, on the covered part of the pad).
pub fn in_rim(l: &Layout, t: f64, xy: [f64; 2]) -> bool {
    let p = l.frame.to_design([xy[0], xy[1], l.z_parting - 1e-3]);
    xy[0] > l.x_start_m && !l.shape.inside(p) && l.shape.offset_distance(p, 0.0) < t
}

/// A problem a rule found: (path, value, message).
type Problem = (String, String, String);

/// Rules that need the fingertip's shape. Returns (path, value, message) for each problem.
pub fn validate(p: &MoldParams) -> Vec<(String, String, String)> {
    let mut out: Vec<Problem> = Vec::new();
    let l = match layout(p) {
        Ok(l) => l,
        Err(e) => {
            out.push(("fingertip".to_string(), p.fingertip_file.clone(), format!("the fingertip's seats cannot be located: {e}")));
            return out;
        }
    };
    cover_rules(p, &l, &mut out);
    let m = &p.mold;
    if p.style == Style::Flat {
        if m.cavities > 1 {
            out.push(("mold.cavities".to_string(), m.cavities.to_string(), "the flat style casts one sheet in a tray: remove `cavities` or use style = \"conforming\"".into()));
        }
        return out;
    }
    if !parting_in_pad_rule(p, &l, &mut out) {
        return out;
    }
    head_recess_rules(p, &l, &mut out);
    cover_end_and_edge_rules(p, &l, &mut out);
    seat_flat_rules(p, &l, &mut out);
    key_and_opening_rules(p, &l, &mut out);
    out
}

/// Cover stage (both styles): the cover is printable detail thick, and each dome cavity fits its
/// flat seat, leaves skin over the dome and is wide enough at its drafted top.
fn cover_rules(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) {
    let mut push = |path: &str, value: String, msg: String| out.push((path.to_string(), value, msg));
    let (c, m) = (&p.cover, &p.mold);
    let t = c.thickness_mm;
    if t < m.min_detail_mm {
        push("cover.thickness_mm", t.to_string(), format!("thinner than printable detail ({} mm, mold.min_detail_mm): the mold's gap could not be printed", m.min_detail_mm));
    }
    for (i, (d, sp)) in l.domes.iter().zip(&p.fingertip.sensors).enumerate() {
        // (a uniform cover keeps the thickness over the dome: the rule above holds it)
        if let Some(skin) = d.skin.filter(|&k| k < m.min_detail_mm) {
            push(
                "cover.thickness_mm",
                t.to_string(),
                format!(
                    "the dome cavity over sensor[{i}] (dome {} mm high, {:.2} mm across on its flat seat) leaves {:.2} mm of cover where it is thinnest, less than {} mm, so it breaks through: use at least {:.2} mm",
                    d.depth,
                    2.0 * d.r_base,
                    skin,
                    m.min_detail_mm,
                    t - skin + m.min_detail_mm
                ),
            );
        }
        if d.r_base > sp.flat_diameter_mm / 2.0 {
            push(
                "cover.dome_clearance_mm",
                c.dome_clearance_mm.to_string(),
                format!(
                    "the dome cavity over sensor[{i}] ({:.2} mm across) is wider than its flat seat ({} mm): use a clearance of at most {:.2} mm",
                    2.0 * d.r_base,
                    sp.flat_diameter_mm,
                    sp.flat_diameter_mm - 2.0 * d.dome_r
                ),
            );
        }
        if d.r_top < d.dome_r {
            let need = 2.0 * (d.dome_r + d.depth * d.taper_deg.to_radians().tan()) - 2.0 * d.dome_r;
            push(
                "cover.dome_clearance_mm",
                c.dome_clearance_mm.to_string(),
                format!(
                    "the dome cavity over sensor[{i}] is drafted {:.1}° (draft {}° + seat tilt {:.1}°), which leaves its top {:.2} mm across, narrower than the {:.1} mm dome: use a clearance of at least {:.2} mm",
                    d.taper_deg,
                    m.draft_deg,
                    d.tilt_deg,
                    2.0 * d.r_top,
                    2.0 * d.dome_r,
                    need
                ),
            );
        }
    }
}

/// Parting stage: the parting plane lies inside the pad. False when it does not (the later
/// conforming rules then do not apply).
fn parting_in_pad_rule(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) -> bool {
    let m = &p.mold;
    let t = p.cover.thickness_mm;
    let pad = l.shape.pad_depth;
    if m.parting_below_midplane_mm >= pad - t.max(m.min_detail_mm) {
        out.push((
            "mold.parting_below_midplane_mm".to_string(),
            m.parting_below_midplane_mm.to_string(),
            format!("the parting plane must lie inside the pad (depth {pad:.2} mm): use less than {:.2} mm", pad - t.max(m.min_detail_mm)),
        ));
        return false;
    }
    true
}

/// Screw stage: the cover must leave the screws' head recesses free: a cover edge across a recess
/// keeps the head from seating (and tears when the screw goes in).
fn head_recess_rules(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) {
    let (c, m) = (&p.cover, &p.mold);
    let s = &l.shape;
    let mount = &p.fingertip.mount;
    let r_recess = if mount.head == crate::params::fingertip::Head::None { mount.hole_diameter_mm / 2.0 } else { mount.head_diameter_mm / 2.0 };
    for (i, h) in mount.holes.iter().enumerate() {
        let (x, z) = (h[0], h[1]);
        let (x_lo, z_lo) = (x + r_recess, z - r_recess);
        if x_lo > l.x_start && z_lo < -m.parting_below_midplane_mm {
            out.push((
                "cover.from_tip_mm".to_string(),
                c.from_tip_mm.to_string(),
                format!(
                    "the cover (from x = {:.2} mm, up to {:.2} mm below the mid-plane) runs over the head recess of the fingertip's hole {i} (Ø{:.2} mm at x = {x}, z = {z}, down to z = {z_lo:.2}): shorten the cover to at most {:.2} mm, raise the hole to z ≥ {:.2} in the fingertip file, or lower mold.parting_below_midplane_mm to ≥ {:.2}",
                    l.x_start,
                    m.parting_below_midplane_mm,
                    2.0 * r_recess,
                    s.length - x_lo,
                    r_recess - m.parting_below_midplane_mm,
                    r_recess - z,
                ),
            ));
        }
    }
}

/// Cover-edge stage: the cover ends far enough from the mount face for the plug, and the pad
/// meets the parting plane steeply enough for the draft and the tessellation.
fn cover_end_and_edge_rules(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) {
    let mut push = |path: &str, value: String, msg: String| out.push((path.to_string(), value, msg));
    let (c, m) = (&p.cover, &p.mold);
    let t = c.thickness_mm;
    let s = &l.shape;
    if l.x_start < m.wall_thickness_mm + 1.0 {
        push(
            "cover.from_tip_mm",
            c.from_tip_mm.to_string(),
            format!(
                "runs too close to the mount face (body {} mm long): the mold's plug needs {} mm beyond the cover's end; use at most {:.1}",
                s.length,
                m.wall_thickness_mm + 1.0,
                s.length - m.wall_thickness_mm - 1.0
            ),
        );
    }
    // a facet of the tessellation leans up to acos(1 − tol/R) from the exact surface's normal
    let facet = (1.0 - m.chordal_tolerance_mm / s.min_curvature_radius()).acos().to_degrees();
    match edge_tilt_deg(s, &l.frame, l.z_parting, l.x_start, t) {
        // (a NaN facet, from a curvature radius under half the tolerance, is refused too)
        Some(tilt) if tilt.is_nan() || facet.is_nan() || tilt + 1e-9 < m.draft_deg + facet => push(
            "mold.parting_below_midplane_mm",
            m.parting_below_midplane_mm.to_string(),
            format!(
                "the pad meets the parting plane at {tilt:.2}° from vertical, less than the draft {}° plus the {facet:.1}° a facet of the {} mm tessellation may lean, so the pieces would catch on the cover: move the parting plane further below the mid-plane",
                m.draft_deg, m.chordal_tolerance_mm
            ),
        ),
        None => push("mold.parting_below_midplane_mm", m.parting_below_midplane_mm.to_string(), "the pad does not reach below the parting plane".into()),
        _ => {}
    }
}

/// Seat stage: every seat's flat region, with the 45° spot face round it, must lie inside the
/// cover, two nozzle widths clear of its end: the end wall would otherwise cut the spot face into
/// a knife edge on the core's plug (or split a sliver off it).
fn seat_flat_rules(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) {
    let mut push = |path: &str, value: String, msg: String| out.push((path.to_string(), value, msg));
    let (c, m) = (&p.cover, &p.mold);
    let clear = crate::checks::min_feature::MIN_FEATURE_MM;
    for (i, (st, sp)) in l.seats.iter().zip(&p.fingertip.sensors).enumerate() {
        let (u, v, _) = mesh::frame(st.normal);
        let rf = sp.flat_diameter_mm / 2.0;
        let (mut xmin, mut zmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..36 {
            let a = 2.0 * std::f64::consts::PI * k as f64 / 36.0;
            let on_rim = |r: f64| l.frame.to_mold(mesh::add(st.flat_center, mesh::add(mesh::scale(u, r * a.cos()), mesh::scale(v, r * a.sin()))));
            // the spot face flares from the rim at 45° and meets the pad within the flat's depth
            xmin = xmin.min(on_rim(rf + st.flat_depth)[0]);
            zmax = zmax.max(on_rim(rf)[2]);
        }
        if xmin < l.x_start_m + clear {
            push(
                "cover.from_tip_mm",
                c.from_tip_mm.to_string(),
                format!(
                    "the cover ends at x = {:.2} mm but sensor[{i}]'s flat seat and its 45° spot face reach x = {xmin:.2} mm (mold frame), less than {clear} mm (two nozzle widths) inside the cover: cover at least {:.1} mm from the tip",
                    l.x_start_m,
                    c.from_tip_mm + (l.x_start_m - xmin) + clear
                ),
            );
        }
        if zmax > l.z_parting - 0.2 {
            push(
                "mold.parting_below_midplane_mm",
                m.parting_below_midplane_mm.to_string(),
                format!("sensor[{i}]'s flat seat rises to z = {zmax:.2} mm, above the parting plane less 0.2 mm: the cover would not wrap it; use at most {:.2}", -zmax - 0.2),
            );
        }
    }
}

/// Keys and openings stage: the key holes stop a wall short of the shell's floor, the vents fit
/// the cavity's rim, and a sprue the file places meets the rim.
fn key_and_opening_rules(p: &MoldParams, l: &Layout, out: &mut Vec<Problem>) {
    let mut push = |path: &str, value: String, msg: String| out.push((path.to_string(), value, msg));
    let m = &p.mold;
    let t = p.cover.thickness_mm;
    let pad = l.shape.pad_depth;
    // keys: the holes must stop a wall short of the shell's floor
    let floor_depth = pad + t - m.parting_below_midplane_mm + m.wall_thickness_mm;
    if m.key_height_mm + m.key_clearance_mm + m.min_wall_mm > floor_depth {
        push(
            "mold.key_height_mm",
            m.key_height_mm.to_string(),
            format!(
                "the key holes ({} mm + {} mm clearance) would leave less than {} mm under them in a shell {floor_depth:.2} mm deep: use at most {:.2}",
                m.key_height_mm,
                m.key_clearance_mm,
                m.min_wall_mm,
                floor_depth - m.key_clearance_mm - m.min_wall_mm
            ),
        );
    }
    if m.vent_diameter_mm > t - 0.1 {
        push("mold.vent_diameter_mm", m.vent_diameter_mm.to_string(), format!("wider than the cavity's rim ({t} mm less 0.1): the vent would not open into the cavity alone"));
    }
    if let Some(xy) = m.sprue_xy_mm {
        if !in_rim(l, t, xy) {
            push(
                "mold.sprue_xy_mm",
                format!("[{}, {}]", xy[0], xy[1]),
                format!("the sprue is outside the cavity: the rim point it names must lie on the cover's rim at the parting plane (x > {:.1}, between the pad and {t} mm outside it; the sprue's axis then stands outward of it); leave it out to pour at the tip", l.x_start),
            );
        }
    }
}

/// PDMS material estimate for a cover volume (mm³).
pub fn material(p: &MoldParams, cover_mm3: f64) -> Value {
    let c = &p.cover;
    let mass = cover_mm3 / 1000.0 * c.density_g_cm3;
    let total = mass * (1.0 + c.waste_margin_percent / 100.0);
    let base = total * c.mix_ratio / (c.mix_ratio + 1.0);
    let agent = total / (c.mix_ratio + 1.0);
    let m = p.mold.material;
    let cure = match m {
        crate::params::mold::Material::Pla => {
            "PLA softens near 55 °C: cure at room temperature (about 48 h at 25 °C) or at most 40 °C (about 24 h); do not use the 65–150 °C schedules"
        }
        _ => "cure at most 65 °C (about 4 h at 65 °C) or 48 h at room temperature; resin molds must be fully post-cured first or they inhibit the PDMS cure",
    };
    json!({
        "cover_volume_mm3": cover_mm3,
        "pdms_density_g_cm3": c.density_g_cm3,
        "pdms_mass_g": mass,
        "waste_margin_percent": c.waste_margin_percent,
        "mix_ratio": format!("{}:1", c.mix_ratio),
        "sylgard_base_g": base,
        "curing_agent_g": agent,
        "youngs_modulus_mpa_estimate": 20.0 / c.mix_ratio,
        "youngs_modulus_note": "estimate: about 20 MPa divided by the base:agent ratio (after Wang et al. 2014); measure your own batch",
        "shrinkage_percent": c.shrinkage_percent,
        "mold_material": m.name(),
        "max_cure_temperature_c": m.max_cure_c(),
        "cure_advice": cure,
        "batch": batch(agent, base + agent, c.mix_ratio),
    })
}

/// A common lab scale's resolution (g) and how far the mix ratio may drift (fraction): the batch
/// advice sizes the pour so that the curing agent is weighed to within this.
pub const SCALE_RESOLUTION_G: f64 = 0.01;
pub const RATIO_TOLERANCE: f64 = 0.05;
/// The smallest pour worth mixing and degassing (g): below it the mix is mostly what sticks to the
/// cup and the stirrer.
pub const MIN_POUR_G: f64 = 5.0;

/// How much to mix so the ratio holds: the curing agent, the smaller part, must be at least
/// resolution / tolerance on the scale (0.2 g on a 0.01 g scale for 5 %), so the smallest sound
/// batch is that times (ratio + 1), and at least MIN_POUR_G; it casts that many covers' worth.
fn batch(agent_g: f64, per_cover_g: f64, ratio: f64) -> Value {
    let min_agent = SCALE_RESOLUTION_G / RATIO_TOLERANCE;
    let min_total = (min_agent * (ratio + 1.0)).max(MIN_POUR_G);
    let covers = (min_total / per_cover_g).ceil().max(1.0);
    json!({
        "scale_resolution_g": SCALE_RESOLUTION_G,
        "ratio_tolerance": RATIO_TOLERANCE,
        "scale_needed_for_one_cover_g": agent_g * RATIO_TOLERANCE,
        "min_batch_g": min_total,
        "covers_per_batch": covers,
    })
}

/// The summary lines a person reads after a build.
pub fn notes(name: &str, mat: &Value) -> Vec<String> {
    let g = |k: &str| mat[k].as_f64().unwrap_or(f64::NAN);
    vec![
        format!(
            "{name}: the cover is {:.0} mm³ = {:.2} g of PDMS; mix {:.2} g Sylgard 184 base with {:.2} g curing agent ({} incl. {:.0} % for waste); Young's modulus about {:.1} MPa (estimate)",
            g("cover_volume_mm3"),
            g("pdms_mass_g"),
            g("sylgard_base_g"),
            g("curing_agent_g"),
            mat["mix_ratio"].as_str().unwrap_or(""),
            g("waste_margin_percent"),
            g("youngs_modulus_mpa_estimate")
        ),
        format!("{name}: {} mold — {}", mat["mold_material"].as_str().unwrap_or(""), mat["cure_advice"].as_str().unwrap_or("")),
        {
            let b = &mat["batch"];
            let f = |k: &str| b[k].as_f64().unwrap_or(f64::NAN);
            format!(
                "{name}: batch: one cover's {:.2} g of curing agent needs a {:.4} g scale to hold the ratio within {:.0} %; on a {} g scale mix at least {:.1} g ({:.2} g of agent) and cast {:.0} covers from it",
                g("curing_agent_g"),
                f("scale_needed_for_one_cover_g"),
                100.0 * f("ratio_tolerance"),
                f("scale_resolution_g"),
                f("min_batch_g"),
                f("min_batch_g") / (1.0 + g("sylgard_base_g") / g("curing_agent_g")),
                f("covers_per_batch")
            )
        },
    ]
}

/// Reads a mold file and the fingertip file it names (relative to `dir`): [`crate::params`]
/// parses and type-checks both, then the fingertip's rules (named on the fingertip file's lines)
/// and, when they hold, the mold's rules are applied.
pub fn load(src: &crate::params::SourceFile, default_name: &str, dir: &std::path::Path) -> crate::error::Result<MoldParams> {
    let p = MoldParams::from_source(src, default_name, dir)?;
    fingertip::rules_on(&p.fingertip, &p.fingertip_src)?;
    let problems: Vec<_> = validate(&p).into_iter().map(|(path, value, msg)| src.problem(&path, value, msg)).collect();
    crate::params::finish(Some(p), problems)
}

/// Builds a mold file's parts.
pub fn build(p: &MoldParams) -> crate::error::Result<MoldBuild> {
    match p.style {
        Style::Conforming => conforming::build(p),
        Style::Flat => flat::build(p),
    }
}
