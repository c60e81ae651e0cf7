//! The conforming two-part mold: core (flange + pad-shaped plug with the sensor domes in place,
//! registration pins, sprue and vents) and shell (the pad's exact offset, key holes), and the
//! cover they cast.

use super::trapped_air::Exit;
use super::{checks, layout, material, notes, openings, Layout, MoldBuild};
use crate::error::{Error, Result};
use crate::fingertip;
use crate::mesh::{scale, segments, sub, Solid, P3};
use crate::params::mold::{CoverProfile, Mold, MoldParams};
use crate::part::{Assembly, AssemblyObject, Part};
use serde_json::{json, Map};

const UP: P3 = [0.0, 0.0, 1.0];
const DOWN: P3 = [0.0, 0.0, -1.0];

/// Everything the checks need, in the assembled frame (design frame; the mold's cavity scaled up
/// by the shrinkage about `scale_center`).
pub struct Assembled {
    pub core: Solid,
    pub shell: Solid,
    /// The cavity = the cover scaled by `k`.
    pub cavity: Solid,
    /// The cover as cast (nominal size, design frame).
    pub cover: Solid,
    /// The fingertip-shaped surface the cover's inner side takes (pad, flats, domes), nominal.
    pub core_surface: Solid,
    pub k: f64,
    pub scale_center: P3,
    pub z_parting: f64,
    /// Top of the core's flange.
    pub z_top: f64,
    pub sprue: ([f64; 2], f64),
    /// The gate well under the sprue: the part of its mouth outside the rim, cut into the shell
    /// `gate_depth` mm below the parting plane (its taper carried on down), so that the mouth lies
    /// wholly over liquid. What it holds is a tab on the cover's edge, trimmed after demolding.
    pub gate: Solid,
    pub gate_depth: f64,
    /// Every vent, open from `from_z` up: the parting plane for a vent over the rim, the pocket's
    /// top for a vent drilled from a pocket in the cavity's ceiling.
    pub vents: Vec<Exit>,
    /// The key holes' clearance volumes (manifest: the checks fill them, as closed pockets).
    pub key_holes: Vec<serde_json::Value>,
    /// Ceiling pockets a straight vent cannot reach (it would cross the cavity): they trap air.
    pub unvented_pockets: Vec<P3>,
    /// Key pins and their holes, in the assembled pose.
    pub pins: Vec<Solid>,
    pub holes: Vec<Solid>,
    pub bounds: (P3, P3),
}

/// The pad with its flat seats and the dome cavities' bosses standing on them (nominal).
fn core_surface(p: &MoldParams, l: &Layout, body: &Solid, tol: f64) -> Solid {
    let flats: Vec<Solid> = l.seats.iter().zip(&p.fingertip.sensors).map(|(st, s)| fingertip::spot_face(st, s, tol)).collect();
    let pad = match Solid::union_all(&flats) {
        Some(f) => body.difference(&f),
        None => body.clone(),
    };
    let mut parts = vec![pad];
    for d in &l.domes {
        let sink = 0.05;
        // a polygon's facets lean less than its circle's cone by cos(pi/n): lean the cone more
        // so every facet keeps the full taper
        let n = segments(d.r_base, tol);
        let tan = d.taper_deg.to_radians().tan() / (std::f64::consts::PI / n as f64).cos();
        parts.push(Solid::cylinder(sub(d.base, scale(d.normal, sink)), d.normal, d.depth + sink, d.r_base + sink * tan, d.r_base - d.depth * tan, n));
    }
    Solid::union_all(&parts).expect("the pad")
}

/// How far the flat window of a uniform cover reaches past the dome cavity's rim (mm).
pub const UNIFORM_MARGIN_MM: f64 = 0.5;
/// How far past a window's edge its 45° slope may run before it meets the pad's offset (mm).
const BLEND_MM: f64 = 6.0;
/// The window's edge slopes down at 45°, or steeper where the pad falls away faster (tan 1, 1.5, 2.5, 4).
const SLOPES_TAN: [f64; 4] = [1.0, 1.5, 2.5, 4.0];
/// A slope must still be inside the offset this far past where it meets it (mm along the window's
/// radius): it enters the pad rather than grazing a flank steeper than itself.
const LAND_PAST_MM: f64 = 0.3;
/// The hull's anchor lies this far under the centre of the board's top face, inside the finger (mm).
const ANCHOR_DEPTH_MM: f64 = 2.0;

