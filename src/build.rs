//! `tipforge build`: every part file in the params folder → validated params → part → checks →
//! STL + 3MF + manifest, written atomically. All input problems of all files are reported at once.

use crate::error::{Error, Gather, Problem, Problems, Result};
use crate::export::{manifest, stl, threemf, Staged};
use crate::params::{self, fingertip::FingertipParams, Kind, SourceFile};
use crate::part::{Assembly, Part};
use rayon::prelude::*;
use serde_json::Map;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub struct Options {
    pub params_dir: PathBuf,
    pub out_dir: PathBuf,
    /// Build only these file stems (empty: all).
    pub only: Vec<String>,
    /// Also write `<part>.png` previews.
    pub preview: bool,
    /// Also slice every printed part with PrusaSlicer (print time and filament into the manifest
    /// and the summary).
    pub slice: bool,
}

/// What one built part reports in the summary.
#[derive(Debug, Clone)]
pub struct Summary {
    pub name: String,
    pub triangles: usize,
    pub volume_mm3: f64,
    pub mass_g: f64,
    pub millis: f64,
}

pub struct Report {
    pub summaries: Vec<Summary>,
    pub written: Vec<PathBuf>,
    pub skipped: Skipped,
    pub notes: Vec<String>,
}

/// A validated part file, ready to build (a handful per build: the size difference of the
/// variants does not matter).
#[allow(clippy::large_enum_variant)]
pub enum Job {
    Fingertip(FingertipParams),
    Rig(crate::params::rig::RigParams),
    Mold(crate::params::mold::MoldParams),
    Hand(crate::params::hand::HandParams),
}

/// What building one file gives: parts, assembly views, assembly violations, manifest sections.
pub struct Built {
    pub parts: Vec<Part>,
    pub assemblies: Vec<Assembly>,
    pub violations: Vec<crate::checks::Violation>,
    /// Top-level manifest sections keyed by section name ("rigs", ...), merged across files.
    pub sections: Vec<(&'static str, Map<String, serde_json::Value>)>,
    /// Plain-words lines for the build summary (material estimates, cure advice).
    pub notes: Vec<String>,
}

pub struct Loaded {
    pub src: SourceFile,
    pub rel: String,
    pub job: Job,
}

/// The files of the params folder, sorted.
pub fn part_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut v: Vec<PathBuf> = rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "toml")).collect();
    v.sort();
    Ok(v)
}

/// Files in the params folder that are not part files, each with the reason.
pub type Skipped = Vec<(String, &'static str)>;

/// Whether a PART argument is a path (`params/fingertip-1s.toml`, `../lab/my.toml`) rather than a
/// stem of a file in the params folder (`fingertip-1s`).
fn is_path(arg: &str) -> bool {
    arg.ends_with(".toml") || arg.contains('/') || arg.contains(std::path::MAIN_SEPARATOR)
}

/// The files to build: every `.toml` in the params folder, or the PART arguments, each a stem of a
/// file there or a path. The flag says whether the files were named one by one.
fn files_to_build(opts: &Options, problems: &mut Vec<Problem>) -> Result<(Vec<PathBuf>, bool)> {
    if opts.only.is_empty() {
        let files = part_files(&opts.params_dir).map_err(|e| e.io_as_input("--params", "give --params the folder of parameter files (default params)"))?;
        return Ok((files, false));
    }
    let mut files = Vec::new();
    // the folder's stems, for "did you mean": listed once
    let stems: Vec<String> = part_files(&opts.params_dir).unwrap_or_default().iter().filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(str::to_string)).collect();
    let known: Vec<&str> = stems.iter().map(String::as_str).collect();
    for arg in &opts.only {
        if is_path(arg) {
            let path = PathBuf::from(arg);
            if path.is_file() {
                files.push(path);
            } else {
                problems.push(Problem::new(
                    arg.clone(),
                    "PART",
                    arg,
                    format!("no such file: {arg}; give a parameter file's path, or the stem of a file in {}", opts.params_dir.display()),
                ));
            }
            continue;
        }
        let path = opts.params_dir.join(format!("{arg}.toml"));
        if path.is_file() {
            files.push(path);
            continue;
        }
        let hint = match params::nearest(arg, &known) {
            Some(s) => format!("did you mean `{s}`?"),
            None if known.is_empty() => format!("{} holds no .toml files", opts.params_dir.display()),
            None => format!("the files there are: {}", known.join(", ")),
        };
        problems.push(Problem::new(opts.params_dir.display().to_string(), "PART", arg, format!("no {arg}.toml in {}; {hint}", opts.params_dir.display())));
    }
    files.dedup();
    Ok((files, true))
}

