//! The analytic fingertip body: the exact surfaces that truck models and the validation reads.

use crate::error::Result;
use crate::mesh::{self, Mesh, P3};
use crate::params::fingertip::Body;
use truck_modeling::{builder, Matrix4, Point3, Rad, Solid as TSolid, Vector3, Wire};

/// Side profile r(x) (pad units: r(0) = pad depth) and the cross-section scales.
#[derive(Debug, Clone)]
pub struct Shape {
    pub length: f64,
    /// Pad depth below the mid-plane, = (width/2)² / pad transverse radius.
    pub pad_depth: f64,
    /// Dorsal height above the mid-plane.
    pub dorsal_height: f64,
    /// Lateral scale: half-width = lateral · r(x).
    pub lateral: f64,
    r_long: f64,
    r_tip: f64,
    /// End of the straight run.
    pub x1: f64,
    c1: (f64, f64),
    c2: (f64, f64),
    /// Tangent point between the pad arc and the tip arc.
    tp: (f64, f64),
}

impl Shape {
    pub fn new(b: &Body) -> Shape {
        let pad_depth = (b.width_mm / 2.0).powi(2) / b.pad_transverse_radius_mm;
        let (l, rl, rt) = (b.length_mm, b.pad_longitudinal_radius_mm, b.tip_radius_mm);
        let c2 = (l - rt, 0.0);
        let x1 = l - rt - ((rl - rt).powi(2) - (rl - pad_depth).powi(2)).max(0.0).sqrt();
        let c1 = (x1, pad_depth - rl);
        let d = (c2.0 - c1.0, c2.1 - c1.1);
        let dn = (d.0 * d.0 + d.1 * d.1).sqrt();
        let tp = (c1.0 + d.0 / dn * rl, c1.1 + d.1 / dn * rl);
        Shape { length: l, pad_depth, dorsal_height: b.thickness_mm - pad_depth, lateral: b.width_mm / 2.0 / pad_depth, r_long: rl, r_tip: rt, x1, c1, c2, tp }
    }

    /// Profile radius at x (0 outside [0, length]).
    pub fn r(&self, x: f64) -> f64 {
        if !(0.0..=self.length).contains(&x) {
            0.0
        } else if x <= self.x1 {
            self.pad_depth
        } else if x <= self.tp.0 {
            self.c1.1 + (self.r_long.powi(2) - (x - self.c1.0).powi(2)).max(0.0).sqrt()
        } else {
            (self.r_tip.powi(2) - (x - self.c2.0).powi(2)).max(0.0).sqrt()
        }
    }

    /// dr/dx.
    pub fn dr(&self, x: f64) -> f64 {
        let h = 1e-6;
        (self.r((x + h).min(self.length)) - self.r((x - h).max(0.0))) / ((x + h).min(self.length) - (x - h).max(0.0))
    }

    fn zscale(&self, z: f64) -> f64 {
        if z >= 0.0 {
            self.dorsal_height / self.pad_depth
        } else {
            1.0
        }
    }

    /// Whether a point is inside the body (ignoring features).
    pub fn inside(&self, p: P3) -> bool {
        let r = self.r(p[0]);
        if r <= 0.0 || p[0] <= 0.0 {
            return false;
        }
        let rho2 = (p[1] / self.lateral).powi(2) + (p[2] / self.zscale(p[2])).powi(2);
        rho2 < r * r
    }

    /// Half-width of the body at x.
    pub fn half_width(&self, x: f64) -> f64 {
        self.lateral * self.r(x)
    }

    /// Pad surface height (negative) at (x, y), if the point is over the body.
    pub fn z_pad(&self, x: f64, y: f64) -> Option<f64> {
        let r = self.r(x);
        let q = 1.0 - (y / (self.lateral * r)).powi(2);
        (r > 0.0 && q >= 0.0).then(|| -r * q.sqrt())
    }

    /// Dorsal surface height at (x, y).
    pub fn z_dorsal(&self, x: f64, y: f64) -> Option<f64> {
        self.z_pad(x, y).map(|z| -z * self.dorsal_height / self.pad_depth)
    }

    /// Outward unit normal of the pad surface at (x, y).
    pub fn pad_normal(&self, x: f64, y: f64) -> Option<P3> {
        let z = self.z_pad(x, y)?;
        let r = self.r(x);
        // F = (y/a)² + z² − r(x)², gradient points outward.
        let g = [-2.0 * r * self.dr(x), 2.0 * y / self.lateral.powi(2), 2.0 * z];
        Some(mesh::unit(g))
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
        let r = self.r(x);
        (0..n)
            .map(|i| {
                let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                let (s, c) = th.sin_cos();
                [self.lateral * r * c, r * s * self.zscale(s)]
            })
            .collect()
    }