/// A uniform cover: over each dome the outer surface is the plane parallel to the seat at the
/// nominal thickness over the dome cavity's top, out to the cavity's rim plus
/// [`UNIFORM_MARGIN_MM`]. Where the pad's offset stands above that plane it is cut down (a cone
/// widening outward at 45°, so the cut keeps its draft); where it falls below, the window's edge
/// slopes down at 45° until it meets the offset, found along each of the window's radii, and the
/// window is the hull of its disc and those landing points (so the blend hugs the pad whatever
/// its shape beyond them).
fn uniform_windows(outer: Solid, l: &Layout, t: f64, tol: f64) -> std::result::Result<Solid, String> {
    let inside = |q: P3, n: P3| outer.contains_along(q, n, 60.0);
    let mut cut = Vec::new();
    let mut blends = vec![outer.clone()];
    for d in &l.domes {
        let n = d.normal;
        let r = d.r_base + UNIFORM_MARGIN_MM;
        let plane = crate::mesh::add(d.base, scale(n, d.depth + t));
        let h_up = 5.0;
        // the cut starts just outside the window's disc, so its polygon cannot clip the disc's rim
        let rc = r + 0.05;
        cut.push(Solid::cylinder(plane, n, h_up, rc, rc + h_up, segments(rc + h_up, tol)));
        let anchor = crate::mesh::sub(d.base, scale(n, ANCHOR_DEPTH_MM));
        let seg = segments(r + BLEND_MM, tol);
        let (u, v, _) = crate::mesh::frame(n);
        let radials: Vec<P3> = (0..seg)
            .map(|k| {
                let a = 2.0 * std::f64::consts::PI * k as f64 / seg as f64;
                crate::mesh::add(scale(u, a.cos()), scale(v, a.sin()))
            })
            .collect();
        // a point `s` mm past the window's edge along `radial`, on a slope of `tan` (depth per mm)
        let on_slope = |radial: P3, s: f64, tan: f64| crate::mesh::add(plane, crate::mesh::sub(scale(radial, r + s), scale(n, s * tan)));
        // where the slope meets the offset along one radius: the first step inside, refined by
        // bisection, and only if the slope then goes on inside (it enters the pad; a slope that
        // grazes a flank steeper than itself would come out again)
        let landing = |radial: P3, tan: f64| -> Option<f64> {
            if inside(on_slope(radial, 0.0, tan), n) {
                return inside(on_slope(radial, LAND_PAST_MM, tan), n).then_some(0.0);
            }
            let step = 0.25;
            let first = (1..=(BLEND_MM / step) as usize).map(|i| i as f64 * step).find(|&x| inside(on_slope(radial, x, tan), n))?;
            // the first point inside: one bisection step past the last one outside
            let hi = crate::mesh::bisect(first - step, first, 10, |x| !inside(on_slope(radial, x, tan), n)) + step / 1024.0;
            inside(on_slope(radial, hi + LAND_PAST_MM, tan), n).then_some(hi)
        };
        // one slope for the whole window: the gentlest (45° first, steeper as over the finger's
        // rounded tip) that enters the pad on every radius within BLEND_MM
        let found = SLOPES_TAN.iter().find_map(|&tan| radials.iter().map(|&q| landing(q, tan)).collect::<Option<Vec<f64>>>().map(|s| (tan, s)));
        let Some((tan, lands)) = found else {
            return Err(format!(
                "the uniform cover's window over the dome at ({:.2}, {:.2}, {:.2}) finds no pad to slope down to within {BLEND_MM} mm: use cover.profile = \"follow_pad\" or a thinner cover",
                d.base[0], d.base[1], d.base[2]
            ));
        };
        let mut pts = Vec::new();
        for (&q, &s) in radials.iter().zip(&lands) {
            pts.push(on_slope(q, 0.0, tan));
            // land a little inside the offset, down the same slope (every face keeps the slope)
            pts.push(on_slope(q, s + 0.1, tan));
        }
        // the hull's underside runs from the landing points to one point under the board, inside
        // the finger: only the window and its slopes stand outside the offset
        pts.push(anchor);
        blends.push(Solid::hull(&pts));
    }
    let Some(cut) = Solid::union_all(&cut) else { return Ok(outer) };
    // cut last: a neighbouring window's blend may not stand over this window either
    Ok(Solid::union_all(&blends).expect("the cover's outer solid").difference(&cut))
}

/// The sprue's radius `above` mm over the parting plane (it widens upward by its taper).
pub fn sprue_radius(m: &crate::params::mold::Mold, above: f64) -> f64 {
    (m.sprue_diameter_mm / 2.0 + above * m.sprue_taper_deg.to_radians().tan()).max(0.05)
}

