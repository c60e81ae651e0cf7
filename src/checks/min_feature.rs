//! Rule: no printed wall, lip or fin is narrower than two nozzle widths. One narrower than that is
//! laid down as at most one extrusion line, or not at all: the slicer drops it or prints a hair
//! that breaks off.
//!
//! Measured from the surface inward: from points on every triangle at most a nozzle width apart, a
//! ray along the inward normal. The material there is a narrow wall when the ray leaves the part
//! within the minimum through a face nearly parallel to the one it started from (walls within
//! 30° of each other: a lip, a fin, a knife edge between two flats). A corner of 60° or more is
//! not a wall: it prints, only its tip is rounded by the nozzle. Narrow surface smaller than a
//! nozzle's footprint is ignored.

use super::Violation;
use crate::mesh::{cross, dot, norm, scale, sub, Mesh, P3};
use crate::part::{Part, Process};

/// The printer's nozzle (mm): the project's print profile is a 0.4 mm nozzle at 0.2 mm layers.
pub const NOZZLE_MM: f64 = 0.4;
/// The narrowest wall that prints as designed: two extrusion lines.
pub const MIN_FEATURE_MM: f64 = 2.0 * NOZZLE_MM;
/// Two faces within this angle of facing each other bound a wall, not a corner.
pub const MAX_WALL_ANGLE_DEG: f64 = 50.0;
/// Narrow surface smaller than a nozzle's footprint is below what the nozzle resolves (mm²).
const MIN_NARROW_AREA_MM2: f64 = NOZZLE_MM * NOZZLE_MM;

/// The rule as stated in a violation.
pub const RULE: &str = "no printed wall, lip or fin may be narrower than two nozzle widths (0.8 mm for a 0.4 mm nozzle): move the features apart or widen the wall";

/// Where a part is narrow: the narrow surface's area, the narrowest spot and its width.
#[derive(Debug, Clone, PartialEq)]
pub struct Narrow {
    pub area_mm2: f64,
    pub narrowest_mm: f64,
    pub at: P3,
}

pub fn check(part: &Part) -> Option<Violation> {
    if part.process != Process::Printed {
        return None;
    }
    let n = narrow_walls(&part.mesh, MIN_FEATURE_MM);
    (n.area_mm2 > MIN_NARROW_AREA_MM2).then(|| Violation {
        part: part.name.clone(),
        rule: RULE,
        measured: format!(
            "{:.2} mm² of surface on walls narrower than {MIN_FEATURE_MM} mm, the narrowest {:.3} mm at ({:.2}, {:.2}, {:.2})",
            n.area_mm2, n.narrowest_mm, n.at[0], n.at[1], n.at[2]
        ),
    })
}

/// Narrow walls of `mesh`: the area of surface whose inward ray leaves through a facing wall within
/// `min_mm`, and the narrowest spot.
pub fn narrow_walls(mesh: &Mesh, min_mm: f64) -> Narrow {
    narrow_walls_with(mesh, min_mm, -(MAX_WALL_ANGLE_DEG.to_radians().cos()))
}

fn narrow_walls_with(mesh: &Mesh, min_mm: f64, facing: f64) -> Narrow {
    let grid = Grid::new(mesh, min_mm);
    let mut out = Narrow { area_mm2: 0.0, narrowest_mm: f64::INFINITY, at: [0.0; 3] };
    let mut found: Vec<(P3, f64, f64)> = Vec::new();
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let twice_area = norm(n);
        if twice_area < 1e-12 {
            continue;
        }
        let outward = scale(n, 1.0 / twice_area);
        let inward = scale(outward, -1.0);
        // sample the triangle at least every minimum width, so that a large flat face running into a
        // knife edge is looked at near the edge too
        let longest = norm(sub(b, a)).max(norm(sub(c, b))).max(norm(sub(a, c)));
        let k = ((longest / MIN_FEATURE_MM).ceil() as usize).clamp(1, 4096);
        let cell_area = twice_area / 2.0 / (k * k) as f64;
        let at = |u: f64, v: f64| [0, 1, 2].map(|q| a[q] + (b[q] - a[q]) * u + (c[q] - a[q]) * v);
        let kf = k as f64;
        for i in 0..k {
            for j in 0..k - i {
                let mut samples = vec![at((i as f64 + 1.0 / 3.0) / kf, (j as f64 + 1.0 / 3.0) / kf)];
                if i + j + 1 < k {
                    samples.push(at((i as f64 + 2.0 / 3.0) / kf, (j as f64 + 2.0 / 3.0) / kf));
                }
                for p in samples {
                    if let Some((d, exit_normal)) = grid.first_exit(mesh, ti, p, inward, min_mm) {
                        if dot(exit_normal, outward) <= facing {
                            out.area_mm2 += cell_area;
                            found.push((p, d, cell_area));
                        }
                    }
                }
            }
        }
    }
    // where to point: the narrowest spot of the largest narrow region (most narrow surface within a
    // millimetre), not a stray sliver elsewhere whose width is near zero but whose area is nothing
    let near = |a: P3, b: P3| norm(sub(a, b)) <= 1.0;
    // (candidates thinned to at most 400, so a part with very many narrow samples stays cheap)
    let stride = found.len().div_ceil(400).max(1);
    let mass = |q: P3| found.iter().filter(|f| near(f.0, q)).map(|f| f.2).sum::<f64>();
    let best = found.iter().step_by(stride).map(|f| (f.0, mass(f.0))).max_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((centre, _)) = best {
        for &(p, d, _) in found.iter().filter(|f| near(f.0, centre)) {
            if d < out.narrowest_mm {
                out.narrowest_mm = d;
                out.at = p;
            }
        }
    }
    out
}

