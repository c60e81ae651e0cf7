//! Rule: the genus equals the number of through holes the parameters ask for.

use super::Violation;
use crate::part::Part;

pub fn check(part: &Part) -> Option<Violation> {
    let g = part.solid.genus();
    (g != part.expected_genus).then(|| Violation {
        part: part.name.clone(),
        rule: "genus must equal the number of through holes",
        measured: format!("genus {g}, expected {}", part.expected_genus),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn a_hole_counts_once() {
        let block = Solid::cuboid([0.0; 3], [4.0, 4.0, 2.0]);
        let holed = block.difference(&Solid::cylinder([2.0, 2.0, -1.0], [0.0, 0.0, 1.0], 4.0, 1.0, 1.0, 16));
        let m = holed.to_mesh();
        assert!(check(&crate::checks::tests::part_with(m.clone(), holed.clone(), 1)).is_none());
        assert!(check(&crate::checks::tests::part_with(m, holed, 0)).is_some());
    }
}
