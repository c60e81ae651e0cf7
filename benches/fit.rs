//! `cargo bench --bench fit` (run by scripts/bench-fit, which adds scipy side by side): on a
//! simulated 10-trial 0–1000 g set, the lsq fit (variable projection, pooled over trials) against
//! the paper's grid search, timing and Eq. 4 error per step; the step windows are written to
//! target/bench-fit/steps.json so scipy's curve_fit fits the same data with the same model.

use serde_json::json;
use std::time::Instant;
use tipforge::params::sensor::{ProtocolParams, SensorParams};
use tipforge::params::SourceFile;
use tipforge::sensor::analyze::{prepare, Options};
use tipforge::sensor::fit::{eq4, paper, paper_as_described, varpro};
use tipforge::sensor::sim::simulate;

fn load(path: &str) -> SourceFile {
    SourceFile::parse(path, std::fs::read_to_string(path).unwrap()).unwrap()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    let recs: Vec<_> = (1..=10).map(|seed| simulate(&s, &p, 20.0, None, seed).0).collect();
    let (prep, _) = prepare(&recs, &Options::default());
    let grids: Vec<usize> = std::env::var("TIPFORGE_PAPER_GRIDS").ok().map(|g| g.split(',').filter_map(|x| x.parse().ok()).collect()).unwrap_or(vec![100, 200]);
    let mut steps_json = Vec::new();
    let mut rows = Vec::new();
    let (mut lsq_total, mut paper_total, mut fast_total) = (0.0, vec![0.0; grids.len()], vec![0.0; grids.len()]);
    for g in &prep.groups {
        let reps = 200;
        let mut times = Vec::with_capacity(reps);
        let mut fit = None;
        for _ in 0..reps {
            let t0 = Instant::now();
            fit = varpro(g);
            times.push(t0.elapsed().as_secs_f64());
        }
        let fit = fit.unwrap();
        let t_lsq = median(times);
        lsq_total += t_lsq;
        let e_lsq = eq4(g, |i, t| fit.model(i, t));
        let w = if g.step.phase == tipforge::sensor::preprocess::Phase::Loading { g.step.after } else { g.step.before } / 1000.0;
        let mut pcols = Vec::new();
        for (gi, &n) in grids.iter().enumerate() {
            let t0 = Instant::now();
            let pf = paper_as_described(g, w, n).unwrap();
            let t = t0.elapsed().as_secs_f64();
            paper_total[gi] += t;
            let t1 = Instant::now();
            let fast = paper(g, w, n).unwrap();
            let tf = t1.elapsed().as_secs_f64();
            fast_total[gi] += tf;
            assert!((fast.eq4 - pf.eq4).abs() < 1e-9);
            pcols.push(json!({"grid": n, "seconds": t, "fast_seconds": tf, "eq4": pf.eq4, "k_per_kg": pf.k, "tau_s": pf.tau_s}));
        }
        rows.push(json!({"phase": g.step.phase, "index": g.step.index, "evaluations": fit.evaluations, "termination": fit.termination, "lsq_seconds": t_lsq, "lsq_eq4": e_lsq, "k": fit.k, "tau_s": fit.tau_s, "paper": pcols}));
        steps_json.push(json!({
            "phase": g.step.phase, "index": g.step.index,
            "trials": g.trials.iter().map(|tr| json!({"t": tr.t, "v": tr.v, "t_log": tr.t_log, "t_on": tr.t_on, "post": tr.post, "pre_end": tr.pre_end})).collect::<Vec<_>>(),
        }));
    }
    let dir = std::path::Path::new("target/bench-fit");
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("steps.json"), serde_json::to_string(&steps_json).unwrap()).unwrap();
    let samples: usize = prep.groups.iter().flat_map(|g| g.trials.iter().map(|t| t.t.len())).sum();
    let out = json!({"trials": recs.len(), "steps": prep.groups.len(), "samples": samples, "rows": rows, "lsq_total_s": lsq_total, "paper_total_s": grids.iter().zip(&paper_total).zip(&fast_total).map(|((g, t), f)| json!({"grid": g, "seconds": t, "fast_seconds": f})).collect::<Vec<_>>()});
    std::fs::write(dir.join("rust.json"), serde_json::to_string_pretty(&out).unwrap()).unwrap();
    println!("10 trials × {} steps, {} samples after the 10-sample mean filter", prep.groups.len(), samples);
    println!("lsq (variable projection, pooled): {:.3} ms for all steps (median of 200 runs per step)", lsq_total * 1e3);
    for ((g, t), f) in grids.iter().zip(&paper_total).zip(&fast_total) {
        println!(
            "paper grid search {g}×{g} as described (Eq. 4 at every point): {:.1} ms ({:.0}× the lsq time); with sufficient statistics: {:.1} ms ({:.0}×)",
            t * 1e3,
            t / lsq_total,
            f * 1e3,
            f / lsq_total
        );
    }
}
