//! Checks every part must pass before anything is written. One rule per file; each violation
//! names the part, the rule and the measured value.

mod bodies;
mod genus;
pub mod min_feature;
mod on_bed;
mod orientation;
mod status;

use crate::part::Part;
use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    pub part: String,
    pub rule: &'static str,
    pub measured: String,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {} (measured: {})", self.part, self.rule, self.measured)
    }
}

/// Printability findings that do not stop a build yet: features a 0.4 mm nozzle cannot print
/// (walls, lips and fins narrower than 0.8 mm). The default two-sensor fingertip and its mold have
/// such features today (issue 18, item 5): they are reported in the summary and the manifest until
/// the design is changed, then this becomes a check.
pub fn advise(part: &Part) -> Vec<Violation> {
    [min_feature::check].iter().filter_map(|c| c(part)).collect()
}

/// Runs every check on a part.
pub fn run(part: &Part) -> Vec<Violation> {
    [status::check, orientation::check, genus::check, bodies::check, on_bed::check].iter().filter_map(|c| c(part)).collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use crate::mesh::{Mesh, Solid};
    use crate::part::Part;

    pub fn part_with(mesh: Mesh, solid: Solid, genus: i32) -> Part {
        Part {
            name: "t".into(),
            mesh,
            solid,
            expected_genus: genus,
            density_g_cm3: 1.0,
            process: crate::part::Process::Printed,
            supports: None,
            infill: 1.0,
            write_3mf: true,
            features: serde_json::Value::Null,
            extra: Default::default(),
        }
    }
}
