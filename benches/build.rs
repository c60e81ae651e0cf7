//! `cargo bench --bench build`: median wall time to build the default parts from their parameter
//! files (parse, validate, model, boolean, mesh, checks; no file writing), at the chordal
//! tolerance in the files (0.01 mm by default; molds 0.02 mm). A mold's time includes its assembled-
//! mold checks (intersection, enclosure, fit, draft), which run before anything is written.

use std::path::PathBuf;
use std::time::Instant;
use tipforge::build::{build_job, load_all, Options};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let runs: usize = std::env::var("TIPFORGE_BENCH_RUNS").ok().and_then(|s| s.parse().ok()).unwrap_or(15);
    // `TIPFORGE_BENCH_ONLY=<stem>`: one parameter file alone (scripts/bench-peers);
    // `rig-plunger`: the rig's plunger alone, modelled and meshed in its print pose
    if let Ok(only) = std::env::var("TIPFORGE_BENCH_ONLY") {
        return single(&only, runs);
    }
    let groups: Vec<(&str, Vec<String>)> = vec![
        ("both fingertips", vec!["fingertip-1s".into(), "fingertip-2s".into()]),
        ("calibration rig", vec!["rig".into()]),
        ("both conforming molds", vec!["mold-1s".into(), "mold-2s".into()]),
        ("flat mold", vec!["mold-flat".into()]),
    ];
    println!("{:<32} {:>6} {:>12} {:>12} {:>12}", "group", "runs", "median ms", "min ms", "max ms");
    for (label, only) in groups {
        let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only, preview: false, slice: false };
        let mut times = Vec::new();
        for _ in 0..runs {
            let t0 = Instant::now();
            let (loaded, _) = load_all(&opts).expect("params load");
            for l in &loaded {
                let built = build_job(&l.job).expect("build");
                assert!(built.violations.is_empty());
                for p in &built.parts {
                    assert!(tipforge::checks::run(p).is_empty());
                }
            }
            times.push(t0.elapsed().as_secs_f64() * 1000.0);
        }
        let (mn, mx) = (times.iter().cloned().fold(f64::INFINITY, f64::min), times.iter().cloned().fold(0.0, f64::max));
        println!("{:<32} {:>6} {:>12.1} {:>12.1} {:>12.1}", label, runs, median(times), mn, mx);
    }
    // every default part as `tipforge build` makes them: files built in parallel (rayon), checks,
    // STL and 3MF bytes, nothing written
    let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![], preview: false, slice: false };
    let mut times = Vec::new();
    for _ in 0..runs {
        let t0 = Instant::now();
        let (loaded, _) = load_all(&opts).expect("params load");
        let outs = tipforge::build::outputs_of_all(&loaded, &opts.out_dir, false, false, None).expect("build");
        assert!(outs.iter().all(|o| o.violations.is_empty()));
        times.push(t0.elapsed().as_secs_f64() * 1000.0);
    }
    let (mn, mx) = (times.iter().cloned().fold(f64::INFINITY, f64::min), times.iter().cloned().fold(0.0, f64::max));
    println!("{:<32} {:>6} {:>12.1} {:>12.1} {:>12.1}", "all parts, parallel", runs, median(times), mn, mx);
    // the whole process, as a user runs it: `tipforge build --out <tmp>` (start-up, parse, build,
    // checks, files written and committed)
    let out = std::env::temp_dir().join(format!("tipforge-bench-build-{}", std::process::id()));
    let mut times = Vec::new();
    for _ in 0..runs.min(9) {
        let t0 = Instant::now();
        let st = std::process::Command::new(env!("CARGO_BIN_EXE_tipforge")).args(["build", "--out"]).arg(&out).stdout(std::process::Stdio::null()).status().expect("run tipforge");
        assert!(st.success());
        times.push(t0.elapsed().as_secs_f64() * 1000.0);
    }
    let _ = std::fs::remove_dir_all(&out);
    let (mn, mx) = (times.iter().cloned().fold(f64::INFINITY, f64::min), times.iter().cloned().fold(0.0, f64::max));
    println!("{:<32} {:>6} {:>12.1} {:>12.1} {:>12.1}", "whole process (tipforge build)", times.len(), median(times), mn, mx);
    // the molds' geometry alone (no checks), to show where the time goes
    let mut times = Vec::new();
    let molds: Vec<_> = ["mold-1s", "mold-2s"]
        .iter()
        .map(|n| {
            let src = tipforge::params::read_source(std::path::Path::new(&format!("params/{n}.toml"))).unwrap();
            tipforge::mold::load(&src, n, std::path::Path::new("params")).unwrap()
        })
        .collect();
    for _ in 0..runs {
        let t0 = Instant::now();
        for m in &molds {
            tipforge::mold::conforming::assemble(m).expect("mold");
        }
        times.push(t0.elapsed().as_secs_f64() * 1000.0);
    }
    let (mn, mx) = (times.iter().cloned().fold(f64::INFINITY, f64::min), times.iter().cloned().fold(0.0, f64::max));
    println!("{:<32} {:>6} {:>12.1} {:>12.1} {:>12.1}", "molds, geometry only", runs, median(times), mn, mx);
}

fn single(only: &str, runs: usize) {
    let mut times = Vec::new();
    if only == "rig-plunger" {
        let src = tipforge::params::read_source(std::path::Path::new("params/rig.toml")).unwrap();
        let p = tipforge::params::rig::RigParams::from_source(&src, "rig", std::path::Path::new("params")).unwrap();
        for _ in 0..runs {
            let t0 = Instant::now();
            let m = tipforge::rig::plunger_print(&p).to_mesh();
            assert!(!m.triangles.is_empty());
            times.push(t0.elapsed().as_secs_f64() * 1000.0);
        }
    } else {
        let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![only.to_string()], preview: false, slice: false };
        for _ in 0..runs {
            let t0 = Instant::now();
            let (loaded, _) = load_all(&opts).expect("params load");
            for l in &loaded {
                let built = build_job(&l.job).expect("build");
                for p in &built.parts {
                    assert!(tipforge::checks::run(p).is_empty());
                }
            }
            times.push(t0.elapsed().as_secs_f64() * 1000.0);
        }
    }
    println!("{only} {runs} {:.2}", median(times));
}
