//! PrusaSlicer as the judge of a printed part: `tipforge build --slice` slices every printed part
//! with the profile kept in the repository (scripts/slicer/pla-0.4-0.2.ini: 0.4 mm nozzle, 0.2 mm
//! layers, PLA), where its file puts it, and reads the print time and filament mass from the
//! G-code. The slicer is an external program (Debian's `prusa-slicer`, installed by
//! scripts/install-slicer); scripts/check_slicer.py checks the same G-code independently.

use crate::error::{Error, Problem, Problems, Result};
use std::path::Path;
use std::process::Command;

/// The print profile, embedded so the binary slices the same way wherever it runs.
pub const PROFILE: &str = include_str!("../scripts/slicer/pla-0.4-0.2.ini");
/// The bed of the repository's print profile (x, y in mm; `bed_shape` in scripts/slicer/pla-0.4-0.2.ini).
pub const PROFILE_BED_MM: [f64; 2] = [250.0, 210.0];
pub const PROFILE_NAME: &str = "scripts/slicer/pla-0.4-0.2.ini";
const PROGRAM: &str = "prusa-slicer";

/// What slicing a part gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Print {
    pub time_s: f64,
    pub filament_g: f64,
    pub layers: usize,
}

/// The slicer's version line, or an input error saying how to install it.
pub fn version() -> Result<String> {
    let out = Command::new(PROGRAM).arg("--help").output().map_err(|_| missing())?;
    let text = String::from_utf8_lossy(&out.stdout);
    Ok(text.lines().next().unwrap_or(PROGRAM).trim().to_string())
}

fn missing() -> Error {
    Error::Input(Problems(vec![Problem::new(
        "--slice",
        "--slice",
        PROGRAM,
        "needs PrusaSlicer's command line (prusa-slicer) on PATH: run scripts/install-slicer, or build without --slice",
    )]))
}

/// Slices one STL (its bytes) in a private temporary folder.
pub fn slice(name: &str, stl: &[u8]) -> Result<Print> {
    let dir = std::env::temp_dir().join(format!("tipforge-slice-{}-{}", std::process::id(), name));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let result = slice_in(&dir, name, stl);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn slice_in(dir: &Path, name: &str, stl: &[u8]) -> Result<Print> {
    let (model, profile, gcode) = (dir.join(format!("{name}.stl")), dir.join("profile.ini"), dir.join(format!("{name}.gcode")));
    std::fs::write(&model, stl).map_err(|e| Error::io(&model, e))?;
    std::fs::write(&profile, PROFILE).map_err(|e| Error::io(&profile, e))?;
    let out = Command::new(PROGRAM)
        .args(["--loglevel", "1", "--export-gcode", "--dont-arrange", "--load"])
        .arg(&profile)
        .arg("--output")
        .arg(&gcode)
        .arg(&model)
        .output()
        .map_err(|_| missing())?;
    if !out.status.success() {
        return Err(Error::geometry(name, format!("PrusaSlicer failed ({}): {}", out.status, String::from_utf8_lossy(&out.stderr).trim())));
    }
    let text = std::fs::read_to_string(&gcode).map_err(|e| Error::io(&gcode, e))?;
    parse(&text).ok_or_else(|| Error::geometry(name, "PrusaSlicer wrote G-code without its print time or filament mass"))
}

/// Print time, filament mass and layer count from PrusaSlicer's G-code comments.
pub fn parse(gcode: &str) -> Option<Print> {
    let (mut time_s, mut filament_g, mut layers) = (None, None, 0);
    for line in gcode.lines() {
        if line == ";LAYER_CHANGE" {
            layers += 1;
        } else if let Some(v) = line.strip_prefix("; estimated printing time (normal mode) =") {
            time_s = duration_s(v.trim());
        } else if let Some(v) = line.strip_prefix("; total filament used [g] =") {
            filament_g = v.trim().parse().ok();
        } else if let (Some(v), None) = (line.strip_prefix("; filament used [g] ="), filament_g) {
            filament_g = v.split(',').map(|x| x.trim().parse::<f64>().ok()).sum();
        }
    }
    Some(Print { time_s: time_s?, filament_g: filament_g?, layers })
}

/// "1d 2h 3m 4s" → seconds.
fn duration_s(text: &str) -> Option<f64> {
    let mut total = 0.0;
    for part in text.split_whitespace() {
        let (num, unit) = part.split_at(part.len().checked_sub(1)?);
        let n: f64 = num.parse().ok()?;
        total += n * match unit {
            "d" => 86400.0,
            "h" => 3600.0,
            "m" => 60.0,
            "s" => 1.0,
            _ => return None,
        };
    }
    Some(total)
}

/// "1h 21m 49s" for a summary line.
pub fn hms(s: f64) -> String {
    let s = s.round() as u64;
    match (s / 3600, s % 3600 / 60, s % 60) {
        (0, m, sec) => format!("{m}m {sec:02}s"),
        (h, m, sec) => format!("{h}h {m:02}m {sec:02}s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_g_code_comments_give_time_mass_and_layers() {
        let g = ";LAYER_CHANGE\n;Z:0.2\nG1 X1 E1\n;LAYER_CHANGE\n;Z:0.4\n; estimated printing time (normal mode) = 1h 21m 49s\n; total filament used [g] = 15.03\n";
        let p = parse(g).unwrap();
        assert_eq!(p, Print { time_s: 4909.0, filament_g: 15.03, layers: 2 });
        assert_eq!(hms(p.time_s), "1h 21m 49s");
        assert!(parse(";LAYER_CHANGE\n").is_none(), "no statistics: no print");
        assert_eq!(duration_s("2d 0h 1m 0s"), Some(172860.0));
    }
}
