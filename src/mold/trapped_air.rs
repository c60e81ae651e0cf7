//! Rule: no air is trapped in the cavity when the mold is poured (+z up). Air only rises: a point
//! of the cavity's surface traps air when every way along the surface to an exit (the rim at the
//! parting plane, where the cavity meets the sprue and the vents, or the opening of a vent drilled
//! from a pocket) goes below it. A priority flood over the cavity mesh gives each vertex its spill
//! height: the highest level at which a path to an exit can stay; where that is lower than the
//! vertex, air stays behind. (scripts/check_air.py measures the same on voxels, independently.)

use crate::mesh::{Mesh, P3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Where air leaves the cavity: a vertical opening of radius `r` about `xy`, open from height
/// `from_z` up (the sprue and rim vents from the parting plane, a pocket vent from the pocket's top).
#[derive(Debug, Clone, Copy)]
pub struct Exit {
    pub xy: [f64; 2],
    pub r: f64,
    pub from_z: f64,
}

/// One pocket of trapped air: its highest point and how far it lies above its spill height.
#[derive(Debug, Clone, PartialEq)]
pub struct Pocket {
    pub apex: P3,
    pub depth_mm: f64,
    pub vertices: usize,
}

/// Pockets deeper than this are reported (mm): below it, facets of the tessellation.
pub const MIN_DEPTH_MM: f64 = 0.02;

#[derive(PartialEq)]
struct Item(f64, usize);
impl Eq for Item {}
impl PartialOrd for Item {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Item {
    fn cmp(&self, o: &Self) -> Ordering {
        self.0.total_cmp(&o.0).then(self.1.cmp(&o.1))
    }
}

/// The pockets of trapped air on the surface of `cavity` (poured with +z up, its top at
/// `z_top`: vertices there are on the rim, open to the air above).
pub fn pockets(cavity: &Mesh, z_top: f64, exits: &[Exit]) -> Vec<Pocket> {
    let n = cavity.vertices.len();
    let mut next: Vec<Vec<usize>> = vec![Vec::new(); n];
    for t in &cavity.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            next[a].push(b);
            next[b].push(a);
        }
    }
    // exits: the rim, and every vertex of a triangle that a vent's opening reaches (the vent's
    // circle meets the triangle's footprint, at or above the height the vent starts)
    let mut exit = vec![false; n];
    for (i, p) in cavity.vertices.iter().enumerate() {
        exit[i] = p[2] >= z_top - 1e-6;
    }
    for t in &cavity.triangles {
        let q = t.map(|k| cavity.vertices[k as usize]);
        let top = q[0][2].max(q[1][2]).max(q[2][2]);
        if exits.iter().any(|e| top >= e.from_z - 0.35 && footprint_distance(e.xy, &q) <= e.r) {
            for &k in t {
                exit[k as usize] = true;
            }
        }
    }
    // spill height: the best bottleneck (highest lowest point) over paths to an exit
    let mut spill = vec![f64::NEG_INFINITY; n];
    let mut heap = BinaryHeap::new();
    for (i, p) in cavity.vertices.iter().enumerate() {
        if exit[i] {
            spill[i] = p[2];
            heap.push(Item(p[2], i));
        }
    }
    while let Some(Item(s, v)) = heap.pop() {
        if s < spill[v] {
            continue;
        }
        for &w in &next[v] {
            let cand = s.min(cavity.vertices[w][2]);
            if cand > spill[w] {
                spill[w] = cand;
                heap.push(Item(cand, w));
            }
        }
    }
    // only a ceiling holds air: a vertex with a face looking up out of the cavity (a high point of
    // the floor, every face round it looking down, stays under the liquid's open surface)
    let mut ceiling = vec![false; n];
    for t in &cavity.triangles {
        let q = t.map(|k| cavity.vertices[k as usize]);
        // the outward normal (the mesh is wound counter-clockwise seen from outside) looks up
        let nrm = crate::mesh::cross(crate::mesh::sub(q[1], q[0]), crate::mesh::sub(q[2], q[0]));
        if nrm[2] > 1e-9 * crate::mesh::norm(nrm) {
            for &k in t {
                ceiling[k as usize] = true;
            }
        }
    }
    // trapped vertices, grouped by connection
    let trapped: Vec<bool> = (0..n).map(|i| ceiling[i] && cavity.vertices[i][2] - spill[i] > MIN_DEPTH_MM).collect();
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    for start in 0..n {
        if !trapped[start] || seen[start] {
            continue;
        }
        let (mut stack, mut apex, mut depth, mut count) = (vec![start], cavity.vertices[start], 0.0f64, 0);
        seen[start] = true;
        while let Some(v) = stack.pop() {
            count += 1;
            let p = cavity.vertices[v];
            depth = depth.max(p[2] - spill[v]);
            if p[2] > apex[2] {
                apex = p;
            }
            for &w in &next[v] {
                if trapped[w] && !seen[w] {
                    seen[w] = true;
                    stack.push(w);
                }
            }
        }
        out.push(Pocket { apex, depth_mm: depth, vertices: count });
    }
    out
}

