//! The analytic fingertip body: the exact surfaces that truck models and the validation reads.

use crate::error::Result;
use crate::interp::Monotone;
use crate::mesh::{self, Mesh, P3};
use crate::params::fingertip::{Body, Form};
use truck_modeling::{builder, Matrix4, Point3, Rad, Solid as TSolid, Vector3, Wire};

/// The body: at every x a cross-section of two half-ellipses sharing the half-width `hw(x)`, the
/// pad's of depth `pd(x)` below the mid-plane and the nail side's of height `dh(x)` above. Each is
/// a base radius g(x) (1 along the finger, closing to 0 at the tip) times a scale: hw = wh·g,
/// pd = zp·g, dh = zd·g. The surface is G = u² + v² − g² = 0 with u = y/wh, v = z/(zp or zd).
#[derive(Debug, Clone)]
pub struct Shape {
    pub length: f64,
    /// Deepest pad below the mid-plane.
    pub pad_depth: f64,
    /// Highest nail side above the mid-plane.
    pub dorsal_height: f64,
    prof: Profile,
}

#[derive(Debug, Clone)]
enum Profile {
    /// Side profile r(x) in pad units (r(0) = pad depth); scales constant.
    Capsule {
        lateral: f64,
        zd: f64,
        r_long: f64,
        r_tip: f64,
        /// End of the straight run.
        x1: f64,
        c1: (f64, f64),
        c2: (f64, f64),
        /// Tangent point between the pad arc and the tip arc.
        tp: (f64, f64),
    },
    /// g = 1 to x_cap, then a quarter ellipse of length `cap`; scales through the stations.
    Stations { x_cap: f64, cap: f64, wh: Monotone, zp: Monotone, zd: Monotone },
}

impl Shape {
    pub fn new(b: &Body) -> Shape {
        let l = b.length_mm;
        match &b.form {
            Form::Capsule { pad_longitudinal_radius_mm: rl, pad_transverse_radius_mm: rtr, tip_radius_mm: rt } => {
                let (rl, rt) = (*rl, *rt);
                let pad_depth = (b.width_mm / 2.0).powi(2) / rtr;
                let c2 = (l - rt, 0.0);
                let x1 = l - rt - ((rl - rt).powi(2) - (rl - pad_depth).powi(2)).max(0.0).sqrt();
                let c1 = (x1, pad_depth - rl);
                let d = (c2.0 - c1.0, c2.1 - c1.1);
                let dn = (d.0 * d.0 + d.1 * d.1).sqrt();
                let tp = (c1.0 + d.0 / dn * rl, c1.1 + d.1 / dn * rl);
                let dorsal = b.thickness_mm - pad_depth;
                let prof = Profile::Capsule { lateral: b.width_mm / 2.0 / pad_depth, zd: dorsal / pad_depth, r_long: rl, r_tip: rt, x1, c1, c2, tp };
                Shape { length: l, pad_depth, dorsal_height: dorsal, prof }
            }
            Form::Stations { tip_length_mm, stations } => {
                let at: Vec<f64> = stations.iter().map(|s| l - s.from_tip_mm).collect();
                let f = |g: &dyn Fn(&crate::params::fingertip::Station) -> f64| Monotone::new(&at, &stations.iter().map(g).collect::<Vec<_>>());
                let prof =
                    Profile::Stations { x_cap: l - tip_length_mm, cap: *tip_length_mm, wh: f(&|s| s.width_mm / 2.0), zp: f(&|s| s.pad_depth_mm), zd: f(&|s| s.nail_height_mm) };
                let (_, pad_depth, dorsal) = crate::params::fingertip::envelope(stations, l, *tip_length_mm);
                Shape { length: l, pad_depth, dorsal_height: dorsal, prof }
            }
        }
    }

    /// Whether the body is lofted through stations (else the capsule form).
    pub fn is_anatomical(&self) -> bool {
        matches!(self.prof, Profile::Stations { .. })
    }

    /// Where the rounded end begins: the scales are constant beyond it.
    fn cap_start(&self) -> f64 {
        match &self.prof {
            Profile::Capsule { tp, .. } => tp.0,
            Profile::Stations { x_cap, .. } => *x_cap,
        }
    }