/// Assembles the conforming mold in the mold frame: the cover cast between the pad's offset and
/// the core's surface, the cavity grown by the shrinkage, the core (flange, plug, pins, sprue and
/// vents) and the shell (key holes), with everything the checks need.
pub fn assemble(p: &MoldParams) -> Result<(Layout, Assembled)> {
    let name = p.name.as_str();
    let l = layout(p).map_err(|e| Error::geometry(name, e))?;
    let (m, c) = (&p.mold, &p.cover);
    let ze = l.z_parting;
    let (outer_d, surface_d) = cover_surfaces(p, &l)?;
    // into the mold's frame (the opening direction is +z there)
    let to_mold = |x: &Solid| {
        if l.frame.alpha == 0.0 {
            x.clone()
        } else {
            let (a, b, c, o) = l.frame.to_mold_columns();
            x.place(a, b, c, o)
        }
    };
    let (outer, surface) = (to_mold(&outer_d), to_mold(&surface_d));
    let xs = l.x_start_m;
    let region = CavityRegion::new(p, &l);
    let (cup, plug, cover) = cast_cover(name, &region, &outer, &surface)?;

    // the mold's cavity is the cover grown by the shrinkage, about a point of the parting plane
    let k = 1.0 + c.shrinkage_percent / 100.0;
    let center = [xs, 0.0, ze];
    let cup_k = cup.scale_about(k, center);
    let plug_k = plug.scale_about(k, center);
    let cavity = cover.scale_about(k, center);
    let (sprue_xy, vent_xy) = openings(p, &l);
    // they were placed on the nominal rim: move them with the cavity's growth
    let grow = |q: [f64; 2]| [center[0] + k * (q[0] - center[0]), center[1] + k * (q[1] - center[1])];
    let (sprue_xy, vent_xy): ([f64; 2], Vec<[f64; 2]>) = (grow(sprue_xy), vent_xy.into_iter().map(grow).collect());
    let fl = flange(m, &cup_k, xs - k * m.wall_thickness_mm, ze, sprue_xy, &vent_xy);
    let (pins, holes, key_holes) = registration_keys(m, &fl, ze);
    let openings_cut = opening_cutters(m, sprue_xy, &vent_xy, ze);
    // a vent from every high point of the cavity's ceiling that is not the rim: the recessed flat
    // round a tilted seat is an upside-down pocket whose highest point traps air (issue 18, item 3)
    let grow_p = |q: P3| [center[0] + k * (q[0] - center[0]), center[1] + k * (q[1] - center[1]), center[2] + k * (q[2] - center[2])];
    let pockets: Vec<P3> = flat_pocket_tops(p, &l).into_iter().map(grow_p).collect();
    let flange = Solid::cuboid([fl.x_lo, -fl.half_y, ze], [fl.x_hi, fl.half_y, fl.z_top]).difference(&Solid::union_all(&openings_cut).expect("sprue"));
    let mut core_parts = vec![flange, plug_k];
    core_parts.extend(pins.iter().cloned());
    let core = Solid::union_all(&core_parts).expect("core");
    let (core, pockets, unvented) = vent_pockets(core, &cavity, &pockets, m, ze, fl.z_top);
    // the shell's hollow: the cup carried on 1 mm above the parting plane, so the shell's top face
    // is cut through, not left coplanar with the cup's rim (which can leave a film over the rim)
    let mut shell_cut = vec![outer.intersection(&region.hull(1.0, 0.0)).scale_about(k, center)];
    shell_cut.extend(holes.iter().cloned());
    // the gate well: the sprue's cone carried on down into the shell, as deep as the cover is thick
    let gate_depth = c.thickness_mm;
    let gate_segs = segments(sprue_radius(m, 0.0), m.chordal_tolerance_mm);
    let gate_cone = |up: f64| Solid::cylinder([sprue_xy[0], sprue_xy[1], ze - gate_depth], UP, gate_depth + up, sprue_radius(m, -gate_depth), sprue_radius(m, up), gate_segs);
    shell_cut.push(gate_cone(1.0));
    let gate = gate_cone(0.0).difference(&cup_k);
    let shell = Solid::cuboid([fl.x_lo, -fl.half_y, fl.z_lo], [fl.x_hi, fl.half_y, ze]).difference(&Solid::union_all(&shell_cut).expect("cup"));
    core.ok(&format!("{name}-core"))?;
    shell.ok(&format!("{name}-shell"))?;
    let cover = if l.frame.alpha == 0.0 {
        cover
    } else {
        let (a, b, c, o) = l.frame.to_design_columns();
        cover.place(a, b, c, o)
    };
    let (rs, rv) = (m.sprue_diameter_mm / 2.0, m.vent_diameter_mm / 2.0);
    let a = Assembled {
        core,
        shell,
        cavity,
        cover,
        core_surface: surface_d,
        k,
        scale_center: center,
        z_parting: ze,
        z_top: fl.z_top,
        sprue: (sprue_xy, rs),
        gate,
        gate_depth,
        vents: vent_xy.iter().map(|v| Exit { xy: *v, r: rv, from_z: ze }).chain(pockets.iter().map(|q| Exit { xy: [q[0], q[1]], r: rv, from_z: q[2] })).collect(),
        key_holes,
        unvented_pockets: unvented,
        pins,
        holes,
        bounds: ([fl.x_lo, -fl.half_y, fl.z_lo], [fl.x_hi, fl.half_y, fl.z_top]),
    };
    Ok((l, a))
}

/// Surface stage: the cover's outer solid (the pad's exact offset, with a uniform cover's
/// windows) and the core's surface (pad, flat seats, dome bosses), nominal, in the design frame.
fn cover_surfaces(p: &MoldParams, l: &Layout) -> Result<(Solid, Solid)> {
    let name = p.name.as_str();
    let tol = p.mold.chordal_tolerance_mm;
    let t = p.cover.thickness_mm;
    let s = &l.shape;
    let body = Solid::from_mesh(&s.body_mesh(tol, name)?, name)?;
    let outer = Solid::from_mesh(&s.offset_mesh(t, tol, name)?, name)?;
    let outer = match p.cover.profile {
        CoverProfile::Uniform => uniform_windows(outer, l, t, tol).map_err(|e| Error::geometry(name, e))?,
        CoverProfile::FollowPad => outer,
    };
    let surface = core_surface(p, l, &body, tol);
    Ok((outer, surface))
}