/// Distance in the xy plane from `c` to triangle `q` (0 inside it).
fn footprint_distance(c: [f64; 2], q: &[P3; 3]) -> f64 {
    let p: Vec<[f64; 2]> = q.iter().map(|v| [v[0], v[1]]).collect();
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    let (d0, d1, d2) = (cross(p[0], p[1], c), cross(p[1], p[2], c), cross(p[2], p[0], c));
    if (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0) {
        return 0.0;
    }
    (0..3)
        .map(|k| {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = if len2 > 0.0 { (((c[0] - a[0]) * ab[0] + (c[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
            (c[0] - a[0] - ab[0] * t).hypot(c[1] - a[1] - ab[1] * t)
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    /// A cavity like a cover poured pad-down: a shallow box open at its top (z = 0), with an
    /// upside-down cup rising 1 mm into its ceiling… seen from inside: a box from z -3 to 0 whose
    /// ceiling has a recess 0.5 mm deep at one place and reaches the top elsewhere only at its rim.
    fn cavity_with_pocket() -> Solid {
        // the liquid's space: a slab, with a pocket pushed up into the ceiling, and a riser at one
        // end that reaches the top (the rim)
        let slab = Solid::cuboid([0.0, 0.0, -3.0], [20.0, 10.0, -1.0]);
        let riser = Solid::cuboid([0.0, 0.0, -3.0], [2.0, 10.0, 0.0]);
        let pocket = Solid::cylinder([12.0, 5.0, -1.5], [0.0, 0.0, 1.0], 1.0, 2.0, 2.0, 32);
        slab.union(&riser).union(&pocket)
    }

    #[test]
    fn a_pocket_in_the_ceiling_traps_air_and_a_vent_at_its_top_lets_it_out() {
        let cav = cavity_with_pocket().to_mesh();
        let found = pockets(&cav, 0.0, &[]);
        assert_eq!(found.len(), 1, "{found:?}");
        // the pocket rises 0.5 mm above the ceiling (-1.0) to -0.5; its apex is its top
        assert!((found[0].depth_mm - 0.5).abs() < 1e-6 && (found[0].apex[2] + 0.5).abs() < 1e-6, "{found:?}");
        assert!((found[0].apex[0] - 12.0).abs() <= 2.1, "{found:?}");
        // a vent from the pocket's top
        let vent = Exit { xy: [12.0, 5.0], r: 0.4, from_z: -0.5 };
        assert!(pockets(&cav, 0.0, &[vent]).is_empty());
        // a ceiling that rises all the way to the rim traps nothing
        let ramp =
            Solid::hull(&[[0.0, 0.0, -3.0], [20.0, 0.0, -3.0], [0.0, 10.0, -3.0], [20.0, 10.0, -3.0], [0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [20.0, 0.0, -1.0], [20.0, 10.0, -1.0]]);
        assert!(pockets(&ramp.to_mesh(), 0.0, &[]).is_empty());
    }

    #[test]
    fn a_high_point_of_the_floor_traps_nothing() {
        // a bump rising 0.5 mm from the floor into the liquid: every face round its top looks down
        // out of the cavity (into the bump), so no air can stay there
        let slab = Solid::cuboid([0.0, 0.0, -3.0], [20.0, 10.0, 0.0]);
        let bump = Solid::cylinder([12.0, 5.0, -3.1], [0.0, 0.0, 1.0], 0.6, 2.0, 1.0, 32);
        let cav = slab.difference(&bump).to_mesh();
        assert!(pockets(&cav, 0.0, &[]).is_empty());
        // the same bump turned into a dimple in the ceiling does trap air
        let dimple = Solid::cylinder([12.0, 5.0, -1.5], [0.0, 0.0, 1.0], 0.6, 2.0, 1.0, 32);
        let ceiling = Solid::cuboid([0.0, 0.0, -3.0], [20.0, 10.0, -1.0]).union(&Solid::cuboid([0.0, 0.0, -3.0], [2.0, 10.0, 0.0])).union(&dimple);
        assert_eq!(pockets(&ceiling.to_mesh(), 0.0, &[]).len(), 1);
    }
}
