//! Thin CLI: parse arguments, call the library, print, choose the exit code.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "tipforge", version, about = "FSR fingertips, calibration rig and PDMS molds for the Gifu Hand III; sensor calibration loop")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Build every part file in the params folder into STL, 3MF and out/manifest.json.
    Build {
        /// Folder of parameter files.
        #[arg(long, default_value = "params")]
        params: PathBuf,
        /// Output folder.
        #[arg(long, short, default_value = "out")]
        out: PathBuf,
        /// Only these parameter files: stems of files in --params (fingertip-1s) or paths
        /// (params/fingertip-1s.toml, ../lab/my-finger.toml). A mold's fingertip is read from the
        /// mold file's own folder.
        parts: Vec<String>,
        /// Also slice every printed part with PrusaSlicer (scripts/install-slicer) using the
        /// repository's profile (0.4 mm nozzle, 0.2 mm layers, PLA): print time and filament mass
        /// go into the manifest and the summary.
        #[arg(long)]
        slice: bool,
        /// Also write a shaded PNG preview of every part (out/<part>.png).
        #[arg(long)]
        preview: bool,
    },
    /// Fit the first-order step model to recordings (one trial per CSV) and write tables,
    /// fashion curves, a JSON report and plots.
    Fit {
        /// Recording CSV files (format: docs/recording-format.md).
        #[arg(required = true)]
        recordings: Vec<PathBuf>,
        /// paper: the paper's Eq. 2–4 grid search; lsq: exact least squares; both.
        #[arg(long, value_enum, default_value = "lsq")]
        method: MethodArg,
        /// Output folder.
        #[arg(long, default_value = "out/fit")]
        out: PathBuf,
        /// Turn off the paper's 10-sample mean filter.
        #[arg(long)]
        no_filter: bool,
        /// The loads were applied by a machine, not by hand: exclude no handling spikes
        /// (a recording can say so itself with a `# loading=actuator` line).
        #[arg(long)]
        actuator: bool,
    },
    /// Where simulation and recordings differ: locate the mismatch, name the physics left out,
    /// model it, refit, and show the held-out improvement.
    Diagnose {
        /// Recording CSV files (format: docs/recording-format.md); two or more are trials of one
        /// protocol and are held out one by one, a single file is held out step by step.
        #[arg(required = true)]
        recordings: Vec<PathBuf>,
        /// Output folder (diagnosis.json, report.html, plots/, predictions/).
        #[arg(long, default_value = "out/diagnosis")]
        out: PathBuf,
        /// Turn off the paper's 10-sample mean filter.
        #[arg(long)]
        no_filter: bool,
        /// Use this simulator configuration's prediction as the baseline (check a simulator
        /// against recordings).
        #[arg(long)]
        sensor: Option<PathBuf>,
        /// With --sensor: the rig manifest whose plunger mass is the preload.
        #[arg(long, requires = "sensor")]
        rig: Option<PathBuf>,
        /// The loads were applied by a machine, not by hand: look for no handling spikes
        /// (a recording can say so itself with a `# loading=actuator` line).
        #[arg(long)]
        actuator: bool,
        /// Also write a calibrated twin: a sensor file (like params/sensor.toml) that `simulate`
        /// reads, with the circuit, the fitted conductance law and relaxation, the noise and the
        /// found terms. Needs a divider recording (vcc_v, r_m_ohm, divider) with a load_g or force_n
        /// column and at least three loads.
        #[arg(long, value_name = "FILE.toml")]
        write_sensor: Option<PathBuf>,
    },
    /// Simulate the rig and sensor: write a recording and its noise-free truth.
    Simulate {
        /// Sensor and read-out configuration (a TOML file like params/sensor.toml).
        #[arg(long, default_value = "params/sensor.toml")]
        sensor: PathBuf,
        /// Loading protocol: the weights stacked and removed, and their hold times.
        #[arg(long, default_value = "params/protocol-1000g.toml")]
        protocol: PathBuf,
        /// out/manifest.json of a build with the rig: the plunger's mass is the preload.
        #[arg(long)]
        rig: Option<PathBuf>,
        /// A mold parameter file: simulate the sensor under its PDMS cover.
        #[arg(long)]
        cover: Option<PathBuf>,
        /// Seed of the noise and the handling (same seed, same file).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Number of trials (files NAME-1.csv …, seeds seed, seed+1, …).
        #[arg(long, default_value_t = 1)]
        trials: usize,
        /// Output recording (the truth goes to truth/NAME.json and truth/NAME.csv beside it).
        #[arg(short = 'o', long = "out", value_name = "FILE.csv")]
        out: PathBuf,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum MethodArg {
    Paper,
    Lsq,
    Both,
}

/// Print a line of the summary. The files are written before anything is printed, so a reader
/// that stops early (`tipforge build | head -1`) loses only text: a closed pipe ends the printing
/// quietly instead of panicking as `println!` does.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let input = e.downcast_ref::<tipforge::error::Error>().is_some_and(|e| e.is_input());
            eprintln!("error: {e:#}");
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.cmd {
        Cmd::Build { params, out, parts, preview, slice } => {
            let report = tipforge::build::run(&tipforge::build::Options { params_dir: params, out_dir: out, only: parts, preview, slice })?;
            for (f, why) in &report.skipped {
                say!("skipped {f}: {why}");
            }
            say!("{:<22} {:>10} {:>12} {:>9} {:>9}", "part", "triangles", "volume mm³", "mass g", "time ms");
            for s in &report.summaries {
                say!("{:<22} {:>10} {:>12.1} {:>9.2} {:>9.1}", s.name, s.triangles, s.volume_mm3, s.mass_g, s.millis);
            }
            for n in &report.notes {
                say!("{n}");
            }
            say!("wrote {} file(s)", report.written.len());
            Ok(())
        }
        Cmd::Fit { recordings, method, out, no_filter, actuator } => {
            use tipforge::sensor::analyze::Method;
            let m = match method {
                MethodArg::Paper => Method::Paper,
                MethodArg::Lsq => Method::Lsq,
                MethodArg::Both => Method::Both,
            };
            let s = tipforge::sensor::cli::fit(&recordings, m, !no_filter, actuator, &out)?;
            for l in &s.lines {
                say!("{l}");
            }
            say!("wrote {} file(s) to {}", s.written.len(), out.display());
            Ok(())
        }
        Cmd::Diagnose { recordings, out, no_filter, sensor, rig, actuator, write_sensor } => {
            let s = tipforge::sensor::cli::diagnose(&recordings, !no_filter, &out, sensor.as_deref(), rig.as_deref(), actuator, write_sensor.as_deref())?;
            for l in &s.lines {
                say!("{l}");
            }
            say!("wrote {} file(s) to {}", s.written.len(), out.display());
            Ok(())
        }
        Cmd::Simulate { sensor, protocol, rig, cover, seed, trials, out } => {
            let spec = tipforge::sensor::cli::SimSpec { sensor: &sensor, protocol: &protocol, rig: rig.as_deref(), cover: cover.as_deref(), seed, trials, out: &out };
            let files = tipforge::sensor::cli::simulate(&spec)?;
            for f in &files {
                say!("wrote {}", f.display());
            }
            Ok(())
        }
    }
}