    /// Exact outward unit normal of the body's side surface at a surface point `p` (from the
    /// profile arcs, not from a mesh). On the mount-face ring it is the side normal (no x part).
    pub fn normal_at(&self, p: P3) -> P3 {
        let zs = self.zscale(p[2]);
        let (qy, qz) = (p[1] / self.lateral, p[2] / zs);
        let rho = (qy * qy + qz * qz).sqrt();
        if rho < 1e-12 {
            return if p[0] > self.length / 2.0 { [1.0, 0.0, 0.0] } else { [-1.0, 0.0, 0.0] };
        }
        let x = p[0];
        // meridian normal (n_x, n_rho) in pad units
        let (nx, nr) = if x <= self.x1 {
            (0.0, 1.0)
        } else if x <= self.tp.0 {
            (x - self.c1.0, rho - self.c1.1)
        } else {
            (x - self.c2.0, rho - self.c2.1)
        };
        let (c, s) = (qy / rho, qz / rho);
        // the scaled surface's normal is S^-1 applied to the unscaled one (S diagonal)
        mesh::unit([nx, nr * c / self.lateral, nr * s / zs])
    }

    /// Surface point at parameters (x, phi): phi = 0 lateral (+y), -pi/2 the pad bottom.
    pub fn surface_point(&self, x: f64, phi: f64) -> P3 {
        let r = self.r(x);
        let (s, c) = phi.sin_cos();
        [x, self.lateral * r * c, r * s * self.zscale(s)]
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
        let r0 = self.r(0.0);
        Ok(base.map(|p| {
            if p[0].abs() < 1e-9 {
                let zs = self.zscale(p[2]);
                let (qy, qz) = (p[1] / self.lateral, p[2] / zs);
                let rho = (qy * qy + qz * qz).sqrt();
                if rho < 1e-12 {
                    return [0.0, 0.0, 0.0];
                }
                let rim = [0.0, p[1] * r0 / rho, p[2] * r0 / rho];
                let n = self.normal_at(rim);
                let moved = mesh::add(rim, mesh::scale(n, t));
                let f = rho / r0;
                [0.0, moved[1] * f, moved[2] * f]
            } else {
                mesh::add(p, mesh::scale(self.normal_at(p), t))
            }
        }))
    }

