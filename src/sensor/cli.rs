//! Library side of the `fit` and `simulate` commands (the binary only parses arguments).

use super::analyze::{self, Method, Options};
use super::recording::{self, Recording};
use super::sim::{self, Cover};
use crate::error::{Error, Gather, Result};
use crate::export::Staged;
use crate::params::read_source;
use crate::params::sensor::{ProtocolParams, SensorParams};
use crate::progress::Progress;
use std::path::{Path, PathBuf};

fn out_dir(out: &Path) -> Result<()> {
    crate::export::check_out_dir(out, "--out", "give --out a folder (it is created if missing)")
}

/// Reads every recording, collecting every file's problems before failing.
pub fn read_all(paths: &[PathBuf], progress: Option<&Progress>) -> Result<Vec<Recording>> {
    let mut recs = Vec::new();
    let mut g = Gather::default();
    for p in paths {
        if let Some(bar) = progress {
            bar.step(format!("reading {}", p.display()));
        }
        recs.extend(g.take(recording::read(p).map_err(|e| e.io_as_input("(file)", "check the path")))?.map(super::decimate::to_working_rate));
    }
    let recs = g.finish(Some(recs))?;
    if recs.is_empty() {
        return Err(Error::input("(command line)", "REC", "none", "give at least one recording CSV"));
    }
    let units: Vec<&str> = recs.iter().map(|r| r.unit).collect();
    if units.iter().any(|u| *u != units[0]) {
        return Err(Error::input(&recs[0].source, "response unit", units.join(", "), "all recordings of one fit must have the same response unit"));
    }
    Ok(recs)
}

pub struct FitSummary {
    pub lines: Vec<String>,
    pub written: Vec<PathBuf>,
}

pub fn fit(paths: &[PathBuf], method: Method, filter: bool, actuator: bool, out: &Path) -> Result<FitSummary> {
    let mut g = Gather::default();
    g.take(out_dir(out))?;
    let bar = Progress::new("fit", paths.len() + 2);
    let recs = g.take(read_all(paths, Some(&bar)))?;
    let mut opts = Options { method, ..Options::default() };
    opts.pre.mean_filter = filter;
    opts.pre.handling = !actuator;
    if let Some(r) = &recs {
        g.0.extend(super::pooling::problems(paths, r, &opts.pre, false));
    }
    let recs = g.finish(recs)?;
    bar.step("fitting the steps");
    // an actuator's load ramps in, or a hand lowers it slowly: the steps are fitted from each ramp's
    // end (issue 15, item 1)
    opts.pre.ramp = super::diagnose::load_ramp(&recs, &opts);
    let (report, prep) = analyze::analyze(&recs, &opts);
    let mut lines = Vec::new();
    if let Some(r) = opts.pre.ramp {
        lines.push(format!(
            "load ramp ({}): {:.1} s {}, ending {:+.1} s from each logged change; the steps' k and τ are fitted from each ramp's end, the level before it",
            if actuator { "an actuator's" } else { "weights lowered slowly by hand" },
            r.duration_s,
            if r.smooth { "S-curve" } else { "at a constant speed" },
            r.end_after_log_s
        ));
    }
    for r in &report.recordings {
        lines.push(format!(
            "{}: {} samples at {:.2} Hz, {} steps, {} handling spike(s) excluded, noise {}",
            r.source,
            r.samples,
            r.sample_rate_hz,
            r.steps,
            r.spikes.len(),
            if r.filter_block > 1 {
                format!("{:.4} {u} raw, {:.4} {u} after the {}-sample mean filter", r.noise_sigma_raw, r.noise_sigma, r.filter_block, u = r.unit)
            } else {
                format!("{:.4} {} (raw samples, no filter)", r.noise_sigma_raw, r.unit)
            }
        ));
        for n in &r.notes {
            lines.push(format!("  note: {n}"));
        }
    }
    for s in &report.steps {
        let mut l = format!("{:?} step {} ({} → {}), {} trial(s):", s.phase, s.index + 1, s.before, s.after, s.trials);
        if let Some(f) = &s.lsq {
            l += &format!(" lsq k = {}", estimate(f.k, f.se_k, 4, &report.unit));
            if let Some(kw) = s.lsq_k_per_weight.filter(|x| x.is_finite()) {
                l += &format!(" ({:.4} {} per {})", kw, report.unit, s.weight_unit);
            }
            l += &format!(", τ = {}", estimate(f.tau_s, f.se_tau_s, 3, "s"));
            if let Some(e) = s.lsq_eq4 {
                l += &format!(", Eq.4 {e:.4}");
            }
            l += ";";
        }
        if let Some(p) = &s.paper {
            l += &format!(" paper k = {:.4} {} per {}, τ = {:.3} s, Eq.4 {:.4}", p.k, report.unit, s.weight_unit, p.tau_s, p.eq4);
        }
        lines.push(l);
        if let Some(why) = &s.tau_describes_creep {
            lines.push(format!("  creep-dominated: {why}"));
        }
        if let Some(b) = &s.bounded {
            lines.push(format!("  onset bounded: {}", b.why));
        }
    }
    if let Some(f) = &report.fashion {
        lines.push(format!("fashion: conductance ∝ (load + {:.1})^{:.3}; τ = {:.3} + {:.5}·load s", f.preload, f.n, f.tau0_s, f.tau1_s_per_unit));
    }
    for n in &report.notes {
        lines.push(format!("note: {n}"));
    }
    bar.step(format!("writing {}", out.display()));
    let written = analyze_stage(&report, &prep, method, out)?;
    Ok(FitSummary { lines, written })
}

