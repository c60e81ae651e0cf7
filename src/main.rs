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
        /// Only these parameter file stems (e.g. fingertip-1s).
        parts: Vec<String>,
        /// Also write a shaded PNG preview of every part (out/<part>.png).
        #[arg(long)]
        preview: bool,
    },
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
        Cmd::Build { params, out, parts, preview } => {
            let report = tipforge::build::run(&tipforge::build::Options { params_dir: params, out_dir: out, only: parts, preview })?;
            for (f, why) in &report.skipped {
                println!("skipped {f}: {why}");
            }
            println!("{:<22} {:>10} {:>12} {:>9} {:>9}", "part", "triangles", "volume mm³", "mass g", "time ms");
            for s in &report.summaries {
                println!("{:<22} {:>10} {:>12.1} {:>9.2} {:>9.1}", s.name, s.triangles, s.volume_mm3, s.mass_g, s.millis);
            }
            for n in &report.notes {
                println!("{n}");
            }
            println!("wrote {} file(s)", report.written.len());
            Ok(())
        }
    }
}