/// Triangles binned in cubes of the search length, so a short ray meets only its neighbours.
struct Grid {
    lo: P3,
    cell: f64,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
}

impl Grid {
    fn new(mesh: &Mesh, cell: f64) -> Grid {
        let (lo, hi) = mesh.bbox();
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / cell).floor() as usize + 1).max(1));
        let mut g = Grid { lo, cell, dims, cells: vec![Vec::new(); dims[0] * dims[1] * dims[2]] };
        for (i, t) in mesh.triangles.iter().enumerate() {
            let p = t.map(|k| mesh.vertices[k as usize]);
            let (a, b) = (g.index([0, 1, 2].map(|k| p[0][k].min(p[1][k]).min(p[2][k]))), g.index([0, 1, 2].map(|k| p[0][k].max(p[1][k]).max(p[2][k]))));
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        let at = (x * g.dims[1] + y) * g.dims[2] + z;
                        g.cells[at].push(i as u32);
                    }
                }
            }
        }
        g
    }

    fn index(&self, p: P3) -> [usize; 3] {
        [0, 1, 2].map(|k| (((p[k] - self.lo[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1))
    }

    /// Where the ray from `o` along unit `d` first leaves the material within `max`: the distance
    /// and the unit outward normal of the face it leaves through (a face turned along the ray).
    fn first_exit(&self, mesh: &Mesh, skip: usize, o: P3, d: P3, max: f64) -> Option<(f64, P3)> {
        let end = [0, 1, 2].map(|k| o[k] + d[k] * max);
        let (a, b) = (self.index([0, 1, 2].map(|k| o[k].min(end[k]))), self.index([0, 1, 2].map(|k| o[k].max(end[k]))));
        let mut best: Option<(f64, P3)> = None;
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    for &ti in &self.cells[(x * self.dims[1] + y) * self.dims[2] + z] {
                        if ti as usize == skip {
                            continue;
                        }
                        let p = mesh.triangles[ti as usize].map(|k| mesh.vertices[k as usize]);
                        let Some(t) = ray_triangle(o, d, p) else { continue };
                        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
                        let len = norm(n);
                        if t > 1e-6 && t <= max && len > 0.0 && dot(n, d) > 0.0 && best.is_none_or(|b| t < b.0) {
                            best = Some((t, scale(n, 1.0 / len)));
                        }
                    }
                }
            }
        }
        best
    }
}

/// Möller–Trumbore: the ray parameter where `o + t d` meets triangle `p`, if it does.
fn ray_triangle(o: P3, d: P3, p: [P3; 3]) -> Option<f64> {
    let (e1, e2) = (sub(p[1], p[0]), sub(p[2], p[0]));
    let h = cross(d, e2);
    let det = dot(e1, h);
    if det.abs() < 1e-14 {
        return None;
    }
    let s = sub(o, p[0]);
    let u = dot(s, h) / det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) / det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(dot(e2, q) / det)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checks::tests::part_with;
    use crate::mesh::Solid;

    #[test]
    fn a_lip_below_two_nozzle_widths_fails_and_a_groove_or_corner_does_not() {
        // a 10 × 10 × 4 block with a 0.22 mm wide, 0.2 mm tall lip standing on it, 3 mm long
        let block = Solid::cuboid([0.0; 3], [10.0, 10.0, 4.0]);
        let lip = block.union(&Solid::cuboid([4.0, 1.0, 3.9], [4.22, 4.0, 4.2]));
        let v = check(&part_with(lip.to_mesh(), lip.clone(), 0)).expect("a 0.22 mm lip");
        assert!(v.measured.contains("narrowest 0.220"), "{v}");
        // the same lip 1.0 mm wide prints
        let wide = block.union(&Solid::cuboid([4.0, 1.0, 3.9], [5.0, 4.0, 4.2]));
        assert!(check(&part_with(wide.to_mesh(), wide.clone(), 0)).is_none());
        // a 0.3 mm groove is not a narrow wall, nor are the block's own 90° corners
        let groove = block.difference(&Solid::cuboid([4.0, 1.0, 3.0], [4.3, 9.0, 5.0]));
        assert!(check(&part_with(groove.to_mesh(), groove.clone(), 0)).is_none());
        assert!(check(&part_with(block.to_mesh(), block.clone(), 0)).is_none());
    }

    #[test]
    fn a_knife_edge_fails_a_60_degree_edge_does_not_and_cast_parts_are_not_checked() {
        // a wedge tapering at 10° to an edge: its last few millimetres are a fin
        let t = 10f64.to_radians().tan() * 10.0;
        let wedge = Solid::hull(&[[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0], [0.0, 0.0, t], [0.0, 10.0, t]]);
        let v = check(&part_with(wedge.to_mesh(), wedge.clone(), 0)).expect("a knife edge");
        assert!(v.measured.contains("mm²"), "{v}");
        // an equilateral prism: every edge 60°
        let h = 3.0 * 3f64.sqrt();
        let blunt = Solid::hull(&[[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [6.0, 0.0, 0.0], [6.0, 10.0, 0.0], [3.0, 0.0, h], [3.0, 10.0, h]]);
        assert!(check(&part_with(blunt.to_mesh(), blunt.clone(), 0)).is_none(), "a 60° edge is a corner, not a wall");
        let mut cast = part_with(wedge.to_mesh(), wedge, 0);
        cast.process = Process::Cast;
        assert!(check(&cast).is_none(), "cast parts are not printed");
    }
}
