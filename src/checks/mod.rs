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

/// Runs every check on a part.
pub fn run(part: &Part) -> Vec<Violation> {
    [status::check, orientation::check, genus::check, bodies::check, on_bed::check, min_feature::check].iter().filter_map(|c| c(part)).collect()
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
