//! Rule: a printed part is written in its print orientation resting on the bed, z = 0. A slicer
//! drops a part that floats and may sink one that goes below; either way the file is not what was
//! designed. Cast parts keep the frame of the part they fit and are not checked.

use super::Violation;
use crate::part::{Part, Process};

/// How far the lowest vertex may be from z = 0 (float noise of the booleans).
const TOLERANCE_MM: f64 = 1e-6;

pub fn check(part: &Part) -> Option<Violation> {
    if part.process != Process::Printed || part.mesh.vertices.is_empty() {
        return None;
    }
    let (lo, _) = part.mesh.bbox();
    (lo[2].abs() > TOLERANCE_MM).then(|| Violation {
        part: part.name.clone(),
        rule: "a printed part must rest on the bed (its lowest point at z = 0)",
        measured: format!("lowest point at z = {:.4} mm", lo[2]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checks::tests::part_with;
    use crate::mesh::Solid;

    #[test]
    fn a_printed_part_off_the_bed_fails_and_a_cast_one_may_float() {
        let on = Solid::cuboid([0.0; 3], [4.0, 4.0, 2.0]);
        assert!(check(&part_with(on.to_mesh(), on.clone(), 0)).is_none());
        let below = on.translate([0.0, 0.0, -2.0]);
        let v = check(&part_with(below.to_mesh(), below.clone(), 0)).expect("2 mm below the bed");
        assert!(v.measured.contains("-2.0000"), "{v}");
        let mut cast = part_with(below.to_mesh(), below, 0);
        cast.process = Process::Cast;
        assert!(check(&cast).is_none());
    }
}
