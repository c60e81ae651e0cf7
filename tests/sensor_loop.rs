//! Sensor loop part 1 end to end: simulated recordings → fits → recovery of the truth; the
//! paper's method reproduces its trends; lsq beats its Eq. 4 error.

use tipforge::params::sensor::{ProtocolParams, SensorParams};
use tipforge::params::SourceFile;
use tipforge::sensor::analyze::{analyze, Method, Options};
use tipforge::sensor::preprocess::Phase;
use tipforge::sensor::sim::simulate;

fn load(path: &str) -> SourceFile {
    SourceFile::parse(path, std::fs::read_to_string(path).unwrap()).unwrap()
}

fn defaults(protocol: &str) -> (SensorParams, ProtocolParams) {
    (SensorParams::from_source(&load("params/sensor.toml")).unwrap(), ProtocolParams::from_source(&load(protocol)).unwrap())
}

fn check_steps(report: &tipforge::sensor::analyze::Report, truth: &tipforge::sensor::sim::Truth, label: &str, worst: &mut (f64, f64)) {
    assert_eq!(report.steps.len(), 10, "{label}");
    for st in &report.steps {
        let phase = if st.phase == Phase::Loading { "loading" } else { "unloading" };
        let t = truth.steps.iter().find(|x| x.phase == phase && x.index == st.index).unwrap();
        let f = st.lsq.as_ref().expect("fit");
        let ek = (f.k / t.k_v - 1.0).abs();
        let et = (f.tau_s / t.tau_s - 1.0).abs();
        *worst = (worst.0.max(ek), worst.1.max(et));
        assert!(ek < 0.02, "{label} {phase} {}: k {} vs {}", st.index, f.k, t.k_v);
        assert!(et < 0.02, "{label} {phase} {}: tau {} vs {}", st.index, f.tau_s, t.tau_s);
    }
}

#[test]
fn lsq_recovers_every_steps_k_and_tau_within_two_percent_per_trial() {
    // the paper's 0–1000 g range, each trial fitted on its own
    let (s, p) = defaults("params/protocol-1000g.toml");
    let mut worst = (0.0f64, 0.0f64);
    for seed in 1..=5 {
        let (rec, truth) = simulate(&s, &p, 20.0, None, seed);
        let (report, _) = analyze(&[rec], &Options::default());
        check_steps(&report, &truth, &format!("1000 g seed {seed}"), &mut worst);
    }
    println!("0–1000 g, single trials: worst relative error k {:.4}, tau {:.4}", worst.0, worst.1);
}

#[test]
fn lsq_recovers_the_200g_range_pooled_over_its_five_trials() {
    // 40 g steps are small (≈0.1 V against 3 mV noise) and fast (τ ≈ 0.35 s): one trial pins τ to
    // about ±1.5 % (1σ); the paper's five trials pooled pin it to well inside 2 %
    let (s, p) = defaults("params/protocol-200g.toml");
    let mut worst = (0.0f64, 0.0f64);
    for set in 0..2u64 {
        let sims: Vec<_> = (1..=5).map(|k| simulate(&s, &p, 20.0, None, 100 * set + k)).collect();
        let recs: Vec<_> = sims.iter().map(|x| x.0.clone()).collect();
        let (report, _) = analyze(&recs, &Options::default());
        check_steps(&report, &sims[0].1, &format!("200 g set {set}"), &mut worst);
    }
    println!("0–200 g, five trials pooled: worst relative error k {:.4}, tau {:.4}", worst.0, worst.1);
}

#[test]
fn paper_method_reproduces_the_trend_and_lsq_has_no_higher_eq4_error() {
    let (s, p) = defaults("params/protocol-1000g.toml");
    let recs: Vec<_> = (1..=5).map(|seed| simulate(&s, &p, 20.0, None, seed).0).collect();
    let (report, _) = analyze(&recs, &Options { method: Method::Both, paper_grid: 60, ..Options::default() });
    let loading: Vec<_> = report.steps.iter().filter(|s| s.phase == Phase::Loading).collect();
    assert_eq!(loading.len(), 5);
    for w in loading.windows(2) {
        let (a, b) = (w[0].paper.as_ref().unwrap(), w[1].paper.as_ref().unwrap());
        assert!(b.k < a.k, "paper k must fall with weight: {} then {}", a.k, b.k);
    }
    let (first, last) = (loading[0].paper.as_ref().unwrap(), loading[4].paper.as_ref().unwrap());
    assert!(last.tau_s > first.tau_s, "paper τ must rise with weight: {} → {}", first.tau_s, last.tau_s);
    for st in &report.steps {
        let (l, pp) = (st.lsq_eq4.unwrap(), st.paper.as_ref().unwrap().eq4);
        assert!(l <= pp, "step {:?} {}: lsq Eq.4 {l} > paper {pp}", st.phase, st.index);
    }
    let f = report.fashion.as_ref().expect("fashion curves");
    assert!((f.n - 1.0).abs() < 0.05, "conductance exponent {}", f.n);
    assert!(f.tau1_s_per_unit > 0.0);
}