fn analyze_stage(report: &analyze::Report, prep: &analyze::Prepared, method: Method, out: &Path) -> Result<Vec<PathBuf>> {
    let lock = crate::export::outdir::OutLock::acquire(out)?;
    super::output::stage(report, prep, method, out).commit(&lock)
}

/// A fitted value with its standard error; a value the data do not determine (no finite error,
/// or an error over 10 × the value) is said to be so instead of printing NaN or 10^14.
fn estimate(v: f64, se: f64, digits: usize, unit: &str) -> String {
    if !v.is_finite() {
        return "not determined".into();
    }
    if se.is_finite() && se <= 10.0 * v.abs() {
        format!("{v:.digits$} ± {se:.digits$} {unit}")
    } else {
        format!("{v:.digits$} {unit} (not determined by the data: the response hardly moves at this step)")
    }
}

/// Where the simulated load comes from.
pub fn preload_from_manifest(path: &Path) -> Result<f64> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e).io_as_input("(file)", "check the path given to --rig (the out/manifest.json a build wrote)"))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::input(path.display().to_string(), "(json)", "invalid", format!("not a tipforge manifest: {e}")))?;
    v.get("rigs")
        .and_then(|r| r.as_object())
        .and_then(|o| o.values().next())
        .and_then(|r| r.get("preload_g"))
        .and_then(|p| p.as_f64())
        .ok_or_else(|| Error::input(path.display().to_string(), "rigs.*.preload_g", "missing", "the manifest has no rig: run `tipforge build` with params/rig.toml first"))
}

/// Cover thickness and mix ratio from a mold file's `[cover]` table, and the dome diameter from
/// the fingertip file it refers to.
pub fn cover_from_mold(path: &Path, sensor: &SensorParams) -> Result<Cover> {
    let src = read_named(path, "--cover")?;
    let cover = src.value.get("cover");
    let num = |key: &str, default: f64| cover.and_then(|c| c.get(key)).and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64))).unwrap_or(default);
    let thickness = num("thickness_mm", 1.5);
    let ratio = num("mix_ratio", 10.0);
    if thickness <= 0.0 || ratio <= 0.0 {
        return Err(Error::input(&src.file, "cover.thickness_mm / cover.mix_ratio", format!("{thickness} / {ratio}"), "must be positive"));
    }
    let mut dome = 8.0;
    if let Some(ft) = src.value.get("fingertip").and_then(|v| v.as_str()) {
        let fp = path.parent().unwrap_or(Path::new(".")).join(ft);
        if let Ok(f) = read_source(&fp) {
            if let Some(d) = f.value.get("sensor").and_then(|s| s.as_array()).and_then(|a| a.first()).and_then(|s| s.get("dome_diameter_mm")).and_then(|d| d.as_float()) {
                dome = d;
            }
        }
    }
    Ok(Cover::new(thickness, ratio, sensor, dome))
}

pub struct SimSpec<'a> {
    pub sensor: &'a Path,
    pub protocol: &'a Path,
    pub rig: Option<&'a Path>,
    pub cover: Option<&'a Path>,
    pub seed: u64,
    pub trials: usize,
    pub out: &'a Path,
}

/// Reads a parameter file named on the command line; a file that cannot be read is the user's
/// input problem (exit code 2), named with its option.
fn read_named(path: &Path, option: &str) -> Result<crate::params::SourceFile> {
    read_source(path).map_err(|e| e.io_as_input("(file)", &format!("check the path given to {option}")))
}

fn load_sensor(path: &Path) -> Result<SensorParams> {
    SensorParams::from_source(&read_named(path, "--sensor")?)
}

pub fn load_protocol(path: &Path) -> Result<ProtocolParams> {
    ProtocolParams::from_source(&read_named(path, "--protocol")?)
}

