//! Triangle meshes, and the bridges to the geometry kernels: truck (exact surfaces, tessellation)
//! and manifold-rust (every boolean). No other module talks to the kernels directly.

use crate::error::{Error, Result};
use manifold_rust::linalg::{Mat3x4, Vec3};
use manifold_rust::manifold::Manifold;
use manifold_rust::types::{Error as MfError, MeshGL64};

pub type P3 = [f64; 3];

/// An indexed triangle mesh, counter-clockwise seen from outside, millimetres.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub vertices: Vec<P3>,
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Bounding box (min, max).
    pub fn bbox(&self) -> (P3, P3) {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }
    /// Signed volume by the divergence theorem (positive for an outward-facing closed mesh).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.vertices[i as usize]);
                (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
            })
            .sum()
    }
    /// Applies a point map (must be a rigid motion to keep orientation).
    pub fn map(&self, f: impl Fn(P3) -> P3) -> Mesh {
        Mesh { vertices: self.vertices.iter().map(|&p| f(p)).collect(), triangles: self.triangles.clone() }
    }
    /// Concatenates meshes (for viewing; the result may hold several shells).
    pub fn merge<'a>(meshes: impl Iterator<Item = &'a Mesh>) -> Mesh {
        let mut out = Mesh::default();
        for m in meshes {
            let base = out.vertices.len() as u32;
            out.vertices.extend_from_slice(&m.vertices);
            out.triangles.extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
        }
        out
    }
    /// Rounds coordinates to f32, as every exported file stores them.
    pub fn to_f32(&self) -> Vec<[f32; 3]> {
        self.vertices.iter().map(|v| [v[0] as f32, v[1] as f32, v[2] as f32]).collect()
    }
}

/// A solid held by the boolean kernel.
#[derive(Clone)]
pub struct Solid(pub Manifold);

impl Solid {
    pub fn from_mesh(mesh: &Mesh, what: &str) -> Result<Solid> {
        let mg = MeshGL64 {
            num_prop: 3,
            vert_properties: mesh.vertices.iter().flat_map(|v| v.iter().copied()).collect(),
            tri_verts: mesh.triangles.iter().flat_map(|t| t.iter().map(|&i| i as u64)).collect(),
            ..Default::default()
        };
        let m = Manifold::from_mesh_gl64(&mg);
        let s = Solid(m);
        s.ok(what)?;
        Ok(s)
    }
    pub fn to_mesh(&self) -> Mesh {
        let mg = self.0.get_mesh_gl64(0);
        let np = mg.num_prop as usize;
        let vertices = mg.vert_properties.chunks(np).map(|c| [c[0], c[1], c[2]]).collect();
        let triangles = mg.tri_verts.chunks(3).map(|t| [t[0] as u32, t[1] as u32, t[2] as u32]).collect();
        Mesh { vertices, triangles }
    }
    /// Fails unless the solid is a valid, non-empty manifold.
    pub fn ok(&self, what: &str) -> Result<()> {
        let st = self.0.status();
        if st != MfError::NoError {
            return Err(Error::geometry(what, format!("geometry kernel status {st:?}")));
        }
        if self.0.is_empty() {
            return Err(Error::geometry(what, "geometry kernel returned an empty solid"));
        }
        Ok(())
    }
    pub fn volume(&self) -> f64 {
        self.0.volume()
    }
    pub fn genus(&self) -> i32 {
        self.0.genus()
    }
    pub fn num_tri(&self) -> usize {
        self.0.num_tri()
    }
    pub fn union(&self, o: &Solid) -> Solid {
        Solid(self.0.union(&o.0))
    }
    pub fn difference(&self, o: &Solid) -> Solid {
        Solid(self.0.difference(&o.0))
    }
    pub fn intersection(&self, o: &Solid) -> Solid {
        Solid(self.0.intersection(&o.0))
    }
    /// Keeps the part on the side the normal points to.
    pub fn trim(&self, normal: P3, offset: f64) -> Solid {
        Solid(self.0.trim_by_plane(v3(normal), offset))
    }
    /// Unions many cutters, pairwise in a balanced tree so each boolean works on small meshes
    /// (a running union would redo the growing result for every cutter).
    pub fn union_all(parts: &[Solid]) -> Option<Solid> {
        let mut level: Vec<Solid> = parts.to_vec();
        if level.is_empty() {
            return None;
        }
        while level.len() > 1 {
            level = level.chunks(2).map(|c| if c.len() == 2 { c[0].union(&c[1]) } else { c[0].clone() }).collect();
        }
        level.pop()
    }
    /// Drops zero-volume shells a boolean can leave where cutter faces nearly coincide
    /// (below `min_volume` mm³), returning how many were dropped.
    pub fn drop_slivers(&self, min_volume: f64) -> (Solid, usize) {
        let parts = self.0.decompose();
        if parts.len() <= 1 {
            return (self.clone(), 0);
        }
        let keep: Vec<Manifold> = parts.iter().filter(|p| p.volume() >= min_volume).cloned().collect();
        let dropped = parts.len() - keep.len();
        if dropped == 0 {
            return (self.clone(), 0);
        }
        (Solid(Manifold::compose(&keep)), dropped)
    }
    /// Number of disconnected bodies.
    pub fn bodies(&self) -> usize {
        self.0.decompose().len()
    }
    /// Smallest distance between two solids, searched up to `search_mm`.
    pub fn min_gap(&self, o: &Solid, search_mm: f64) -> f64 {
        self.0.min_gap(&o.0, search_mm)
    }
    /// Area of the cross-section at height z (plane normal +z).
    pub fn slice_area(&self, z: f64) -> f64 {
        self.0.slice(z).area()
    }
    pub fn translate(&self, d: P3) -> Solid {
        Solid(self.0.translate(v3(d)))
    }
    /// Rigid motion: columns of the rotation (images of x, y, z) and translation.
    pub fn place(&self, ex: P3, ey: P3, ez: P3, origin: P3) -> Solid {
        Solid(self.0.transform(&Mat3x4::from_cols(v3(ex), v3(ey), v3(ez), v3(origin))))
    }