/// The cavity's region in the mold frame: below the parting plane and beyond the cover's end
/// plane, which leans by the draft (x grows downward) so the shell drops off the cover's end and
/// the core's plug lifts off it; before that plane the shell is solid.
struct CavityRegion {
    /// The cover's end plane at the parting plane (x) and the parting plane (z).
    xs: f64,
    ze: f64,
    /// Half-width, depth and far end of the region: well outside the cover.
    big_y: f64,
    depth: f64,
    far_x: f64,
    /// The end plane's lean (tan of the draft).
    tan: f64,
}

impl CavityRegion {
    /// The region of mold `p` laid out by `l`, well outside its cover.
    fn new(p: &MoldParams, l: &Layout) -> CavityRegion {
        let t = p.cover.thickness_mm;
        CavityRegion {
            xs: l.x_start_m,
            ze: l.z_parting,
            big_y: p.fingertip.body.width_mm + 2.0 * t + 20.0,
            depth: p.fingertip.body.thickness_mm + 2.0 * t + 20.0,
            far_x: l.shape.length + t + 10.0,
            tan: p.mold.draft_deg.to_radians().tan(),
        }
    }

    /// The region as a solid. `up` extends it above the parting plane, `back` behind the end
    /// plane: the plug cut with them overlaps the flange, and the cover is cut with no coplanar
    /// faces.
    fn hull(&self, up: f64, back: f64) -> Solid {
        let (xs, ze, tan) = (self.xs, self.ze, self.tan);
        let mut hull = Vec::new();
        for y in [-self.big_y, self.big_y] {
            for z in [ze + up, ze - self.depth] {
                hull.push([xs - back + tan * (ze - z), y, z]);
                hull.push([self.far_x, y, z]);
            }
        }
        Solid::hull(&hull)
    }
}

/// Cast stage, in the mold frame at nominal size: the cup (the offset solid within the cavity's
/// region), the core's plug, and the cover between them. Returns (cup, plug, cover).
fn cast_cover(name: &str, region: &CavityRegion, outer: &Solid, surface: &Solid) -> Result<(Solid, Solid, Solid)> {
    let cup = outer.intersection(&region.hull(0.0, 0.0));
    // the plug reaches 1 mm into the flange so the two unite robustly; that reach is the plug's own
    // last millimetre lifted (the pad narrows downward, so it stays inside the plug's top face and
    // cannot overhang the rim, the sprue or a vent)
    let plug_below = surface.intersection(&region.hull(0.0, 0.0));
    let slab = Solid::cuboid([-1.0, -region.big_y, region.ze - 1.0], [region.far_x, region.big_y, region.ze]);
    let plug = plug_below.union(&plug_below.intersection(&slab).translate([0.0, 0.0, 1.0]));
    let plug_cut = surface.intersection(&region.hull(1.0, 0.5));
    let (cover, _) = cup.difference(&plug_cut).drop_slivers(1e-6);
    cover.ok(name)?;
    Ok((cup, plug, cover))
}

/// The core's flange and the shell's block in the mold frame: x from `x_lo` to `x_hi`, y within
/// ±`half_y`, z from the shell's floor `z_lo` to the flange's top `z_top`.
struct Flange {
    x_lo: f64,
    x_hi: f64,
    half_y: f64,
    z_lo: f64,
    z_top: f64,
}

/// Flange stage: the block round the grown cup (`cup_k`) from `x_lo`, a wall thick, holding the
/// keys, the sprue (it widens to its top) and the vents with a wall round them.
fn flange(m: &Mold, cup_k: &Solid, x_lo: f64, ze: f64, sprue_xy: [f64; 2], vent_xy: &[[f64; 2]]) -> Flange {
    let (lo, hi) = cup_k.bbox();
    let w = m.wall_thickness_mm;
    let (kr, kc) = (m.key_diameter_mm / 2.0, m.key_clearance_mm);
    // the flange must hold the sprue (it widens to its top) and the vents with a wall round them
    let r_sprue_top = sprue_radius(m, w + 1.0);
    let half_y = (lo[1].abs().max(hi[1].abs()) + 2.0 * w + 2.0 * (kr + kc)).max(sprue_xy[1].abs() + r_sprue_top + m.min_wall_mm);
    let x_hi =
        (hi[0] + w).max(sprue_xy[0] + r_sprue_top + m.min_wall_mm).max(vent_xy.iter().map(|v| v[0] + m.vent_diameter_mm / 2.0 + m.min_wall_mm).fold(f64::NEG_INFINITY, f64::max));
    Flange { x_lo, x_hi, half_y, z_lo: lo[2] - w, z_top: ze + w }
}