/// Simulates `trials` recordings; returns the files written.
pub fn simulate(spec: &SimSpec) -> Result<Vec<PathBuf>> {
    let mut g = Gather::default();
    if spec.out.is_dir() {
        g.take::<()>(Err(Error::input(spec.out.display().to_string(), "-o", spec.out.display(), "is a folder: give -o the recording's file name, e.g. sim/rec.csv")))?;
    } else if let Some(dir) = spec.out.parent() {
        g.take(crate::export::check_out_dir(dir, "-o", "give -o a file name in a folder (the folder is created if missing)"))?;
    }
    if !(1..=1000).contains(&spec.trials) {
        g.take::<()>(Err(Error::input("(command line)", "--trials", spec.trials, "the number of recordings to simulate: 1 to 1000")))?;
    }
    let s = g.take(load_sensor(spec.sensor))?;
    let p = g.take(load_protocol(spec.protocol))?;
    let manifest_preload = g.take(spec.rig.map(preload_from_manifest).transpose())?;
    let (s, p, manifest_preload) = g.finish(s.zip(p).zip(manifest_preload).map(|((s, p), m)| (s, p, m)))?;
    let preload = manifest_preload.unwrap_or(s.preload_g);
    let cover = match spec.cover {
        Some(c) => Some(cover_from_mold(c, &s)?),
        None => None,
    };
    let mut st = Staged::default();
    let stem = spec.out.file_stem().and_then(|x| x.to_str()).unwrap_or("rec").to_string();
    let dir = spec.out.parent().unwrap_or(Path::new(""));
    let bar = Progress::new("simulate", spec.trials + 1);
    for k in 0..spec.trials {
        bar.step(format!("trial {} of {}", k + 1, spec.trials));
        let seed = spec.seed + k as u64;
        let (mut rec, truth) = sim::simulate(&s, &p, preload, cover.as_ref(), seed);
        let name = if spec.trials > 1 { format!("{stem}-{}", k + 1) } else { stem.clone() };
        rec.source = format!("{name}.csv");
        let comment = format!(
            "tipforge simulate: sensor {}, protocol {}, preload {preload} g, seed {seed}{}",
            spec.sensor.display(),
            spec.protocol.display(),
            cover.as_ref().map(|c| format!(", PDMS cover {} mm at {}:1 (dome carries {:.3} of the load)", c.thickness_mm, c.mix_ratio, c.dome_share)).unwrap_or_default()
        );
        st.add(dir.join(format!("{name}.csv")), sim::to_csv(&rec, &comment).into_bytes());
        let mut tj = serde_json::json!({"schema": "tipforge.truth/1", "seed": seed, "preload_g": preload, "steps": truth.steps, "sensor": format!("{:?}", s), "protocol": format!("{:?}", p), "cover": cover});
        if let Some(o) = tj.as_object_mut() {
            o.insert("recording".into(), serde_json::json!(format!("{name}.csv")));
        }
        let mut text = serde_json::to_string_pretty(&tj).expect("truth json");
        text.push('\n');
        st.add(dir.join("truth").join(format!("{name}.json")), text.into_bytes());
        let mut csv = String::from("time_s,clean_v,first_order_v\n");
        for i in 0..rec.len() {
            csv += &format!("{:.4},{:.6},{:.6}\n", rec.time_s[i], truth.clean_v[i], truth.first_order_v[i]);
        }
        st.add(dir.join("truth").join(format!("{name}.csv")), csv.into_bytes());
    }
    bar.step("writing");
    let lock = crate::export::outdir::OutLock::acquire(dir)?;
    st.commit(&lock)
}

