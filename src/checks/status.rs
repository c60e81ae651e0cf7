//! Rule: the mesh re-imports into the boolean kernel as a closed 2-manifold (status NoError).

use super::Violation;
use crate::mesh::Solid;
use crate::part::Part;

pub fn check(part: &Part) -> Option<Violation> {
    match Solid::from_mesh(&part.mesh, &part.name) {
        Ok(_) => None,
        Err(e) => Some(Violation { part: part.name.clone(), rule: "mesh must be a closed 2-manifold (kernel status NoError)", measured: e.to_string() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn open_mesh_is_rejected() {
        let s = Solid::cuboid([0.0; 3], [1.0; 3]);
        let mut m = s.to_mesh();
        m.triangles.pop();
        let part = crate::checks::tests::part_with(m, s, 0);
        assert!(check(&part).is_some());
    }
}