/// Key stage: registration keys, tapered pins under the flange, holes in the shell's top face.
/// Returns the pins, the holes and the holes' manifest entries.
fn registration_keys(m: &Mold, fl: &Flange, ze: f64) -> (Vec<Solid>, Vec<Solid>, Vec<serde_json::Value>) {
    let tol = m.chordal_tolerance_mm;
    let w = m.wall_thickness_mm;
    let (kr, kc) = (m.key_diameter_mm / 2.0, m.key_clearance_mm);
    let inset = w + kr + kc;
    let (x_lo_k, x_hi, half_y) = (fl.x_lo, fl.x_hi, fl.half_y);
    let corners = [[x_lo_k + inset, -half_y + inset], [x_hi - inset, half_y - inset], [x_lo_k + inset, half_y - inset], [x_hi - inset, -half_y + inset]];
    let dtan = m.draft_deg.to_radians().tan();
    let (h, lift) = (m.key_height_mm, 0.5);
    let mut pins = Vec::new();
    let mut holes = Vec::new();
    let mut key_holes = Vec::new();
    for kxy in corners.iter().take(m.key_count) {
        let top = [kxy[0], kxy[1], ze + lift];
        key_holes.push(json!({"top": top, "depth_mm": lift + h + kc, "r_top_mm": kr + kc + lift * dtan, "r_bottom_mm": kr + kc - (h + kc) * dtan}));
        pins.push(Solid::cylinder(top, DOWN, lift + h, kr + lift * dtan, kr - h * dtan, segments(kr + kc, tol)));
        holes.push(Solid::cylinder(top, DOWN, lift + h + kc, kr + kc + lift * dtan, kr + kc - (h + kc) * dtan, segments(kr + kc, tol)));
    }
    (pins, holes, key_holes)
}

/// Opening stage: the cutters of the sprue (widening upward) and the vents through the flange.
fn opening_cutters(m: &Mold, sprue_xy: [f64; 2], vent_xy: &[[f64; 2]], ze: f64) -> Vec<Solid> {
    let tol = m.chordal_tolerance_mm;
    let w = m.wall_thickness_mm;
    let r_sprue_top = sprue_radius(m, w + 1.0);
    let mut openings_cut = vec![Solid::cylinder([sprue_xy[0], sprue_xy[1], ze - 1.0], UP, w + 2.0, sprue_radius(m, -1.0), r_sprue_top, segments(sprue_radius(m, w), tol))];
    let rv = m.vent_diameter_mm / 2.0;
    for v in vent_xy {
        openings_cut.push(Solid::cylinder([v[0], v[1], ze - 1.0], UP, w + 2.0, rv, rv, segments(rv, tol)));
    }
    openings_cut
}

/// Pocket-vent stage: each ceiling pocket (its top, mold frame, grown) gets a vent straight up
/// through the core, unless that would cross the cavity again or cut a second hole (into the
/// ridge between two flats, say): such a pocket is reported. Returns the core and the pockets
/// vented and not.
fn vent_pockets(mut core: Solid, cavity: &Solid, pockets: &[P3], m: &Mold, ze: f64, z_top: f64) -> (Solid, Vec<P3>, Vec<P3>) {
    let tol = m.chordal_tolerance_mm;
    let rv = m.vent_diameter_mm / 2.0;
    let mut vented = Vec::new();
    let mut unvented = Vec::new();
    for q in pockets {
        // only a vent at the very top lets the pocket's air out (one further in starts below it)
        let clear = [[0.0, 0.0], [rv, 0.0], [-rv, 0.0], [0.0, rv], [0.0, -rv]]
            .iter()
            .all(|o| cavity.ray_hits([q[0] + o[0], q[1] + o[1], q[2] + 0.05], [q[0] + o[0], q[1] + o[1], ze + 0.01]).is_empty());
        let from = q[2] - 0.3;
        let cut = clear.then(|| core.difference(&Solid::cylinder([q[0], q[1], from], UP, z_top + 1.0 - from, rv, rv, segments(rv, tol))));
        match cut {
            Some(cut) if cut.genus() == core.genus() + 1 && cut.bodies() == 1 => {
                core = cut;
                vented.push(*q);
            }
            _ => unvented.push(*q),
        }
    }
    (core, vented, unvented)
}

/// The highest point, in the pour orientation (+z of the mold frame), of every tilted recessed flat
/// (nominal size, mold frame). The flat is cut into the core's plug, so seen from the cavity below
/// it is a pocket in the ceiling; a level flat has no single high point and needs no vent (air
/// leaves it sideways, where the pad rises to the flanks).
pub fn flat_pocket_tops(p: &MoldParams, l: &Layout) -> Vec<P3> {
    let up = [0.0, 0.0, 1.0];
    let mut out = Vec::new();
    for (d, s) in l.domes.iter().zip(&p.fingertip.sensors) {
        let n = l.frame.dir_to_mold(d.normal);
        let along = sub(up, scale(n, crate::mesh::dot(up, n)));
        let len = crate::mesh::norm(along);
        // a flat tilted so little that its rim rises less than 0.01 mm traps nothing to speak of
        if len * s.flat_diameter_mm / 2.0 < 0.01 {
            continue;
        }
        let c = l.frame.to_mold(d.base);
        out.push(crate::mesh::add(c, scale(along, s.flat_diameter_mm / 2.0 / len)));
    }
    out
}

impl Assembled {
    /// The top of the ceiling pocket a vent was drilled from, if it was (not over the rim).
    pub fn pocket_top(&self, v: &Exit) -> Option<f64> {
        (v.from_z < self.z_parting).then_some(v.from_z)
    }
    /// The tops of the ceiling pockets that got a vent (mold frame, grown by the shrinkage).
    pub fn pocket_vents(&self) -> Vec<P3> {
        self.vents.iter().filter_map(|v| self.pocket_top(v).map(|z| [v.xy[0], v.xy[1], z])).collect()
    }
}

