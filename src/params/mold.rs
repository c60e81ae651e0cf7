//! PDMS cover mold parameters. A mold file names its fingertip file; the cover and the mold are
//! derived from that fingertip's body and sensor seats, so nothing is entered twice.
//!
//! Design frame = the fingertip's (x from the mount face to the tip, y lateral, z toward the nail;
//! the pad at negative z). The mold opens along z: the shell (below the parting plane) comes off
//! downward, the core (above it, carrying the fingertip-shaped plug) upward.

use super::fingertip::FingertipParams;
use super::{fields_of, Collector, Schema, SourceFile};
use crate::error::{Error, Result};
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawCover {
    pub thickness_mm: Option<f64>,
    pub from_tip_mm: Option<f64>,
    pub dome_clearance_mm: Option<f64>,
    pub shrinkage_percent: Option<f64>,
    pub mix_ratio: Option<f64>,
    pub waste_margin_percent: Option<f64>,
    pub density_g_cm3: Option<f64>,
    pub profile: Option<String>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawMold {
    pub wall_thickness_mm: Option<f64>,
    pub parting_below_midplane_mm: Option<f64>,
    pub demolding_tilt_deg: Option<f64>,
    pub draft_deg: Option<f64>,
    pub key_count: Option<i64>,
    pub key_diameter_mm: Option<f64>,
    pub key_height_mm: Option<f64>,
    pub key_clearance_mm: Option<f64>,
    pub sprue_diameter_mm: Option<f64>,
    pub sprue_taper_deg: Option<f64>,
    pub sprue_xy_mm: Option<Vec<f64>>,
    pub vent_count: Option<i64>,
    pub vent_diameter_mm: Option<f64>,
    pub cavities: Option<i64>,
    pub material: Option<String>,
    pub min_detail_mm: Option<f64>,
    pub min_wall_mm: Option<f64>,
    pub density_g_cm3: Option<f64>,
    pub chordal_tolerance_mm: Option<f64>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawFlat {
    pub margin_mm: Option<f64>,
}

static COVER_SCHEMA: Schema = Schema { fields: fields_of::<RawCover>, tables: &[] };
static MOLD_SCHEMA: Schema = Schema { fields: fields_of::<RawMold>, tables: &[] };
static FLAT_SCHEMA: Schema = Schema { fields: fields_of::<RawFlat>, tables: &[] };
pub static SCHEMA: Schema =
    Schema { fields: || &["kind", "name", "fingertip", "style"], tables: &[("cover", false, &COVER_SCHEMA), ("mold", false, &MOLD_SCHEMA), ("flat", false, &FLAT_SCHEMA)] };

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Two-part mold cast to the fingertip's own pad shape.
    Conforming,
    /// The paper's petri-dish method: a flat sheet with dome patterns, cut and glued on.
    Flat,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Material {
    Pla,
    Petg,
    Resin,
}

impl Material {
    pub fn name(self) -> &'static str {
        match self {
            Material::Pla => "PLA",
            Material::Petg => "PETG",
            Material::Resin => "resin",
        }
    }
    /// Highest cure temperature the printed mold takes (°C).
    pub fn max_cure_c(self) -> f64 {
        match self {
            Material::Pla => 40.0,
            Material::Petg => 65.0,
            Material::Resin => 65.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Cover {
    pub thickness_mm: f64,
    pub from_tip_mm: f64,
    pub dome_clearance_mm: f64,
    pub shrinkage_percent: f64,
    pub mix_ratio: f64,
    pub waste_margin_percent: f64,
    pub density_g_cm3: f64,
    pub profile: CoverProfile,
}

/// How the cover's outer surface runs over a sensing area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoverProfile {
    /// A flat window parallel to the seat at the nominal thickness over the dome's top, reaching
    /// `UNIFORM_MARGIN_MM` past the sensing area and blending into the pad's offset by 45° cones:
    /// the thickness over the sensing area is the nominal.
    Uniform,
    /// The pad's exact offset everywhere: the flat's recess adds to the thickness and the pad's
    /// curvature takes away (the summary states the profile).
    FollowPad,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Mold {
    pub wall_thickness_mm: f64,
    pub parting_below_midplane_mm: f64,
    /// The opening direction, tilted within the finger's mid-plane (degrees): the direction the
    /// shell comes off (the pad's side) leans this much toward the tip; the core comes off the
    /// opposite way and the parting plane is square to it.
    pub demolding_tilt_deg: f64,
    pub draft_deg: f64,
    pub key_count: usize,
    pub key_diameter_mm: f64,
    pub key_height_mm: f64,
    pub key_clearance_mm: f64,
    pub sprue_diameter_mm: f64,
    pub sprue_taper_deg: f64,
    /// The rim point (x, y, mold frame) the sprue pours at (its axis stands outward of it); None = the tip.
    pub sprue_xy_mm: Option<[f64; 2]>,
    pub vent_count: usize,
    pub vent_diameter_mm: f64,
    /// Covers cast at once: the core and the shell carry this many cavities side by side.
    pub cavities: usize,
    pub material: Material,
    pub min_detail_mm: f64,
    pub min_wall_mm: f64,
    pub density_g_cm3: f64,
    pub chordal_tolerance_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct MoldParams {
    pub name: String,
    /// The fingertip file as written in the mold file, and its validated parameters.
    pub fingertip_file: String,
    pub fingertip: FingertipParams,
    /// The fingertip file's text, so that the fingertip's own rules name its lines.
    pub fingertip_src: SourceFile,
    pub style: Style,
    pub cover: Cover,
    pub mold: Mold,
    pub flat_margin_mm: f64,
}

impl MoldParams {
    /// The output stem of the cover this mold casts (`mold-1s` → `cover-1s`).
    pub fn cover_name(&self) -> String {
        match self.name.strip_prefix("mold-") {
            Some(rest) => format!("cover-{rest}"),
            None => format!("{}-cover", self.name),
        }
    }

    /// Parses and type-checks a mold file and the fingertip file it names (relative to `dir`, the
    /// mold file's folder). Every problem of both files is collected. The geometric rules of both
    /// live with their families and are applied by [`crate::mold::load`].
    pub fn from_source(src: &SourceFile, default_name: &str, dir: &Path) -> Result<MoldParams> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&SCHEMA));
        if !c.problems.is_empty() {
            return super::finish(None, c.problems);
        }
        let mut problems = Vec::new();
        let cv: Option<RawCover> = src.table("cover", &mut problems);
        let md: Option<RawMold> = src.table("mold", &mut problems);
        let fl: Option<RawFlat> = src.table("flat", &mut problems);
        c.problems.extend(problems);
        let name = super::part_name(src, default_name, &mut c.problems);
        let style = match src.value.get("style") {
            None => Some(Style::Conforming),
            Some(toml::Value::String(s)) if s == "conforming" => Some(Style::Conforming),
            Some(toml::Value::String(s)) if s == "flat" => Some(Style::Flat),
            Some(v) => {
                c.push("style", v, "use \"conforming\" (cast to the fingertip's shape) or \"flat\" (the paper's petri-dish sheet)");
                None
            }
        };
        let fingertip = match src.value.get("fingertip") {
            Some(toml::Value::String(f)) => match super::read_named(&mut c, "fingertip", f, dir, super::Kind::Fingertip, "a fingertip file")? {
                Some(fsrc) => {
                    let stem = Path::new(f).file_stem().and_then(|s| s.to_str()).unwrap_or("fingertip").to_string();
                    match FingertipParams::from_source(&fsrc, &stem, dir) {
                        Ok(p) => Some((f.clone(), p, fsrc)),
                        Err(Error::Input(p)) => {
                            c.problems.extend(p.0);
                            None
                        }
                        Err(e) => return Err(e),
                    }
                }
                None => None,
            },
            Some(v) => {
                c.push("fingertip", v, "must be a file name string, e.g. fingertip = \"fingertip-1s.toml\"");
                None
            }
            None => {
                c.push("fingertip", "missing", "required: the fingertip file this cover fits, e.g. fingertip = \"fingertip-1s.toml\"");
                None
            }
        };
        let (Some(cv), Some(md), Some(fl)) = (cv, md, fl) else {
            return super::finish(None, c.problems);
        };
        let cover = cover_params(&mut c, &cv);
        let mold = mold_params(&mut c, &md);
        let margin = c.or_within(fl.margin_mm, 5.0, "flat.margin_mm", 1.0, 50.0);
        let v = match (name, style, fingertip, cover, mold, margin) {
            (Some(name), Some(style), Some((ff, fp, fsrc)), Some(cover), Some(mold), Some(flat_margin_mm)) => {
                Some(MoldParams { name, fingertip_file: ff, fingertip: fp, fingertip_src: fsrc, style, cover, mold, flat_margin_mm })
            }
            _ => None,
        };
        super::finish(v, c.problems)
    }
}

fn cover_params(c: &mut Collector, r: &RawCover) -> Option<Cover> {
    let t = c.or_within(r.thickness_mm, 1.5, "cover.thickness_mm", 0.05, 10.0);
    let from_tip = c.or_within(r.from_tip_mm, 20.0, "cover.from_tip_mm", 2.0, 200.0);
    let clear = c.or_within(r.dome_clearance_mm, 0.3, "cover.dome_clearance_mm", 0.0, 3.0);
    let shrink = c.or_within(r.shrinkage_percent, 1.0, "cover.shrinkage_percent", 0.0, 5.0);
    let ratio = c.or_within(r.mix_ratio, 10.0, "cover.mix_ratio", 3.0, 30.0);
    let waste = c.or_within(r.waste_margin_percent, 25.0, "cover.waste_margin_percent", 0.0, 500.0);
    let density = c.or_within(r.density_g_cm3, 1.03, "cover.density_g_cm3", 0.5, 3.0);
    let profile = match r.profile.as_deref() {
        None | Some("uniform") => Some(CoverProfile::Uniform),
        Some("follow_pad") => Some(CoverProfile::FollowPad),
        Some(other) => {
            c.push("cover.profile", other, "use \"uniform\" (the nominal thickness over each sensing area) or \"follow_pad\" (the pad's offset everywhere)");
            None
        }
    };
    Some(Cover {
        thickness_mm: t?,
        from_tip_mm: from_tip?,
        dome_clearance_mm: clear?,
        shrinkage_percent: shrink?,
        mix_ratio: ratio?,
        waste_margin_percent: waste?,
        density_g_cm3: density?,
        profile: profile?,
    })
}

fn count(c: &mut Collector, v: Option<i64>, default: i64, path: &str, lo: i64, hi: i64) -> Option<usize> {
    let x = v.unwrap_or(default);
    if !(lo..=hi).contains(&x) {
        c.push(path, x, format!("must be a whole number from {lo} to {hi} (default {default})"));
        return None;
    }
    Some(x as usize)
}

fn mold_params(c: &mut Collector, r: &RawMold) -> Option<Mold> {
    let wall = c.or_within(r.wall_thickness_mm, 3.0, "mold.wall_thickness_mm", 0.8, 30.0);
    let parting = c.or_within(r.parting_below_midplane_mm, 1.0, "mold.parting_below_midplane_mm", 0.0, 50.0);
    let tilt = c.or_within(r.demolding_tilt_deg, 0.0, "mold.demolding_tilt_deg", -20.0, 20.0);
    let draft = c.or_within(r.draft_deg, 1.0, "mold.draft_deg", 0.0, 15.0);
    let keys = count(c, r.key_count, 3, "mold.key_count", 2, 4);
    let key_d = c.or_within(r.key_diameter_mm, 4.0, "mold.key_diameter_mm", 1.0, 20.0);
    let key_h = c.or_within(r.key_height_mm, 3.0, "mold.key_height_mm", 0.5, 20.0);
    let key_c = c.or_within(r.key_clearance_mm, 0.2, "mold.key_clearance_mm", 0.0, 2.0);
    let sprue_d = c.or_within(r.sprue_diameter_mm, 3.0, "mold.sprue_diameter_mm", 0.5, 20.0);
    let sprue_taper = c.or_within(r.sprue_taper_deg, 15.0, "mold.sprue_taper_deg", 0.0, 45.0);
    let sprue_xy = match &r.sprue_xy_mm {
        None => Some(None),
        Some(v) if v.len() == 2 && v.iter().all(|x| x.is_finite()) => Some(Some([v[0], v[1]])),
        Some(v) => {
            c.push("mold.sprue_xy_mm", format!("{v:?}"), "must be two numbers [x, y] in the fingertip's frame, or left out to pour at the tip");
            None
        }
    };
    let vents = count(c, r.vent_count, 3, "mold.vent_count", 1, 12);
    let vent_d = c.or_within(r.vent_diameter_mm, 0.8, "mold.vent_diameter_mm", 0.3, 5.0);
    let cavities = count(c, r.cavities, 1, "mold.cavities", 1, 12);
    let material = match r.material.as_deref() {
        None | Some("PLA") | Some("pla") => Some(Material::Pla),
        Some("PETG") | Some("petg") => Some(Material::Petg),
        Some("resin") => Some(Material::Resin),
        Some(other) => {
            c.push("mold.material", other, "use \"PLA\", \"PETG\" or \"resin\" (it sets the highest cure temperature)");
            None
        }
    };
    let detail = c.or_within(r.min_detail_mm, 0.4, "mold.min_detail_mm", 0.05, 5.0);
    let min_wall = c.or_within(r.min_wall_mm, 1.2, "mold.min_wall_mm", 0.2, 10.0);
    let density = c.or_within(r.density_g_cm3, 1.24, "mold.density_g_cm3", 0.1, 25.0);
    let tol = c.or_within(r.chordal_tolerance_mm, 0.02, "mold.chordal_tolerance_mm", 0.002, 0.05);
    if let (Some(w), Some(m)) = (wall, min_wall) {
        if w < m {
            c.push("mold.wall_thickness_mm", w, format!("must be at least the minimum wall {m} mm"));
        }
    }
    Some(Mold {
        wall_thickness_mm: wall?,
        parting_below_midplane_mm: parting?,
        demolding_tilt_deg: tilt?,
        draft_deg: draft?,
        key_count: keys?,
        key_diameter_mm: key_d?,
        key_height_mm: key_h?,
        key_clearance_mm: key_c?,
        sprue_diameter_mm: sprue_d?,
        sprue_taper_deg: sprue_taper?,
        sprue_xy_mm: sprue_xy?,
        vent_count: vents?,
        vent_diameter_mm: vent_d?,
        cavities: cavities?,
        material: material?,
        min_detail_mm: detail?,
        min_wall_mm: min_wall?,
        density_g_cm3: density?,
        chordal_tolerance_mm: tol?,
    })
}
