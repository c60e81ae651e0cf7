//! The sensor board (`kind = "sensor_board"`): the one definition of the force sensor that every
//! part is made for. Fingertips, the rig and (through their fingertip) the molds name the board file,
//! as a mold names its fingertip, and size their seats, pockets, slots and dome cavities from it,
//! so the sensor cannot be one size in one part and another in the next.

use super::{fields_of, Collector, Schema, SourceFile};
use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawBoard {
    pub kind: Option<String>,
    pub name: Option<String>,
    pub board_diameter_mm: Option<f64>,
    pub board_thickness_mm: Option<f64>,
    pub sensing_diameter_mm: Option<f64>,
    pub dome_diameter_mm: Option<f64>,
    pub dome_height_mm: Option<f64>,
    pub tail_width_mm: Option<f64>,
    pub tail_length_mm: Option<f64>,
    pub dome_stiffness_n_per_mm: Option<f64>,
}

pub static SCHEMA: Schema = Schema { fields: fields_of::<RawBoard>, tables: &[] };

/// A sensor board, in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct Board {
    pub board_diameter_mm: f64,
    pub board_thickness_mm: f64,
    /// The active area: the rig's frustum face is exactly this.
    pub sensing_diameter_mm: f64,
    pub dome_diameter_mm: f64,
    pub dome_height_mm: f64,
    pub tail_width_mm: f64,
    pub tail_length_mm: f64,
    pub dome_stiffness_n_per_mm: f64,
}

impl Board {
    pub fn from_source(src: &SourceFile) -> Result<Board> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&SCHEMA));
        let mut problems = Vec::new();
        let raw: Option<RawBoard> = src.table("", &mut problems);
        c.problems.extend(problems);
        let Some(r) = raw else { return super::finish(None, c.problems) };
        let disc = c.positive(r.board_diameter_mm, "board_diameter_mm", "8.6");
        let thick = c.positive(r.board_thickness_mm, "board_thickness_mm", "0.3");
        let sensing = c.positive(r.sensing_diameter_mm, "sensing_diameter_mm", "8.0");
        let dome_d = c.positive(r.dome_diameter_mm, "dome_diameter_mm", "8.0");
        let dome_h = c.positive(r.dome_height_mm, "dome_height_mm", "1.0");
        let tail_w = c.positive(r.tail_width_mm, "tail_width_mm", "1.4");
        let tail_l = c.positive(r.tail_length_mm, "tail_length_mm", "30.0");
        let k = c.or_within(r.dome_stiffness_n_per_mm, 20.0, "dome_stiffness_n_per_mm", 0.1, 1.0e5);
        if let (Some(d), Some(b)) = (dome_d, disc) {
            if d > b {
                c.push("dome_diameter_mm", d, format!("the dome must fit on the board ({b} mm)"));
            }
        }
        if let (Some(s), Some(d)) = (sensing, dome_d) {
            if s > d {
                c.push("sensing_diameter_mm", s, format!("the sensing area lies under the dome: at most the dome's {d} mm"));
            }
        }
        if let (Some(w), Some(b)) = (tail_w, disc) {
            if w >= b {
                c.push("tail_width_mm", w, format!("the tail must be narrower than the board ({b} mm)"));
            }
        }
        let v = match (disc, thick, sensing, dome_d, dome_h, tail_w, tail_l, k) {
            (Some(a), Some(b), Some(s), Some(d), Some(h), Some(w), Some(l), Some(k)) => Some(Board {
                board_diameter_mm: a,
                board_thickness_mm: b,
                sensing_diameter_mm: s,
                dome_diameter_mm: d,
                dome_height_mm: h,
                tail_width_mm: w,
                tail_length_mm: l,
                dome_stiffness_n_per_mm: k,
            }),
            _ => None,
        };
        super::finish(v, c.problems)
    }
}

/// The board a part file names with `sensor_board = "<file>"` (relative to `dir`, the part file's
/// folder); problems are added to `c` (the part file's) or are the board file's own.
pub fn named(c: &mut Collector, src: &SourceFile, dir: &Path) -> Result<Option<Board>> {
    let file = match src.value.get("sensor_board") {
        Some(toml::Value::String(f)) => f.clone(),
        Some(v) => {
            c.push("sensor_board", v, "must be a file name string, e.g. sensor_board = \"fsr-8mm.toml\"");
            return Ok(None);
        }
        None => {
            c.push("sensor_board", "missing", "required: the sensor board file this part is made for, e.g. sensor_board = \"fsr-8mm.toml\" (kind = \"sensor_board\")");
            return Ok(None);
        }
    };
    let Some(bsrc) = super::read_named(c, "sensor_board", &file, dir, super::Kind::SensorBoard, "a sensor board file (kind = \"sensor_board\")")? else {
        return Ok(None);
    };
    match Board::from_source(&bsrc) {
        Ok(b) => Ok(Some(b)),
        Err(Error::Input(p)) => {
            c.problems.extend(p.0);
            Ok(None)
        }
        Err(e) => Err(e),
    }
}
