//! Rule: a part is one body (no loose shells, no slivers left by a cut).

use super::Violation;
use crate::part::Part;

pub fn check(part: &Part) -> Option<Violation> {
    let n = part.solid.bodies();
    (n != 1).then(|| Violation { part: part.name.clone(), rule: "a part must be exactly one body", measured: format!("{n} bodies") })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn two_boxes_are_two_bodies() {
        let a = Solid::cuboid([0.0; 3], [1.0; 3]);
        let b = Solid::cuboid([3.0, 0.0, 0.0], [4.0, 1.0, 1.0]);
        let both = a.union(&b);
        assert!(check(&crate::checks::tests::part_with(both.to_mesh(), both.clone(), 0)).is_some());
        assert!(check(&crate::checks::tests::part_with(a.to_mesh(), a, 0)).is_none());
    }
}