/// What one pour of this mold casts, against the smallest sound batch (`mold::batch`): the
/// number of cavities that pours a whole batch at once.
fn pour_note(name: &str, n: usize, fits: usize, mat: &serde_json::Value) -> String {
    let g = |k: &str| mat[k].as_f64().unwrap_or(f64::NAN);
    let mixed = g("sylgard_base_g") + g("curing_agent_g");
    let batch = mat["batch"]["covers_per_batch"].as_f64().unwrap_or(1.0) as usize;
    let pour = format!(
        "{name}: {n} cavit{} cast{} {n} cover{} per pour ({:.2} g mixed)",
        if n == 1 { "y" } else { "ies" },
        if n == 1 { "s" } else { "" },
        if n == 1 { "" } else { "s" },
        n as f64 * mixed
    );
    if n >= batch {
        format!("{pour}: a sound batch in one pour")
    } else if batch <= fits {
        format!("{pour}; a sound batch casts {batch}: set mold.cavities = {batch} to pour it at once ({:.2} g)", batch as f64 * mixed)
    } else {
        format!(
            "{pour}; a sound batch casts {batch}, but at most {fits} cavities fit the bed: set mold.cavities = {fits} and pour the batch into {} molds",
            batch.div_ceil(fits.max(1))
        )
    }
}

/// How many cavities fit side by side on the print profile's bed (the row along its longer side,
/// the mold's length across the shorter), and the row's length for n.
fn cavities_fit(a: &Assembled, pitch: f64) -> (usize, impl Fn(usize) -> f64) {
    let width = a.bounds.1[1] - a.bounds.0[1];
    let length = a.bounds.1[0] - a.bounds.0[0];
    let [long, short] = crate::slicer::PROFILE_BED_MM;
    let need = move |n: usize| width + pitch * (n as f64 - 1.0);
    let fits = if length > short { 0 } else { (1..=64).take_while(|&n| need(n) <= long).last().unwrap_or(0) };
    (fits, need)
}

/// Adjacent cavities' flanges overlap by this (mm), so the pieces unite into one body each.
pub const CAVITY_OVERLAP_MM: f64 = 1.0;

/// Builds a conforming mold file: assembles and checks the mold, then lays out the printed pieces
/// (as many cavities as asked, side by side), the cast cover, the assembly view, the manifest
/// entry and the summary's lines.
pub fn build(p: &MoldParams) -> Result<MoldBuild> {
    let name = p.name.as_str();
    let (l, a) = assemble(p)?;
    let (violations, measured) = checks::conforming(p, &l, &a);
    let z_lo = a.bounds.0[2];
    // print poses: the shell as it stands (cavity up); the core flange-down (plug and pins up);
    // the cover in the fingertip's print frame, so it overlays fingertip STL
    let shell_print = a.shell.translate([0.0, 0.0, -z_lo]);
    let core_print = a.core.place([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [0.0, 0.0, a.z_top]);
    let cover_print = a.cover.place([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0; 3]);
    // several cavities: copies side by side along y, their flanges overlapping by 1 mm so that each
    // piece stays one body (the assembly view and the assembled-mold checks are one cavity's)
    let n = p.mold.cavities;
    let pitch = a.bounds.1[1] - a.bounds.0[1] - CAVITY_OVERLAP_MM;
    // the row of cavities must fit the print profile's bed, along its longer side
    let (fits, need) = cavities_fit(&a, pitch);
    if n > fits {
        return Err(Error::geometry(
            name,
            format!(
                "mold.cavities = {n}: {n} cavities side by side take {:.0} × {:.0} mm, more than the {} × {} mm bed of the print profile: use at most {fits}",
                need(n),
                a.bounds.1[0] - a.bounds.0[0],
                crate::slicer::PROFILE_BED_MM[0],
                crate::slicer::PROFILE_BED_MM[1]
            ),
        ));
    }
    let side_by_side = |one: &Solid| -> Solid {
        if n == 1 {
            return one.clone();
        }
        let copies: Vec<Solid> = (0..n).map(|i| one.translate([0.0, pitch * (i as f64 - (n - 1) as f64 / 2.0), 0.0])).collect();
        Solid::union_all(&copies).expect("at least one cavity")
    };
    let (shell_print, core_print) = (side_by_side(&shell_print), side_by_side(&core_print));
    let cover_name = p.cover_name();
    let mat = material(p, a.cover.volume());
    // to_assembled: rows of a 3×4 matrix [R | t] mapping the print pose back to the assembly
    let core = mold_piece(p, core_print, "core", (n * (1 + a.vents.len())) as i32, json!([[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, a.z_top]]));
    let shell = mold_piece(p, shell_print, "shell", 0, json!([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, z_lo]]));
    let cover = cover_part(p, &l, &a, cover_print);
    let exploded = a.core.translate([0.0, 0.0, 25.0]);
    let assembly = Assembly {
        name: format!("{name}-assembly"),
        parts: vec![
            AssemblyObject::part(format!("{name}-shell"), a.shell.to_mesh()),
            AssemblyObject::reference(format!("{cover_name} cavity (reference)"), a.cavity.to_mesh()),
            AssemblyObject::reference(format!("{name}-core (reference, lifted 25 mm)"), exploded.to_mesh()),
        ],
    };
    let mut manifest = Map::new();
    let over_domes = measured["cover_over_sensing_area_mm"].clone();
    let entry = manifest_entry(p, &l, &a, measured, [&core.name, &shell.name], &mat, pitch);
    manifest.insert(name.to_string(), serde_json::Value::Object(entry));
    let notes = summary_notes(p, &a, &mat, fits, &over_domes);
    Ok(MoldBuild { parts: vec![core, shell, cover], assemblies: vec![assembly], violations, manifest, notes })
}