    /// Uniform scale by `k` about `center`.
    pub fn scale_about(&self, k: f64, center: P3) -> Solid {
        Solid(self.0.translate(v3(scale(center, -1.0))).scale(Vec3::new(k, k, k)).translate(v3(center)))
    }
    /// Axis-aligned bounds (lo, hi).
    pub fn bbox(&self) -> (P3, P3) {
        let b = self.0.bounding_box();
        ([b.min.x, b.min.y, b.min.z], [b.max.x, b.max.y, b.max.z])
    }
    /// Whether a point is inside (ray parity along +z up to `above`).
    pub fn contains(&self, p: P3, above: f64) -> bool {
        self.0.ray_cast(v3(p), v3([p[0], p[1], above])).len() % 2 == 1
    }
    /// Whether a point is inside (ray parity along `dir` for `len` mm: a ray that leaves the solid).
    pub fn contains_along(&self, p: P3, dir: P3, len: f64) -> bool {
        self.0.ray_cast(v3(p), v3(add(p, scale(dir, len)))).len() % 2 == 1
    }
    /// Hits of the segment a→b with the surface, nearest first, as distances from a (mm).
    pub fn ray_hits(&self, a: P3, b: P3) -> Vec<f64> {
        let len = norm(sub(b, a));
        self.0.ray_cast(v3(a), v3(b)).iter().map(|h| h.distance * len).collect()
    }

    /// Axis-aligned box.
    pub fn cuboid(lo: P3, hi: P3) -> Solid {
        let s = sub(hi, lo);
        Solid(Manifold::cube(v3(s), false).translate(v3(lo)))
    }
    /// Frustum/cylinder along `dir` starting at `base`, radius `r0` at the base and `r1` at the end.
    /// Polygon radii are scaled so the polygon's area equals the circle's.
    pub fn cylinder(base: P3, dir: P3, height: f64, r0: f64, r1: f64, segments: usize) -> Solid {
        let k = area_radius_factor(segments);
        let c = Manifold::cylinder(height, r0 * k, r1 * k, segments as i32);
        let (u, v, w) = frame(dir);
        Solid(c).place(u, v, w, base)
    }
    /// Convex hull of points.
    pub fn hull(points: &[P3]) -> Solid {
        let v: Vec<Vec3> = points.iter().map(|&p| v3(p)).collect();
        Solid(Manifold::hull(&v))
    }
}

