//! A built part: its mesh, what the checks expect of it, and what the manifest reports.

use crate::mesh::{Mesh, Solid};
use serde_json::{Map, Value};

#[derive(Clone)]
pub struct Part {
    /// Output file stem, e.g. `fingertip-1s`.
    pub name: String,
    pub mesh: Mesh,
    pub solid: Solid,
    /// Number of through holes the part must have (its genus).
    pub expected_genus: i32,
    pub density_g_cm3: f64,
    /// How the part is made: printed in PLA (its STL lies on the bed in its print orientation) or
    /// cast in PDMS (it keeps the frame of the part it covers).
    pub process: Process,
    /// Where a printed part needs support in its print orientation, measured with PrusaSlicer
    /// (scripts/check_slicer.py); None: it prints without (the slicer check enforces it).
    pub supports: Option<&'static str>,
    /// Fraction of the volume printed solid (1.0 = 100 % infill).
    pub infill: f64,
    /// Whether to write a 3MF beside the STL.
    pub write_3mf: bool,
    /// Nominal features the external checks measure (seats, holes, faces), in the output frame.
    pub features: Value,
    /// Extra manifest entries (preload, material estimates, …).
    pub extra: Map<String, Value>,
}

/// How a part is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Process {
    /// Printed without support, in the orientation its file is written in, resting on z = 0.
    Printed,
    /// Cast in a mold; written in the frame of the part it fits.
    Cast,
}

impl Process {
    pub fn name(self) -> &'static str {
        match self {
            Process::Printed => "printed",
            Process::Cast => "cast",
        }
    }
}

impl Part {
    pub fn volume_mm3(&self) -> f64 {
        self.solid.volume()
    }
    pub fn mass_g(&self) -> f64 {
        self.volume_mm3() / 1000.0 * self.density_g_cm3 * self.infill
    }
}

/// An extra output that is not a printable part (e.g. an assembly view), written as 3MF only.
#[derive(Clone)]
pub struct Assembly {
    pub name: String,
    pub parts: Vec<AssemblyObject>,
}

/// One object of an assembly view: a printed part in its assembled pose, or a reference shape
/// (a sensor, a cavity, a part lifted off for viewing) that slicers must not print.
#[derive(Clone)]
pub struct AssemblyObject {
    pub name: String,
    pub mesh: Mesh,
    pub printable: bool,
}

impl AssemblyObject {
    pub fn part(name: impl Into<String>, mesh: Mesh) -> Self {
        AssemblyObject { name: name.into(), mesh, printable: true }
    }
    pub fn reference(name: impl Into<String>, mesh: Mesh) -> Self {
        AssemblyObject { name: name.into(), mesh, printable: false }
    }
}
