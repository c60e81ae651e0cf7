//! Rule: the mesh faces outward — its signed volume is positive and matches the kernel's volume.
//! (An inside-out mesh passes the kernel's status with negative volume.)

use super::Violation;
use crate::part::Part;

pub fn check(part: &Part) -> Option<Violation> {
    let v = part.mesh.signed_volume();
    let k = part.solid.volume();
    if v <= 0.0 || (v - k).abs() > 1e-6 * k.abs().max(1.0) {
        return Some(Violation {
            part: part.name.clone(),
            rule: "mesh must face outward (positive signed volume equal to the kernel volume)",
            measured: format!("signed volume {v:.3} mm³, kernel volume {k:.3} mm³"),
        });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn inside_out_mesh_is_rejected() {
        let s = Solid::cuboid([0.0; 3], [1.0; 3]);
        let mut m = s.to_mesh();
        assert!(check(&crate::checks::tests::part_with(m.clone(), s.clone(), 0)).is_none());
        for t in &mut m.triangles {
            t.swap(1, 2);
        }
        assert!(check(&crate::checks::tests::part_with(m, s, 0)).is_some());
    }
}