    /// Smallest principal curvature radius of the side surface (sampled; used to pick a
    /// tessellation tolerance for offsets).
    pub fn min_curvature_radius(&self) -> f64 {
        // cross-section half-ellipses: radii b^2/a and a^2/b; meridian: tip and pad arcs
        let a = self.lateral * self.pad_depth;
        let mut m = self.r_tip.min(self.r_long);
        for b in [self.pad_depth, self.dorsal_height] {
            m = m.min(b * b / a).min(a * a / b);
        }
        m
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
        // sphere in coordinates whose poles lie sideways (the apex is a regular point there)
        if bx > self.tp.0 - 0.5 {
            let rt = self.r_tip;
            let on_tip = |a: f64, b: f64| -> Option<P3> {
                let q = [self.c2.0 + rt * a.cos() * b.cos(), rt * b.sin(), rt * a.sin() * b.cos()];
                (q[0] >= self.tp.0).then(|| [q[0], q[1] * self.lateral, q[2] * self.zscale(q[2])])
            };
            let d2t = |a: f64, b: f64| {
                on_tip(a, b).map_or(f64::INFINITY, |q| {
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

    /// The exact revolved body scaled to one half (`dorsal` or pad), as a truck solid.
    fn truck_half(&self, dorsal: bool) -> TSolid {
        let l = self.length;
        let v = |x: f64, y: f64| builder::vertex(Point3::new(x, y, 0.0));
        let mid = |c: (f64, f64), r: f64, a: (f64, f64), b: (f64, f64)| {
            let m = ((a.0 + b.0) / 2.0 - c.0, (a.1 + b.1) / 2.0 - c.1);
            let mn = (m.0 * m.0 + m.1 * m.1).sqrt();
            Point3::new(c.0 + m.0 / mn * r, c.1 + m.1 / mn * r, 0.0)
        };
        let p_tip = v(l, 0.0);
        let p_t = v(self.tp.0, self.tp.1);
        let p_x1 = v(self.x1, self.pad_depth);
        let p_m = v(0.0, self.pad_depth);
        let p_o = v(0.0, 0.0);
        let mut edges = vec![builder::circle_arc(&p_tip, &p_t, mid(self.c2, self.r_tip, (l, 0.0), self.tp))];
        if self.x1 > 1e-6 {
            edges.push(builder::circle_arc(&p_t, &p_x1, mid(self.c1, self.r_long, self.tp, (self.x1, self.pad_depth))));
            edges.push(builder::line(&p_x1, &p_m));
        } else {
            edges.push(builder::circle_arc(&p_t, &p_m, mid(self.c1, self.r_long, self.tp, (0.0, self.pad_depth))));
        }
        edges.push(builder::line(&p_m, &p_o));
        let wire: Wire = edges.into();
        let shell = builder::cone(&wire, Vector3::unit_x(), Rad(2.0 * std::f64::consts::PI));
        let solid = TSolid::new(vec![shell]);
        let zs = if dorsal { self.dorsal_height / self.pad_depth } else { 1.0 };
        builder::transformed(&solid, Matrix4::from_nonuniform_scale(1.0, self.lateral, zs))
    }

    /// The body as one closed mesh within `tol` of the exact surfaces. truck tessellates the
    /// revolved body scaled to the dorsal height; the pad half is that body's exact image under a
    /// z-scale of pad depth / dorsal height (< 1, validated), applied to the vertices below the
    /// mid-plane. A contraction cannot increase the chordal error, so `tol` holds on both halves.
    pub fn body_mesh(&self, tol: f64, what: &str) -> Result<Mesh> {
        let k = self.pad_depth / self.dorsal_height;
        let dorsal = mesh::tessellate(&self.truck_half(true), tol, what)?;
        Ok(dorsal.map(|p| if p[2] < 0.0 { [p[0], p[1], p[2] * k] } else { p }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body() -> Body {
        Body { length_mm: 28.0, width_mm: 16.0, thickness_mm: 14.0, pad_longitudinal_radius_mm: 40.0, pad_transverse_radius_mm: 12.0, tip_radius_mm: 4.5 }
    }

    #[test]
    fn profile_is_continuous_and_tangent() {
        let s = Shape::new(&body());
        assert!((s.r(0.0) - s.pad_depth).abs() < 1e-12);
        assert!(s.r(28.0).abs() < 1e-9);
        let mut prev = s.r(0.0);
        for i in 1..=2790 {
            let x = i as f64 * 0.01;
            let r = s.r(x);
            // the tip arc meets the axis square, so allow its slope there
            assert!((r - prev).abs() < 0.01 * (1.0 + s.dr(x - 0.005).abs()) + 1e-9, "jump at {x}");
            assert!(r <= prev + 1e-12, "profile must not grow toward the tip");
            prev = r;
        }
        // slopes match on both sides of the tangent point
        let e = 1e-4;
        let (a, b) = (s.dr(s.tp.0 - e), s.dr(s.tp.0 + e));
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
    fn tessellation_is_within_the_chordal_tolerance_of_the_exact_surface() {
        let s = Shape::new(&body());
        for tol in [0.05, 0.01] {
            let m = s.body_mesh(tol, "test").unwrap();
            // every vertex lies on the exact surface (within round-off)
            for v in &m.vertices {
                if v[0] > 1e-6 && v[0] < s.length - 1e-6 {
                    let rho = ((v[1] / s.lateral).powi(2) + (v[2] / s.zscale(v[2])).powi(2)).sqrt();
                    assert!((rho - s.r(v[0])).abs() < 1e-6, "vertex off surface: {v:?}");
                }
            }
            // triangle centroids: first-order distance |F| / |grad F| of F = rho - r(x)
            let mut worst = 0.0f64;
            for t in &m.triangles {
                let p: Vec<P3> = t.iter().map(|&i| m.vertices[i as usize]).collect();
                let c = [(p[0][0] + p[1][0] + p[2][0]) / 3.0, (p[0][1] + p[1][1] + p[2][1]) / 3.0, (p[0][2] + p[1][2] + p[2][2]) / 3.0];
                if c[0] < 1e-3 || c[0] > s.length - 0.3 {
                    continue; // the mount face is planar; the apex is a point
                }
                let zs = s.zscale(c[2]);
                let rho = ((c[1] / s.lateral).powi(2) + (c[2] / zs).powi(2)).sqrt();
                if rho < 1e-9 {
                    continue;
                }
                let f = rho - s.r(c[0]);
                let g = [-s.dr(c[0]), c[1] / (s.lateral * s.lateral * rho), c[2] / (zs * zs * rho)];
                worst = worst.max(f.abs() / mesh::norm(g));
            }
            assert!(worst <= tol * 1.05, "tol {tol}: worst chordal deviation {worst}");
            assert!(worst > tol * 0.2, "tol {tol}: deviation {worst} suspiciously small: the test measures nothing");
        }
    }
}