/// A printed piece of the mold (`suffix`: core or shell) in its print pose; `to_assembled` maps
/// that pose back to the assembly.
fn mold_piece(p: &MoldParams, solid: Solid, suffix: &str, genus: i32, to_assembled: serde_json::Value) -> Part {
    let name = p.name.as_str();
    Part {
        name: format!("{name}-{suffix}"),
        mesh: solid.to_mesh(),
        solid,
        expected_genus: genus,
        density_g_cm3: p.mold.density_g_cm3,
        process: crate::part::Process::Printed,
        supports: if suffix == "core" { Some("flat ceilings of the sprue and vent openings at the tip end, 2-3 mm above the bed") } else { None },
        infill: 1.0,
        write_3mf: true,
        features: json!({
            "kind": format!("mold-{suffix}"),
            "mold": name,
            "to_assembled": to_assembled,
            "min_wall_mm": p.mold.min_wall_mm,
            "chordal_tolerance_mm": p.mold.chordal_tolerance_mm,
        }),
        extra: Default::default(),
    }
}

/// The cast cover as a part, in the fingertip's print frame (`cover_print`), with its domes.
fn cover_part(p: &MoldParams, l: &Layout, a: &Assembled, cover_print: Solid) -> Part {
    let domes: Vec<serde_json::Value> = l
        .domes
        .iter()
        .map(|d| {
            json!({
                "base": fingertip::to_print(d.base),
                "normal": fingertip::to_print(d.normal),
                "cavity_base_diameter_mm": 2.0 * d.r_base,
                "cavity_top_diameter_mm": 2.0 * d.r_top,
                "depth_mm": d.depth,
                "dome_diameter_mm": 2.0 * d.dome_r,
                "skin_mm": d.skin,
            })
        })
        .collect();
    Part {
        name: p.cover_name(),
        mesh: cover_print.to_mesh(),
        solid: cover_print,
        expected_genus: 0,
        density_g_cm3: p.cover.density_g_cm3,
        process: crate::part::Process::Cast,
        supports: None,
        infill: 1.0,
        write_3mf: false,
        features: json!({
            "kind": "cover",
            "mold": p.name,
            "fingertip": p.fingertip.name,
            "frame": "the fingertip's print frame: the cover sits on fingertip STL as exported",
            "thickness_mm": p.cover.thickness_mm,
            "domes": domes,
            "shrinkage_scale": a.k,
        }),
        extra: Default::default(),
    }
}

/// The mold's `molds` manifest entry: what it is made of, the checks' measurements, and what an
/// independent check needs to reassemble it from the written files.
fn manifest_entry(
    p: &MoldParams,
    l: &Layout,
    a: &Assembled,
    measured: serde_json::Value,
    pieces: [&str; 2],
    mat: &serde_json::Value,
    pitch: f64,
) -> Map<String, serde_json::Value> {
    let name = p.name.as_str();
    let n = p.mold.cavities;
    let mut entry = Map::new();
    entry.insert("style".into(), json!("conforming"));
    entry.insert("fingertip".into(), json!(p.fingertip_file));
    entry.insert("pieces".into(), json!(pieces));
    entry.insert("cover".into(), json!(p.cover_name()));
    entry.insert("material".into(), mat.clone());
    entry.insert(
        "demolding".into(),
        json!(format!(
            "the core lifts along +z of the mold frame (the pad normal tilted {}° toward the tip), the shell drops along -z; parting plane square to it at the cover's edge",
            p.mold.demolding_tilt_deg
        )),
    );
    entry.insert("parting_plane_z_mm".into(), json!(a.z_parting));
    entry.insert("checks".into(), measured);
    entry.insert("assembly".into(), json!(format!("{name}-assembly.3mf")));
    // what an independent check needs to reassemble the mold from the written files
    entry.insert("frames".into(), frames(l, a));
    entry.insert("fingertip_part".into(), json!(p.fingertip.name));
    entry.insert("parting_z_mm".into(), json!(a.z_parting));
    entry.insert("flange_top_z_mm".into(), json!(a.z_top));
    entry.insert("key_clearance_mm".into(), json!(p.mold.key_clearance_mm));
    entry.insert("key_holes".into(), json!(a.key_holes));
    entry.insert("draft_deg".into(), json!(p.mold.draft_deg));
    entry.insert(
        "openings".into(),
        json!(std::iter::once(json!({"xy": a.sprue.0, "radius_mm": a.sprue.1, "gate_well": {"depth_mm": a.gate_depth, "volume_mm3": a.gate.volume(), "radius_bottom_mm": sprue_radius(&p.mold, -a.gate_depth), "why": "the sprue's mouth lies wholly over liquid: the rim and this well in the shell beside it (a tab on the cover's edge, trimmed)"}}))
            .chain(a.vents.iter().map(|v| match a.pocket_top(v) {
                // a vent from a pocket in the cavity's ceiling starts at the pocket's top
                Some(z) => json!({"xy": v.xy, "radius_mm": v.r, "from_z_mm": z, "why": "the top of the recessed flat round a tilted seat, a pocket in the ceiling that traps air"}),
                None => json!({"xy": v.xy, "radius_mm": v.r}),
            }))
            .collect::<Vec<_>>()),
    );
    entry.insert("pour_up".into(), json!([0.0, 0.0, 1.0]));
    entry.insert("unvented_pockets".into(), json!(a.unvented_pockets));
    let fm = |q: P3| l.frame.to_mold(q);
    let fd = |n: P3| l.frame.dir_to_mold(n);
    entry.insert(
        "domes_assembled".into(),
        json!(l
            .domes
            .iter()
            .map(|d| json!({"base": fm(d.base), "normal": fd(d.normal), "dome_diameter_mm": 2.0 * d.dome_r, "dome_height_mm": d.depth, "cavity_radius_mm": d.r_base}))
            .collect::<Vec<_>>()),
    );
    entry.insert(
        "seats_assembled".into(),
        json!(l
            .seats
            .iter()
            .zip(&p.fingertip.sensors)
            .map(|(st, s)| {
                // the channel's path on the pad, seen from the opening direction
                let path: Vec<[f64; 2]> = fingertip::channel_path(&l.shape, s)
                    .iter()
                    .map(|q| {
                        let m = fm([q[0], q[1], l.shape.z_pad(q[0].max(1e-9), q[1]).unwrap_or(0.0)]);
                        [m[0], m[1]]
                    })
                    .collect();
                json!({"center": fm(st.flat_center), "normal": fd(st.normal), "seat_diameter_mm": s.seat_diameter_mm, "channel_width_mm": s.channel_width_mm, "channel_depth_mm": s.channel_depth_mm, "channel_path_xy": path})
            })
            .collect::<Vec<_>>()),
    );
    entry.insert("cover_thickness_mm".into(), json!(p.cover.thickness_mm));
    entry.insert("cavities".into(), json!(n));
    entry.insert("cavity_pitch_mm".into(), json!(if n > 1 { pitch } else { 0.0 }));
    entry.insert("chordal_tolerance_mm".into(), json!(p.mold.chordal_tolerance_mm));
    entry
}