/// Reads and validates every part file, collecting every problem of every file.
pub fn load_all(opts: &Options) -> Result<(Vec<Loaded>, Skipped)> {
    let mut problems: Vec<Problem> = Vec::new();
    let mut loaded = Vec::new();
    let mut skipped = Vec::new();
    let (files, named) = files_to_build(opts, &mut problems)?;
    for path in files {
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("").to_string();
        let src = match params::read_source(&path) {
            Ok(s) => s,
            Err(Error::Input(p)) => {
                problems.extend(p.0);
                continue;
            }
            Err(e) => return Err(e),
        };
        let kind = match params::kind_of(&src) {
            Ok(k) => k,
            Err(p) => {
                problems.push(p);
                continue;
            }
        };
        if !kind.is_part() {
            if named {
                problems.push(src.problem(
                    "kind",
                    format!("{kind:?}").to_lowercase(),
                    format!("{stem} is not a part file: `build` makes fingertips, rigs, molds and hand sets; sensor board files are named by the parts, sensor and protocol files are read by `simulate`"),
                ));
            } else {
                skipped.push((path.display().to_string(), "not a part file (a sensor board, sensor model or protocol)"));
            }
            continue;
        }
        let rel = path.display().to_string();
        let job = match kind {
            Kind::Fingertip => crate::fingertip::load(&src, &stem, path.parent().unwrap_or(Path::new("."))).map(Job::Fingertip),
            Kind::Rig => crate::params::rig::RigParams::from_source(&src, &stem, path.parent().unwrap_or(Path::new("."))).map(Job::Rig),
            Kind::Mold => crate::mold::load(&src, &stem, path.parent().unwrap_or(Path::new("."))).map(Job::Mold),
            Kind::Hand => crate::hand::load(&src, &stem, path.parent().unwrap_or(Path::new("."))).map(Job::Hand),
            _ => {
                skipped.push((rel, "part kind not built by this version"));
                continue;
            }
        };
        match job {
            Ok(job) => loaded.push(Loaded { src, rel, job }),
            Err(Error::Input(p)) => problems.extend(p.0),
            Err(e) => return Err(e),
        }
    }
    if !problems.is_empty() {
        return Err(Error::Input(Problems(problems)));
    }
    Ok((loaded, skipped))
}

/// Builds the parts of one loaded file.
pub fn build_job(job: &Job) -> Result<Built> {
    match job {
        Job::Fingertip(p) => Ok(Built { parts: vec![crate::fingertip::build(p)?], assemblies: vec![], violations: vec![], sections: vec![], notes: vec![] }),
        Job::Rig(p) => {
            let b = crate::rig::build(p)?;
            let l = crate::rig::layout(p);
            let depth = l.base_top - l.seat_floor;
            let note = format!(
                "{}: seat recess {:.2} mm deep ({} layers of {} mm); the {} mm board sits {:.2} mm below the base top",
                p.name,
                depth,
                (depth / p.layer_height_mm).round(),
                p.layer_height_mm,
                p.sensor.board_thickness_mm,
                depth - p.sensor.board_thickness_mm
            );
            Ok(Built { parts: b.parts, assemblies: b.assemblies, violations: b.violations, sections: vec![("rigs", b.manifest)], notes: vec![note] })
        }
        Job::Mold(p) => {
            let b = crate::mold::build(p)?;
            Ok(Built { parts: b.parts, assemblies: b.assemblies, violations: b.violations, sections: vec![("molds", b.manifest)], notes: b.notes })
        }
        Job::Hand(p) => {
            let b = crate::hand::build(p)?;
            Ok(Built { parts: b.parts, assemblies: b.assemblies, violations: vec![], sections: vec![("hands", b.manifest)], notes: b.notes })
        }
    }
}