    /// Base radius g(x) (0 outside [0, length]).
    fn g(&self, x: f64) -> f64 {
        if !(0.0..=self.length).contains(&x) {
            return 0.0;
        }
        match &self.prof {
            Profile::Capsule { r_long, r_tip, x1, c1, c2, tp, .. } => {
                if x <= *x1 {
                    self.pad_depth
                } else if x <= tp.0 {
                    c1.1 + (r_long.powi(2) - (x - c1.0).powi(2)).max(0.0).sqrt()
                } else {
                    (r_tip.powi(2) - (x - c2.0).powi(2)).max(0.0).sqrt()
                }
            }
            Profile::Stations { x_cap, cap, .. } => {
                if x <= *x_cap {
                    1.0
                } else {
                    (1.0 - ((x - x_cap) / cap).powi(2)).max(0.0).sqrt()
                }
            }
        }
    }

    /// g·g′ (finite at the apex, where g′ is not).
    fn gg(&self, x: f64) -> f64 {
        match &self.prof {
            Profile::Capsule { r_long, x1, c1, c2, tp, .. } => {
                if x <= *x1 {
                    0.0
                } else if x <= tp.0 {
                    let q = (r_long.powi(2) - (x - c1.0).powi(2)).max(1e-300).sqrt();
                    -(c1.1 + q) * (x - c1.0) / q
                } else {
                    -(x - c2.0)
                }
            }
            Profile::Stations { x_cap, cap, .. } => {
                if x <= *x_cap {
                    0.0
                } else {
                    -(x - x_cap) / (cap * cap)
                }
            }
        }
    }

    /// Scales (wh, zp, zd) at x and their slopes.
    fn scales(&self, x: f64) -> ([f64; 3], [f64; 3]) {
        match &self.prof {
            Profile::Capsule { lateral, zd, .. } => ([*lateral, 1.0, *zd], [0.0; 3]),
            Profile::Stations { wh, zp, zd, .. } => ([wh.at(x), zp.at(x), zd.at(x)], [wh.slope(x), zp.slope(x), zd.slope(x)]),
        }
    }

    /// Pad depth below the mid-plane at x (0 outside the body).
    pub fn pad_depth_at(&self, x: f64) -> f64 {
        self.scales(x).0[1] * self.g(x)
    }

    /// Nail-side height above the mid-plane at x.
    pub fn dorsal_height_at(&self, x: f64) -> f64 {
        self.scales(x).0[2] * self.g(x)
    }

    /// (u, v, g) of a point: its section coordinates scaled to the base radius.
    fn uvg(&self, p: P3) -> (f64, f64, f64) {
        let ([wh, zp, zd], _) = self.scales(p[0]);
        (p[1] / wh, p[2] / if p[2] >= 0.0 { zd } else { zp }, self.g(p[0]))
    }

    /// Whether a point is inside the body (ignoring features).
    pub fn inside(&self, p: P3) -> bool {
        if p[0] <= 0.0 || p[0] > self.length {
            return false;
        }
        let (u, v, g) = self.uvg(p);
        g > 0.0 && u * u + v * v < g * g
    }

    /// Half-width of the body at x.
    pub fn half_width(&self, x: f64) -> f64 {
        self.scales(x).0[0] * self.g(x)
    }

    /// Pad surface height (negative) at (x, y), if the point is over the body.
    pub fn z_pad(&self, x: f64, y: f64) -> Option<f64> {
        let hw = self.half_width(x);
        let q = 1.0 - (y / hw).powi(2);
        (hw > 0.0 && q >= 0.0).then(|| -self.pad_depth_at(x) * q.sqrt())
    }

    /// Dorsal surface height at (x, y).
    pub fn z_dorsal(&self, x: f64, y: f64) -> Option<f64> {
        let hw = self.half_width(x);
        let q = 1.0 - (y / hw).powi(2);
        (hw > 0.0 && q >= 0.0).then(|| self.dorsal_height_at(x) * q.sqrt())
    }

    /// |y| of the flank at (x, z).
    pub fn flank_y(&self, x: f64, z: f64) -> Option<f64> {
        let zh = if z >= 0.0 { self.dorsal_height_at(x) } else { self.pad_depth_at(x) };
        let q = 1.0 - (z / zh).powi(2);
        (zh > 0.0 && q >= 0.0).then(|| self.half_width(x) * q.sqrt())
    }