/// The manifest's `frames`: each written piece's print pose, and the design frame, mapped to the
/// assembled mold.
fn frames(l: &Layout, a: &Assembled) -> serde_json::Value {
    let z_lo = a.bounds.0[2];
    // the fingertip's print frame (y, z, x of the design frame) → design → the mold's frame
    let dm = l.frame.rows_to_mold();
    let p2d = [[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]];
    let mut print_to_mold = [[0.0; 4]; 3];
    for r in 0..3 {
        for col in 0..4 {
            let mut v: f64 = (0..3).map(|k| dm[r][k] * p2d[k][col]).sum();
            if col == 3 {
                v += dm[r][3];
            }
            print_to_mold[r][col] = v;
        }
    }
    json!({
        "core_print_to_assembled": [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, a.z_top]],
        "shell_print_to_assembled": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, z_lo]],
        "cover_print_to_assembled": print_to_mold,
        "fingertip_print_to_assembled": print_to_mold,
        "design_to_assembled": l.frame.rows_to_mold(),
        "cavity_scale": a.k,
        "cavity_scale_center": a.scale_center,
    })
}

/// The summary's lines: material, pours, the cover over each sensing area (`over_domes`, from the
/// checks) and a warning for each pocket no vent reaches.
fn summary_notes(p: &MoldParams, a: &Assembled, mat: &serde_json::Value, fits: usize, over_domes: &serde_json::Value) -> Vec<String> {
    let name = p.name.as_str();
    let mut notes = notes(name, mat);
    notes.push(pour_note(name, p.mold.cavities, fits, mat));
    for (i, c) in over_domes.as_array().into_iter().flatten().enumerate() {
        let f = |k: &str| c[k].as_f64().unwrap_or(f64::NAN);
        let profile = match p.cover.profile {
            CoverProfile::Uniform => format!(
                "profile \"uniform\": a flat window parallel to the seat reaching {UNIFORM_MARGIN_MM} mm past the dome cavity, sloping down to the pad's offset at 45° (steeper where the pad falls away); held to ±{:.0} %",
                checks::UNIFORM_TOLERANCE * 100.0
            ),
            CoverProfile::FollowPad => "profile \"follow_pad\": the outer surface follows the finger's pad, so the flat's recess adds and the pad's curvature takes away".to_string(),
        };
        notes.push(format!(
            "{name}: cover over sensor[{i}]'s sensing area: {:.2} mm at its centre, {:.2}-{:.2} mm over it (nominal {} mm; {profile})",
            f("centre_mm"),
            f("min_mm"),
            f("max_mm"),
            p.cover.thickness_mm
        ));
    }
    for q in &a.unvented_pockets {
        notes.push(format!("{name}: WARNING: the cavity's ceiling has a pocket at ({:.2}, {:.2}, {:.2}) (mold frame) that no straight vent reaches: it will trap air beside the dome; tilt the seat or the demolding direction", q[0], q[1], q[2]));
    }
    notes
}