/// What one parameter file gives the build: its files (bytes, not yet written), manifest entries,
/// summary rows, check violations, manifest sections and notes.
pub struct Outputs {
    pub files: Vec<(PathBuf, Vec<u8>)>,
    pub entries: Vec<(String, serde_json::Value)>,
    pub summaries: Vec<Summary>,
    pub violations: Vec<crate::checks::Violation>,
    pub sections: Vec<(&'static str, Map<String, serde_json::Value>)>,
    pub notes: Vec<String>,
}

/// Builds one loaded file and renders its outputs: parts, checks, STL, 3MF and previews. The parts
/// of a file are serialised in parallel.
pub fn outputs_of(l: &Loaded, out_dir: &Path, preview: bool, slice: bool) -> Result<Outputs> {
    let t0 = Instant::now();
    let Built { parts, assemblies, violations, sections, notes } = build_job(&l.job)?;
    let per_part_ms = t0.elapsed().as_secs_f64() * 1000.0 / parts.len().max(1) as f64;
    let sha = manifest::sha256_hex(l.src.text.as_bytes());
    let mut out = Outputs { files: Vec::new(), entries: Vec::new(), summaries: Vec::new(), violations, sections, notes };
    let per_part: Vec<PartOutputs> = parts.par_iter().map(|part| part_outputs(part, out_dir, preview, slice)).collect::<Result<_>>()?;
    for (part, (violations, files, print)) in parts.iter().zip(per_part) {
        out.violations.extend(violations);
        let names: Vec<String> = files.iter().filter_map(|(p, _)| p.file_name().and_then(|n| n.to_str()).map(str::to_string)).collect();
        let mut entry = manifest::entry(part, &l.rel, &sha, &names);
        if let (Some(pr), serde_json::Value::Object(e)) = (&print, &mut entry) {
            e.insert(
                "print".into(),
                serde_json::json!({"time_s": pr.time_s, "filament_g": pr.filament_g, "layers": pr.layers, "profile": crate::slicer::PROFILE_NAME, "slicer": "PrusaSlicer"}),
            );
            out.notes.push(format!(
                "{}: prints in {}, {:.2} g of PLA, {} layers (PrusaSlicer, {})",
                part.name,
                crate::slicer::hms(pr.time_s),
                pr.filament_g,
                pr.layers,
                crate::slicer::PROFILE_NAME
            ));
        }
        out.entries.push((part.name.clone(), entry));
        out.summaries.push(Summary { name: part.name.clone(), triangles: part.mesh.triangles.len(), volume_mm3: part.volume_mm3(), mass_g: part.mass_g(), millis: per_part_ms });
        out.files.extend(files);
    }
    let per_assembly: Vec<_> = assemblies.par_iter().map(|a| assembly_outputs(a, out_dir, preview)).collect();
    out.files.extend(per_assembly.into_iter().flatten());
    if let (true, Job::Fingertip(p), Some(part)) = (preview, &l.job, parts.first()) {
        if let Some(png) = crate::fingertip::section_plot::render(p, &part.mesh) {
            out.files.push((out_dir.join(format!("{}-sections.png", part.name)), png));
        }
    }
    Ok(out)
}

/// A part's checks and files: STL, 3MF when asked, PNG preview when asked.
type PartOutputs = (Vec<crate::checks::Violation>, Vec<(PathBuf, Vec<u8>)>, Option<crate::slicer::Print>);

fn part_outputs(part: &Part, out_dir: &Path, preview: bool, slice: bool) -> Result<PartOutputs> {
    let violations = crate::checks::run(part);
    let stl_bytes = stl::to_bytes(&part.mesh);
    let print = if slice && part.process == crate::part::Process::Printed { Some(crate::slicer::slice(&part.name, &stl_bytes)?) } else { None };
    let mut files = vec![(out_dir.join(format!("{}.stl", part.name)), stl_bytes)];
    if part.write_3mf {
        files.push((out_dir.join(format!("{}.3mf", part.name)), threemf::to_bytes(&[threemf::Object::printed(&part.name, &part.mesh)])));
    }
    if preview {
        files.push((out_dir.join(format!("{}.png", part.name)), crate::preview::render(&part.mesh, &part.name)));
    }
    Ok((violations, files, print))
}

/// An assembly view's 3MF (reference objects typed as such) and preview.
fn assembly_outputs(a: &Assembly, out_dir: &Path, preview: bool) -> Vec<(PathBuf, Vec<u8>)> {
    let objs: Vec<threemf::Object> = a.parts.iter().map(|o| threemf::Object { name: &o.name, mesh: &o.mesh, printable: o.printable }).collect();
    let mut files = vec![(out_dir.join(format!("{}.3mf", a.name)), threemf::to_bytes(&objs))];
    if preview {
        let merged = crate::mesh::Mesh::merge(a.parts.iter().map(|o| &o.mesh));
        files.push((out_dir.join(format!("{}.png", a.name)), crate::preview::render(&merged, &a.name)));
    }
    files
}

/// Builds every loaded file, in parallel (rayon: one task per file, and per part within a file).
/// The results come back in the files' order, so the output is the same whatever the scheduling.
pub fn outputs_of_all(loaded: &[Loaded], out_dir: &Path, preview: bool, slice: bool, bar: Option<&crate::progress::Progress>) -> Result<Vec<Outputs>> {
    loaded
        .par_iter()
        .map(|l| {
            let o = outputs_of(l, out_dir, preview, slice);
            if let Some(bar) = bar {
                bar.step(format!("built {}", l.rel));
            }
            o
        })
        .collect()
}

/// The whole build: load, build, check, write.
pub fn run(opts: &Options) -> Result<Report> {
    let mut g = Gather::default();
    g.take(crate::export::check_out_dir(&opts.out_dir, "--out", "give --out a folder (it is created if missing)"))?;
    let loaded = g.take(load_all(opts))?;
    let (loaded, skipped) = g.finish(loaded)?;
    let mut staged = Staged::default();
    let mut entries = Map::new();
    let mut summaries = Vec::new();
    let mut violations = Vec::new();
    let mut sections = Map::new();
    let mut notes = Vec::new();
    let bar = crate::progress::Progress::new("build", loaded.len() + 1);
    if opts.slice {
        crate::slicer::version()?;
    }
    for o in outputs_of_all(&loaded, &opts.out_dir, opts.preview, opts.slice, Some(&bar))? {
        notes.extend(o.notes);
        violations.extend(o.violations);
        for (k, m) in o.sections {
            let entry = sections.entry(k.to_string()).or_insert_with(|| serde_json::Value::Object(Map::new()));
            if let serde_json::Value::Object(obj) = entry {
                obj.extend(m);
            }
        }
        for (path, bytes) in o.files {
            staged.add(path, bytes);
        }
        entries.extend(o.entries);
        summaries.extend(o.summaries);
    }
    if !violations.is_empty() {
        let msg = violations.iter().map(|v| format!("  {v}")).collect::<Vec<_>>().join("\n");
        return Err(Error::geometry("build", format!("checks failed, nothing written:\n{msg}")));
    }
    // from here to the commit the folder is this run's: a concurrent build waits, so the manifest
    // read below is the one this commit replaces
    let lock = crate::export::outdir::OutLock::acquire(&opts.out_dir)?;
    if !opts.only.is_empty() {
        // a build of some parts keeps the manifest's entries of the others, whose files stay in out/
        if let Some(old) = std::fs::read(opts.out_dir.join("manifest.json")).ok().and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok()) {
            manifest::keep_others(&old, &mut entries, &mut sections);
        }
    }
    staged.add(opts.out_dir.join("manifest.json"), manifest::document(entries, sections));
    bar.step(format!("writing {}", opts.out_dir.display()));
    let written = staged.commit(&lock)?;
    Ok(Report { summaries, written, skipped, notes })
}