    /// Outward unit normal of the pad surface at (x, y).
    pub fn pad_normal(&self, x: f64, y: f64) -> Option<P3> {
        let z = self.z_pad(x, y)?;
        Some(self.normal_at([x, y, z]))
    }

    /// Distance travelled from `p` along unit `dir` until leaving the body (p must be inside).
    pub fn exit_distance(&self, p: P3, dir: P3, max: f64) -> f64 {
        let step = 0.01;
        let mut t = 0.0;
        while t < max {
            if !self.inside(mesh::add(p, mesh::scale(dir, t + step))) {
                return mesh::bisect(t, t + step, 30, |d| self.inside(mesh::add(p, mesh::scale(dir, d))));
            }
            t += step;
        }
        max
    }

    /// Cross-section outline at x as (y, z) points.
    pub fn outline(&self, x: f64, n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let p = self.surface_point(x, 2.0 * std::f64::consts::PI * i as f64 / n as f64);
                [p[1], p[2]]
            })
            .collect()
    }

    /// Exact outward unit normal of the body's side surface at a surface point `p` (from the
    /// exact sections, not from a mesh): the gradient of G = u² + v² − g².
    pub fn normal_at(&self, p: P3) -> P3 {
        let x = p[0];
        let (u, v, _) = self.uvg(p);
        if u * u + v * v < 1e-24 {
            return if x > self.length / 2.0 { [1.0, 0.0, 0.0] } else { [-1.0, 0.0, 0.0] };
        }
        let ([wh, zp, zd], [dwh, dzp, dzd]) = self.scales(x);
        let (zs, dzs) = if p[2] >= 0.0 { (zd, dzd) } else { (zp, dzp) };
        let gx = -u * u * dwh / wh - v * v * dzs / zs - self.gg(x);
        mesh::unit([gx, u / wh, v / zs])
    }

    /// Surface point at parameters (x, phi): phi = 0 lateral (+y), -pi/2 the pad bottom.
    pub fn surface_point(&self, x: f64, phi: f64) -> P3 {
        let (s, c) = phi.sin_cos();
        let zh = if s >= 0.0 { self.dorsal_height_at(x) } else { self.pad_depth_at(x) };
        [x, self.half_width(x) * c, zh * s]
    }

    /// The body offset outward by `t` (the exact offset surface, regenerated): every vertex of the
    /// body's tessellation lies on the exact surface and is moved by `t` along the exact normal
    /// there. Mount-face vertices stay in the face plane, scaled with its moved rim. `tol` is the
    /// chordal tolerance wanted on the offset; the body is tessellated finer by the ratio of the
    /// smallest curvature radius to that radius plus `t`, since offsetting outward flattens chords
    /// by that ratio at most.
    pub fn offset_mesh(&self, t: f64, tol: f64, what: &str) -> Result<Mesh> {
        let r_min = self.min_curvature_radius();
        let base = self.body_mesh(tol * r_min / (r_min + t), what)?;
        let g0 = self.g(0.0);
        Ok(base.map(|p| {
            if p[0].abs() < 1e-9 {
                let (u, v, _) = self.uvg(p);
                let rho = (u * u + v * v).sqrt();
                if rho < 1e-12 {
                    return [0.0, 0.0, 0.0];
                }
                let rim = [0.0, p[1] * g0 / rho, p[2] * g0 / rho];
                let moved = mesh::add(rim, mesh::scale(self.normal_at(rim), t));
                let f = rho / g0;
                [0.0, moved[1] * f, moved[2] * f]
            } else {
                mesh::add(p, mesh::scale(self.normal_at(p), t))
            }
        }))
    }

    /// Smallest principal curvature radius of the side surface (a lower bound from the sections'
    /// ellipses, the side profiles and the rounded end; used to pick a tessellation tolerance for
    /// offsets).
    pub fn min_curvature_radius(&self) -> f64 {
        match &self.prof {
            Profile::Capsule { lateral, zd, r_long, r_tip, .. } => {
                // cross-section half-ellipses: radii b^2/a and a^2/b; meridian: tip and pad arcs
                let a = lateral * self.pad_depth;
                let mut m = r_tip.min(*r_long);
                for b in [self.pad_depth, zd * self.pad_depth] {
                    m = m.min(b * b / a).min(a * a / b);
                }
                m
            }
            Profile::Stations { x_cap, cap, wh, zp, zd, .. } => {
                let mut m = f64::INFINITY;
                let ellipse = |a: f64, b: f64| (a * a / b).min(b * b / a);
                let n = 200;
                for i in 0..=n {
                    let x = x_cap * i as f64 / n as f64;
                    let (a, p, d) = (wh.at(x), zp.at(x), zd.at(x));
                    m = m.min(ellipse(a, p)).min(ellipse(a, d));
                }
                // side profiles of width, pad and nail lines: a curve's radius (1 + s²)^1.5 / |s''|
                // is at least 1 / |s''|
                for f in [wh, zp, zd] {
                    let k = f.max_curvature();
                    if k > 0.0 {
                        m = m.min(1.0 / k);
                    }
                }
                // the rounded end: a semi-ellipsoid of semi-axes cap, wh, zp or zd
                let (a, p, d) = (wh.at(*x_cap), zp.at(*x_cap), zd.at(*x_cap));
                for b in [a, p, d] {
                    m = m.min(ellipse(*cap, b));
                }
                m.min(ellipse(a, p)).min(ellipse(a, d))
            }
        }
    }

    /// The radius the pad bends round most sharply (for a flat sheet wrapped onto it).
    pub fn pad_bend_radius(&self) -> f64 {
        match &self.prof {
            Profile::Capsule { lateral, r_tip, .. } => (self.pad_depth * self.pad_depth / (lateral * self.pad_depth)).min(*r_tip),
            Profile::Stations { x_cap, cap, wh, zp, .. } => {
                let n = 200;
                let across = (0..=n).map(|i| x_cap * i as f64 / n as f64).map(|x| wh.at(x).powi(2) / zp.at(x)).fold(f64::INFINITY, f64::min);
                across.min(zp.at(*x_cap).powi(2) / cap).min(cap * cap / zp.at(*x_cap))
            }
        }
    }

    /// Point of the rounded end in coordinates whose poles lie sideways (the apex is a regular
    /// point there): a on the meridian through the apex, b sideways. None off the end.
    fn cap_point(&self, a: f64, b: f64) -> Option<P3> {
        let (x0, len, rad) = match &self.prof {
            Profile::Capsule { r_tip, c2, .. } => (c2.0, *r_tip, *r_tip),
            Profile::Stations { x_cap, cap, .. } => (*x_cap, *cap, 1.0),
        };
        let q = [x0 + len * a.cos() * b.cos(), rad * b.sin(), rad * a.sin() * b.cos()];
        if q[0] < self.cap_start() {
            return None;
        }
        let ([wh, zp, zd], _) = self.scales(q[0]);
        Some([q[0], q[1] * wh, q[2] * if q[2] >= 0.0 { zd } else { zp }])
    }

    /// Distance from `p` to the exact offset surface at `t` (the point's nearest offset-surface
    /// point, found by Gauss-Newton over the surface parameters from a coarse grid). Used by tests
    /// and checks to measure meshes against the exact surface.
    pub fn offset_distance(&self, p: P3, t: f64) -> f64 {
        let f = |x: f64, phi: f64| {
            let x = x.clamp(1e-9, self.length - 1e-9);
            let q = self.surface_point(x, phi);
            mesh::add(q, mesh::scale(self.normal_at(q), t))
        };
        let d2 = |x: f64, phi: f64| {
            let o = f(x, phi);
            mesh::dot(mesh::sub(o, p), mesh::sub(o, p))
        };
        let (mut bx, mut bp, mut best) = (0.0, 0.0, f64::INFINITY);
        let nx = 80;
        for i in 0..=nx {
            let x = self.length * i as f64 / nx as f64;
            for j in 0..72 {
                let phi = 2.0 * std::f64::consts::PI * j as f64 / 72.0;
                let v = d2(x, phi);
                if v < best {
                    (bx, bp, best) = (x, phi, v);
                }
            }
        }
        // pattern search refinement (robust where the parametrisation degenerates at the tip)
        let (mut sx, mut sp) = (self.length / nx as f64, 2.0 * std::f64::consts::PI / 72.0);
        for _ in 0..200 {
            let mut improved = false;
            for (dx, dp) in [(sx, 0.0), (-sx, 0.0), (0.0, sp), (0.0, -sp)] {
                let v = d2((bx + dx).clamp(0.0, self.length), bp + dp);
                if v < best {
                    (bx, bp, best) = ((bx + dx).clamp(0.0, self.length), bp + dp, v);
                    improved = true;
                }
            }
            if !improved {
                sx /= 2.0;
                sp /= 2.0;
                if sx < 1e-9 {
                    break;
                }
            }
        }
        // near the tip the (x, phi) parametrisation degenerates at the apex: also search the tip
        // in coordinates whose poles lie sideways (the apex is a regular point there)
        if bx > self.cap_start() - 0.5 {
            let d2t = |a: f64, b: f64| {
                self.cap_point(a, b).map_or(f64::INFINITY, |q| {
                    let o = mesh::add(q, mesh::scale(self.normal_at(q), t));
                    mesh::dot(mesh::sub(o, p), mesh::sub(o, p))
                })
            };
            let (mut ba, mut bb, mut bt) = (0.0, 0.0, f64::INFINITY);
            for i in -20..=20 {
                for j in -20..=20 {
                    let (a, b) = (i as f64 * 0.075, j as f64 * 0.075);
                    let v = d2t(a, b);
                    if v < bt {
                        (ba, bb, bt) = (a, b, v);
                    }
                }
            }
            let mut st = 0.075;
            while st > 1e-10 {
                let mut improved = false;
                for (da, db) in [(st, 0.0), (-st, 0.0), (0.0, st), (0.0, -st)] {
                    let v = d2t(ba + da, bb + db);
                    if v < bt {
                        (ba, bb, bt) = (ba + da, bb + db, v);
                        improved = true;
                    }
                }
                if !improved {
                    st /= 2.0;
                }
            }
            best = best.min(bt);
        }
        best.sqrt()
    }

    /// The body as one closed mesh within `tol` of the exact surfaces.
    pub fn body_mesh(&self, tol: f64, what: &str) -> Result<Mesh> {
        match &self.prof {
            Profile::Capsule { zd, .. } => {
                // truck tessellates the revolved body scaled to the dorsal height; the pad half is
                // that body's exact image under a z-scale of pad depth / dorsal height (< 1,
                // validated), applied to the vertices below the mid-plane. A contraction cannot
                // increase the chordal error, so `tol` holds on both halves.
                let k = 1.0 / zd;
                let dorsal = mesh::tessellate(&self.truck_capsule(), tol, what)?;
                Ok(dorsal.map(|p| if p[2] < 0.0 { [p[0], p[1], p[2] * k] } else { p }))
            }
            Profile::Stations { .. } => self.stations_mesh(tol, what),
        }
    }

    /// The capsule: the exact revolved side profile, scaled to the dorsal half.
    fn truck_capsule(&self) -> TSolid {
        let Profile::Capsule { lateral, zd, r_long, r_tip, x1, c1, c2, tp } = &self.prof else { unreachable!("capsule profile") };
        let l = self.length;
        let v = |x: f64, y: f64| builder::vertex(Point3::new(x, y, 0.0));
        let mid = |c: (f64, f64), r: f64, a: (f64, f64), b: (f64, f64)| {
            let m = ((a.0 + b.0) / 2.0 - c.0, (a.1 + b.1) / 2.0 - c.1);
            let mn = (m.0 * m.0 + m.1 * m.1).sqrt();
            Point3::new(c.0 + m.0 / mn * r, c.1 + m.1 / mn * r, 0.0)
        };
        let p_tip = v(l, 0.0);
        let p_t = v(tp.0, tp.1);
        let p_x1 = v(*x1, self.pad_depth);
        let p_m = v(0.0, self.pad_depth);
        let p_o = v(0.0, 0.0);
        let mut edges = vec![builder::circle_arc(&p_tip, &p_t, mid(*c2, *r_tip, (l, 0.0), *tp))];
        if *x1 > 1e-6 {
            edges.push(builder::circle_arc(&p_t, &p_x1, mid(*c1, *r_long, *tp, (*x1, self.pad_depth))));
            edges.push(builder::line(&p_x1, &p_m));
        } else {
            edges.push(builder::circle_arc(&p_t, &p_m, mid(*c1, *r_long, *tp, (0.0, self.pad_depth))));
        }
        edges.push(builder::line(&p_m, &p_o));
        let wire: Wire = edges.into();
        let shell = builder::cone(&wire, Vector3::unit_x(), Rad(2.0 * std::f64::consts::PI));
        let solid = TSolid::new(vec![shell]);
        builder::transformed(&solid, Matrix4::from_nonuniform_scale(1.0, *lateral, *zd))
    }

    /// The anatomical body, tessellated from its exact parametric form on a structured grid: rows
    /// along the finger, columns round each section, the apex and the mount face's centre as fan
    /// points. (truck has no smooth skin through sections, only ruled homotopies, so the loft is not
    /// a truck body; every vertex lies on the exact surface.) The chord error is bounded by halves
    /// of the tolerance: round a section, Δφ²/8 times the largest semi-axis; along the run,
    /// Δx²/8 times the scales' curvature; over the rounded end, Δθ²/8 times its largest semi-axis.
    /// The tests measure the result against the exact surface.
    fn stations_mesh(&self, tol: f64, what: &str) -> Result<Mesh> {
        let Profile::Stations { x_cap, cap, wh, zp, zd, .. } = &self.prof else { unreachable!("stations profile") };
        let s_max = [wh, zp, zd].iter().map(|f| (0..=100).map(|i| f.at(x_cap * i as f64 / 100.0)).fold(0.0, f64::max)).fold(0.0, f64::max);
        let step = |size: f64| (4.0 * tol / size).sqrt();
        let n_phi = 4 * ((2.0 * std::f64::consts::PI / step(s_max)) / 4.0).ceil().max(2.0) as usize;
        let n_cap = ((std::f64::consts::FRAC_PI_2 / step(s_max.max(*cap))).ceil() as usize).max(2);
        // rows along the run, spaced per piece between stations by that piece's curvature (where
        // the scales are held, before the first and after the last station, 2 mm apart)
        let mut cuts = vec![0.0];
        cuts.extend(wh.knots().iter().copied().filter(|&k| k > 0.0 && k < *x_cap));
        cuts.push(*x_cap);
        let knots = wh.knots();
        let curvature_at = |a: f64, b: f64| -> f64 {
            (0..knots.len().saturating_sub(1))
                .filter(|&i| knots[i] < b - 1e-12 && knots[i + 1] > a + 1e-12)
                .map(|i| [wh, zp, zd].iter().map(|f| f.piece_curvature(i)).fold(0.0, f64::max))
                .fold(0.0, f64::max)
        };
        let mut rows: Vec<(f64, f64)> = vec![(0.0, 1.0)];
        for w in cuts.windows(2) {
            let k = curvature_at(w[0], w[1]);
            // chord sag along x: dx² / 8 · k ≤ tol / 2
            let dx = if k > 0.0 { (4.0 * tol / k).sqrt().min(2.0) } else { 2.0 };
            let n = (((w[1] - w[0]) / dx).ceil() as usize).max(1);
            rows.extend((1..=n).map(|i| (w[0] + (w[1] - w[0]) * i as f64 / n as f64, 1.0)));
        }
        for i in 1..n_cap {
            let th = std::f64::consts::FRAC_PI_2 * i as f64 / n_cap as f64;
            rows.push((x_cap + cap * th.sin(), th.cos()));
        }
        let mut vertices = Vec::with_capacity(rows.len() * n_phi + 2);
        for &(x, g) in &rows {
            let ([w, pd, nd], _) = self.scales(x);
            for j in 0..n_phi {
                let (sn, cs) = (2.0 * std::f64::consts::PI * j as f64 / n_phi as f64).sin_cos();
                let (sn, cs) = if j % (n_phi / 4) == 0 { (sn.round(), cs.round()) } else { (sn, cs) };
                vertices.push([x, w * g * cs, g * sn * if sn >= 0.0 { nd } else { pd }]);
            }
        }
        let centre = vertices.len() as u32;
        vertices.push([0.0, 0.0, 0.0]);
        let apex = vertices.len() as u32;
        vertices.push([self.length, 0.0, 0.0]);
        let at = |r: usize, j: usize| (r * n_phi + j % n_phi) as u32;
        let mut triangles = Vec::with_capacity(2 * rows.len() * n_phi);
        for j in 0..n_phi {
            triangles.push([centre, at(0, j + 1), at(0, j)]);
            for r in 0..rows.len() - 1 {
                triangles.push([at(r, j), at(r, j + 1), at(r + 1, j + 1)]);
                triangles.push([at(r, j), at(r + 1, j + 1), at(r + 1, j)]);
            }
            triangles.push([at(rows.len() - 1, j), at(rows.len() - 1, j + 1), apex]);
        }
        let mut m = Mesh { vertices, triangles };
        if m.signed_volume() < 0.0 {
            m.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        }
        if m.signed_volume() <= 0.0 {
            return Err(crate::error::Error::geometry(what, "the anatomical body's tessellation has no volume"));
        }
        Ok(m)
    }
}