/// Radius factor that gives a regular n-gon the area of its circle.
pub fn area_radius_factor(n: usize) -> f64 {
    let n = n as f64;
    (2.0 * std::f64::consts::PI / (n * (2.0 * std::f64::consts::PI / n).sin())).sqrt()
}

/// Segment count so a polygon stays within `tol` of its circle (at least 12, a multiple of 4).
pub fn segments(r: f64, tol: f64) -> usize {
    let t = (tol / r).min(1.0);
    let n = (std::f64::consts::PI / (1.0 - t).acos()).ceil() as usize;
    n.max(12).div_ceil(4) * 4
}

/// Where a predicate turns from true to false between `lo` (true) and `hi` (false): bisection,
/// `iters` halvings; returns the last point where it held.
pub fn bisect(mut lo: f64, mut hi: f64, iters: usize, holds: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..iters {
        let mid = 0.5 * (lo + hi);
        if holds(mid) {
            lo = mid
        } else {
            hi = mid
        }
    }
    lo
}

pub fn v3(p: P3) -> Vec3 {
    Vec3::new(p[0], p[1], p[2])
}
pub fn sub(a: P3, b: P3) -> P3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn add(a: P3, b: P3) -> P3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn scale(a: P3, s: f64) -> P3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: P3, b: P3) -> P3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
pub fn norm(a: P3) -> f64 {
    dot(a, a).sqrt()
}
pub fn unit(a: P3) -> P3 {
    scale(a, 1.0 / norm(a))
}
/// A right-handed orthonormal frame whose third axis is `w`.
pub fn frame(w: P3) -> (P3, P3, P3) {
    let w = unit(w);
    let helper = if w[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let u = unit(cross(helper, w));
    let v = cross(w, u);
    (u, v, w)
}

/// Tessellates an exact truck solid at a chordal tolerance into a closed mesh.
pub fn tessellate(solid: &truck_modeling::Solid, tol: f64, what: &str) -> Result<Mesh> {
    use truck_meshalgo::prelude::*;
    let mut poly = solid.triangulation(tol).to_polygon();
    poly.put_together_same_attrs(1e-5);
    let vertices: Vec<P3> = poly.positions().iter().map(|p| [p.x, p.y, p.z]).collect();
    let mut triangles = Vec::with_capacity(poly.faces().len());
    for tri in poly.faces().triangle_iter() {
        let t = [tri[0].pos as u32, tri[1].pos as u32, tri[2].pos as u32];
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            triangles.push(t);
        }
    }
    if triangles.is_empty() {
        return Err(Error::geometry(what, "tessellation produced no triangles"));
    }
    Ok(Mesh { vertices, triangles })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_area_matches_circle() {
        for n in [12, 40, 64, 200] {
            let r = 4.0 * area_radius_factor(n);
            let area = 0.5 * n as f64 * r * r * (2.0 * std::f64::consts::PI / n as f64).sin();
            assert!((area / (std::f64::consts::PI * 16.0) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn segments_meet_tolerance() {
        for (r, tol) in [(1.2, 0.01), (5.0, 0.01), (5.0, 0.001), (0.5, 0.05)] {
            let n = segments(r, tol);
            let sag = r * (1.0 - (std::f64::consts::PI / n as f64).cos());
            assert!(sag <= tol + 1e-12, "r {r} tol {tol} n {n} sag {sag}");
            assert_eq!(n % 4, 0);
        }
    }

    #[test]
    fn frame_is_orthonormal_and_right_handed() {
        for w in [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.3, -0.4, -0.8]] {
            let (u, v, ww) = frame(w);
            assert!((dot(u, v)).abs() < 1e-12 && (dot(u, ww)).abs() < 1e-12);
            assert!((norm(sub(cross(u, v), ww))) < 1e-12);
        }
    }

    #[test]
    fn cube_round_trips_through_kernel() {
        let c = Solid::cuboid([0.0; 3], [1.0, 2.0, 3.0]);
        let m = c.to_mesh();
        assert!((m.signed_volume() - 6.0).abs() < 1e-9);
        let back = Solid::from_mesh(&m, "cube").unwrap();
        assert!((back.volume() - 6.0).abs() < 1e-9);
        assert_eq!(back.genus(), 0);
    }
}