/// `tipforge diagnose`: returns the summary lines and the files written.
#[allow(clippy::too_many_arguments)]
pub fn diagnose(paths: &[PathBuf], filter: bool, out: &Path, sensor: Option<&Path>, rig: Option<&Path>, actuator: bool, write_sensor: Option<&Path>) -> Result<FitSummary> {
    let mut g = Gather::default();
    g.take(out_dir(out))?;
    let bar = Progress::new("diagnose", paths.len() + 2);
    let recs = g.take(read_all(paths, Some(&bar)))?;
    let sp = g.take(sensor.map(load_sensor).transpose())?;
    let manifest_preload = g.take(rig.map(preload_from_manifest).transpose())?;
    let mut opts = Options::default();
    opts.pre.mean_filter = filter;
    opts.pre.handling = !actuator;
    if let Some(r) = &recs {
        g.0.extend(super::pooling::problems(paths, r, &opts.pre, true));
    }
    let (recs, sp, manifest_preload) = g.finish(recs.zip(sp).zip(manifest_preload).map(|((r, s), m)| (r, s, m)))?;
    let preload = match (manifest_preload, &sp) {
        (Some(m), _) => m,
        (None, Some(s)) => s.preload_g,
        _ => 0.0,
    };
    if sp.is_some() && recs[0].protocol_kind == super::recording::ProtocolKind::Input {
        return Err(Error::input(
            &recs[0].source,
            "protocol column",
            "input",
            "--sensor needs the load (load_g or force_n) to simulate the recording; this one logs a unitless input",
        ));
    }
    if sp.is_some() && recs[0].unit != "V" {
        return Err(Error::input(&recs[0].source, "response", recs[0].unit, "--sensor compares voltages: give the divider metadata (vcc_v, r_m_ohm, divider) or a voltage column"));
    }
    if let Some(path) = write_sensor {
        twin_preconditions(path, paths, &recs[0])?;
    }
    let sb = sp.as_ref().map(|s| super::diagnose::SimBaseline { sensor: s, preload_g: preload });
    bar.step("locating, choosing and refitting terms (held out)");
    let d = super::diagnose::diagnose_with(&recs, &opts, sb.as_ref())
        .ok_or_else(|| {
            Error::input(
                &recs[0].source,
                "protocol",
                "too few steps to hold out",
                "diagnosis needs at least one step of the protocol column, and each load level held in enough steps that every step can be predicted from the others (a level held once or only briefly cannot be scored held out): record more cycles, or give more trials",
            )
        })?;
    super::heldout_guard::check(&d, &recs)?;
    // the analysis's report, once, when the advice or the twin needs its fashion curves
    let ambiguous = d.findings.iter().any(|f| !f.alternatives.is_empty());
    // (with the load's ramp the diagnosis fitted, so its steps are the diagnosis's)
    let mut opts = opts;
    opts.pre.ramp = d.baseline.load_ramp;
    let report = (ambiguous || write_sensor.is_some()).then(|| super::analyze::analyze(&recs, &opts).0);
    // what to record next, for every finding whose name does not stand alone
    let mut d = d;
    if let (true, Some(report)) = (ambiguous, &report) {
        let actuator = recs.iter().any(|r| !super::preprocess::by_hand(r, &opts.pre));
        (d.advice, d.advice_notes) = super::advice::advise(&d, report, &recs[0], actuator);
    }
    // the calibrated twin: the fashion curves of the same analysis, the diagnosis's terms
    let twin = match (write_sensor, &report) {
        (Some(path), Some(report)) => {
            let text = super::twin::sensor_toml(&d, report, &recs[0]).map_err(|why| Error::input(&recs[0].source, "--write-sensor", path.display(), why))?;
            Some((path.to_path_buf(), text))
        }
        _ => None,
    };
    // the recordings are the largest thing held: gone before the outputs are built
    drop(recs);
    bar.step(format!("writing {}", out.display()));
    let mut lines = super::diagnose_out::summary(&d);
    let lock = crate::export::outdir::OutLock::acquire(out)?;
    // the twin is staged beside its name before the folder is committed, and renamed after: a
    // twin that cannot be written leaves the folder as it was
    let staged = match twin {
        Some((path, text)) => {
            let tmp = path.with_file_name(format!(".{}.tmp-{}", path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(), std::process::id()));
            std::fs::write(&tmp, text).map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                Error::input("(file)", "--write-sensor", path.display(), format!("cannot write the sensor file: {e}"))
            })?;
            Some((tmp, path))
        }
        None => None,
    };
    let mut written = match super::diagnose_out::stage(&d, out).commit(&lock) {
        Ok(w) => w,
        Err(e) => {
            if let Some((tmp, _)) = &staged {
                let _ = std::fs::remove_file(tmp);
            }
            return Err(e);
        }
    };
    if let Some((tmp, path)) = staged {
        std::fs::rename(&tmp, &path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Error::input("(file)", "--write-sensor", path.display(), format!("cannot write the sensor file: {e}"))
        })?;
        lines.push(format!("twin: wrote {} (simulate --sensor {})", path.display(), path.display()));
        written.push(path);
    }
    Ok(FitSummary { lines, written })
}

/// What `--write-sensor FILE` needs before the diagnosis runs: a file name in an existing folder,
/// not a folder, not one of the recordings, and recordings a twin can be written from.
fn twin_preconditions(path: &Path, inputs: &[PathBuf], rec: &super::recording::Recording) -> Result<()> {
    let fail = |why: String| Err(Error::input("(file)", "--write-sensor", path.display(), why));
    if path.is_dir() {
        return fail("is a folder: give the sensor file's name, e.g. out/twin.toml".into());
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !parent.is_dir() {
        return fail(format!("the folder {} does not exist: create it first", parent.display()));
    }
    let same = |a: &Path| std::fs::canonicalize(a).ok().zip(std::fs::canonicalize(path).ok()).is_some_and(|(x, y)| x == y);
    if inputs.iter().any(|i| same(i)) {
        return fail("is one of the recordings: the twin would overwrite it; give another name".into());
    }
    super::twin::can_write(rec).map_err(|why| Error::input(&rec.source, "--write-sensor", path.display(), why))
}