/// A tapered finger with a pulp: widest and flattest at the mount, the pad deepest at x = 15.
#[cfg(test)]
pub(crate) fn tests_anat() -> Body {
    use crate::params::fingertip::Station;
    let st = |at: f64, width_mm, pad_depth_mm, nail_height_mm| Station { from_tip_mm: 28.0 - at, width_mm, pad_depth_mm, nail_height_mm };
    Body {
        length_mm: 28.0,
        width_mm: 16.0,
        thickness_mm: 13.4,
        form: Form::Stations { tip_length_mm: 7.0, stations: vec![st(0.0, 16.0, 5.6, 7.2), st(8.0, 15.6, 6.0, 6.9), st(15.0, 15.0, 6.4, 6.4), st(21.0, 14.0, 6.0, 5.6)] },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body() -> Body {
        Body { length_mm: 28.0, width_mm: 16.0, thickness_mm: 14.0, form: Form::Capsule { pad_longitudinal_radius_mm: 40.0, pad_transverse_radius_mm: 12.0, tip_radius_mm: 4.5 } }
    }

    fn anatomical() -> Body {
        super::tests_anat()
    }

    #[test]
    fn profile_is_continuous_and_tangent() {
        let s = Shape::new(&body());
        assert!((s.pad_depth_at(0.0) - s.pad_depth).abs() < 1e-12);
        assert!(s.pad_depth_at(28.0).abs() < 1e-9);
        let mut prev = s.pad_depth_at(0.0);
        for i in 1..=2790 {
            let x = i as f64 * 0.01;
            let r = s.pad_depth_at(x);
            assert!((r - prev).abs() < 0.01 * (1.0 + (s.gg(x - 0.005) / s.g(x - 0.005)).abs()) + 1e-9, "jump at {x}");
            assert!(r <= prev + 1e-12, "profile must not grow toward the tip");
            prev = r;
        }
        // slopes match on both sides of the tangent point
        let tp = s.cap_start();
        let e = 1e-4;
        let (a, b) = (s.gg(tp - e) / s.g(tp - e), s.gg(tp + e) / s.g(tp + e));
        assert!((a - b).abs() < 1e-2, "{a} vs {b}");
    }

    #[test]
    fn pad_is_flatter_than_dorsal() {
        let s = Shape::new(&body());
        assert!(s.pad_depth < s.dorsal_height);
        // transverse radius of curvature at the pad bottom equals the parameter
        let w2 = 8.0f64;
        assert!(((w2 * w2 / s.pad_depth) - 12.0).abs() < 1e-9);
    }

    #[test]
    fn anatomical_body_tapers_has_a_pulp_and_a_flatter_nail() {
        let s = Shape::new(&anatomical());
        assert!(s.is_anatomical());
        // taper: the half-width falls from the mount to the start of the rounded end
        assert!(s.half_width(0.0) > s.half_width(21.0) + 0.9);
        // pulp: the pad is deepest between the mount and the tip, at its station
        let deepest = (0..=2800).map(|i| i as f64 * 0.01).fold((0.0, 0.0), |b, x| if s.pad_depth_at(x) > b.1 { (x, s.pad_depth_at(x)) } else { b });
        assert!((deepest.0 - 15.0).abs() < 0.02 && (deepest.1 - 6.4).abs() < 1e-9, "{deepest:?}");
        assert!(s.pad_depth_at(0.0) < 6.0 && s.pad_depth_at(25.0) < 6.0);
        // over the nail (the distal half) the nail side is flatter than the pulp: a larger
        // transverse radius hw² / h
        let hw = s.half_width(21.0);
        assert!(hw * hw / s.dorsal_height_at(21.0) > 1.05 * hw * hw / s.pad_depth_at(21.0));
        // the stations are met exactly
        for (x, w, p, n) in [(0.0, 16.0, 5.6, 7.2), (8.0, 15.6, 6.0, 6.9), (15.0, 15.0, 6.4, 6.4), (21.0, 14.0, 6.0, 5.6)] {
            assert!((2.0 * s.half_width(x) - w).abs() < 1e-12 && (s.pad_depth_at(x) - p).abs() < 1e-12 && (s.dorsal_height_at(x) - n).abs() < 1e-12);
        }
        // closed at the tip
        assert!(s.half_width(28.0).abs() < 1e-12);
    }

    #[test]
    fn normal_is_the_surface_gradient() {
        for b in [body(), anatomical()] {
            let s = Shape::new(&b);
            for (x, phi) in [(3.0, -1.2), (11.0, 0.4), (17.0, -2.0), (23.5, 2.5), (26.0, -1.0), (27.5, 0.3)] {
                let p = s.surface_point(x, phi);
                let n = s.normal_at(p);
                // tangent vectors along the surface are perpendicular to the normal
                let h = 1e-6;
                let tx = mesh::sub(s.surface_point(x + h, phi), s.surface_point(x - h, phi));
                let tp = mesh::sub(s.surface_point(x, phi + h), s.surface_point(x, phi - h));
                assert!(mesh::dot(n, mesh::unit(tx)).abs() < 1e-5 && mesh::dot(n, mesh::unit(tp)).abs() < 1e-5, "x {x} phi {phi}");
                // and it points out
                assert!(!s.inside(mesh::add(p, mesh::scale(n, 1e-4))) && s.inside(mesh::sub(p, mesh::scale(n, 1e-4))));
            }
        }
    }

    #[test]
    fn tessellation_is_within_the_chordal_tolerance_of_the_exact_surface() {
        for b in [body(), anatomical()] {
            let s = Shape::new(&b);
            for tol in [0.05, 0.01] {
                let m = s.body_mesh(tol, "test").unwrap();
                // every vertex lies on the exact surface (within round-off)
                for v in &m.vertices {
                    if v[0] > 1e-6 && v[0] < s.length - 1e-6 {
                        let (u, w, g) = s.uvg(*v);
                        assert!(((u * u + w * w).sqrt() - g).abs() < 1e-6, "vertex off surface: {v:?}");
                    }
                }
                // triangle centroids: first-order distance |G| / |grad G| of G = u² + v² − g²
                let mut worst = 0.0f64;
                for t in &m.triangles {
                    let p: Vec<P3> = t.iter().map(|&i| m.vertices[i as usize]).collect();
                    let c = [(p[0][0] + p[1][0] + p[2][0]) / 3.0, (p[0][1] + p[1][1] + p[2][1]) / 3.0, (p[0][2] + p[1][2] + p[2][2]) / 3.0];
                    if c[0] < 1e-3 || c[0] > s.length - 0.3 {
                        continue; // the mount face is planar; the apex is a point
                    }
                    let (u, w, g) = s.uvg(c);
                    if u * u + w * w < 1e-18 {
                        continue;
                    }
                    let ([wh, zp, zd], [dwh, dzp, dzd]) = s.scales(c[0]);
                    let (zs, dzs) = if c[2] >= 0.0 { (zd, dzd) } else { (zp, dzp) };
                    let gv = [2.0 * (-u * u * dwh / wh - w * w * dzs / zs - s.gg(c[0])), 2.0 * u / wh, 2.0 * w / zs];
                    worst = worst.max((u * u + w * w - g * g).abs() / mesh::norm(gv));
                }
                assert!(worst <= tol * 1.05, "tol {tol}: worst chordal deviation {worst}");
                assert!(worst > tol * 0.2, "tol {tol}: deviation {worst} suspiciously small: the test measures nothing");
            }
        }
    }
}
