//! diagnose end to end on simulated recordings where the truth is known: no finding on clean data,
//! the concealed effect found on data with it, output contract written.

#[path = "common/nuisances.rs"]
mod nuisances;

use nuisances::trial_nuisances;
use std::path::PathBuf;
use std::process::Command;
use tipforge::params::sensor::{ProtocolParams, SensorParams};
use tipforge::params::SourceFile;
use tipforge::sensor::diagnose::diagnose;
use tipforge::sensor::sim::simulate;

fn load(path: &str) -> SourceFile {
    SourceFile::parse(path, std::fs::read_to_string(path).unwrap()).unwrap()
}

fn case(seed0: u64, f: impl Fn(&mut SensorParams)) -> Vec<tipforge::sensor::recording::Recording> {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    f(&mut s);
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    (0..3).map(|k| simulate(&s, &p, 20.0, None, seed0 + k).0).collect()
}

/// RMS error of the baseline and the improved prediction against the simulator's noise-free truth.
fn truth_errors(d: &tipforge::sensor::diagnose::Diagnosis, seed0: u64, f: impl Fn(&mut SensorParams)) -> (f64, f64) {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    f(&mut s);
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    let (mut eb, mut ei, mut n) = (0.0, 0.0, 0.0);
    for (k, pr) in d.predictions.iter().enumerate() {
        let (_, truth) = simulate(&s, &p, 20.0, None, seed0 + k as u64);
        for i in 0..truth.clean_v.len() {
            eb += (pr.baseline[i] - truth.clean_v[i]).powi(2);
            ei += (pr.improved[i] - truth.clean_v[i]).powi(2);
            n += 1.0;
        }
    }
    ((eb / n).sqrt(), (ei / n).sqrt())
}

#[test]
fn clean_data_gives_no_finding_on_seeds_it_was_not_tuned_on() {
    for seed in [1000, 2000, 3000, 4000] {
        let d = diagnose(&case(seed, |_| {}), &Default::default()).unwrap();
        assert!(d.findings.is_empty(), "seed {seed}: {:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
        assert!((d.final_.heldout_rmse - d.baseline.heldout_rmse).abs() < 1e-12);
    }
}

#[test]
fn concealed_hysteresis_and_spikes_are_named() {
    let d = diagnose(&case(5000, |s| s.effects.hysteresis = 0.03), &Default::default()).unwrap();
    assert_eq!(d.findings.first().map(|f| f.effect), Some("hysteresis"));
    assert!(d.final_.heldout_rmse < 0.5 * d.baseline.heldout_rmse);
    let d = diagnose(&case(6000, |s| s.effects.spike_v = 0.2), &Default::default()).unwrap();
    let f = d.findings.iter().find(|f| f.effect == "handling_spikes").expect("spikes reported");
    assert!(f.windows.len() >= 10, "{:?}", d.findings);
    // the baseline fits the data as given; excluding the spikes predicts the held-out data better
    assert!(f.heldout_rmse_after < f.heldout_rmse_before, "{} -> {}", f.heldout_rmse_before, f.heldout_rmse_after);
    // saturation is modelled (clip, and the clipped steps' τ and onsets from the others), so the
    // improved prediction is closer to held-out data than the baseline's
    let d = diagnose(&case(7000, |s| s.effects.saturation_v = 1.55), &Default::default()).unwrap();
    let f = d.findings.iter().find(|f| f.effect == "saturation").expect("saturation named");
    assert!(f.heldout_rmse_after < 0.95 * f.heldout_rmse_before, "{} -> {}", f.heldout_rmse_before, f.heldout_rmse_after);
    assert!(d.final_.effects.contains(&"saturation"));
    // and against the noise-free truth the improved prediction is far closer than the baseline's
    let (eb, ei) = truth_errors(&d, 7000, |s| s.effects.saturation_v = 1.55);
    assert!(ei < 0.5 * eb, "{eb} -> {ei}");
}

/// Issue 15: trials that differ in gain (±3 %, the sensor's temperature or the hand) are a nuisance
/// of the set-up: a gain per trial enters the model, validated inside each held-out trial, and is
/// reported apart from the findings; a 1σ hysteresis is still named; and on trials of one gain no
/// gain enters. Seeds 73 000–73 200, not looked at before (the rule was set on CLI cases 10 011–10 041).
#[test]
fn trials_of_different_gain_are_a_nuisance_not_a_finding() {
    for seed in [73_000u64, 73_100, 73_200] {
        let set = |s: &mut SensorParams| {
            s.nuisance.gain_jitter = 0.03;
            s.effects.hysteresis = 5.492e-3;
        };
        let d = diagnose(&case(seed, set), &Default::default()).unwrap();
        let found: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(found, vec!["hysteresis"], "seed {seed}");
        let g = d.nuisances.iter().find(|n| n.name == "trial_gain").unwrap_or_else(|| panic!("seed {seed}: no trial gain"));
        assert!(g.heldout_rmse_after < 0.8 * g.heldout_rmse_before, "seed {seed}: {} -> {}", g.heldout_rmse_before, g.heldout_rmse_after);
        let same = diagnose(&case(seed, |s| s.effects.hysteresis = 5.492e-3), &Default::default()).unwrap();
        assert!(same.nuisances.iter().all(|n| n.name != "trial_gain"), "seed {seed}: a gain entered on trials of one gain");
    }
}

#[test]
fn cli_writes_the_output_contract() {
    let dir = std::env::temp_dir().join(format!("tipforge-diag-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let rec = dir.join("rec.csv");
    let bin = env!("CARGO_BIN_EXE_tipforge");
    let o = Command::new(bin).args(["simulate", "--trials", "2", "-o"]).arg(&rec).output().unwrap();
    assert!(o.status.success());
    let out = dir.join("diag");
    let recs: Vec<PathBuf> = vec![dir.join("rec-1.csv"), dir.join("rec-2.csv")];
    let o = Command::new(bin).arg("diagnose").args(&recs).arg("--out").arg(&out).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}{}", String::from_utf8_lossy(&o.stderr));
    assert!(text.contains("held-out RMSE"));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
    assert_eq!(j["schema"], "tipforge.diagnosis/1");
    for k in ["recordings", "baseline", "findings", "unexplained", "final"] {
        assert!(j.get(k).is_some(), "{k}");
    }
    let csv = std::fs::read_to_string(out.join("predictions/rec-1.csv")).unwrap();
    assert!(csv.starts_with("time_s,measured,baseline,improved\n"));
    assert_eq!(csv.lines().count(), 20001 + 1);
    assert!(out.join("report.html").exists() && out.join("plots/rec-1.png").exists());
    // bad input: clear error, exit 2
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "time_s,voltage_v,load_g\n0,1,0\n0,1,0\n").unwrap();
    let o = Command::new(bin).arg("diagnose").arg(&bad).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("time must increase"));
}

#[test]
fn shared_real_recording_is_diagnosed() {
    let path = std::path::Path::new("../shared/data/real/cbsilicone_v10_Ro.csv");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let rec = tipforge::sensor::recording::read(path).unwrap();
    // its strain steps come from a linear actuator (its header says so): no handling spikes
    let mut opts = tipforge::sensor::analyze::Options::default();
    opts.pre.handling = false;
    let d = diagnose(std::slice::from_ref(&rec), &opts).unwrap();
    assert!(d.findings.iter().all(|f| f.effect != "handling_spikes"), "{:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
    // every strain change, up and down alike, makes the resistance jump and relax back over tens
    // of seconds: modelled by the relaxation spectrum over every change (issue 15), named after
    // the exact form closest to it, a second relaxation driven by the size of the change
    let f = d.findings.iter().find(|f| f.effect == "second_time_constant").unwrap_or_else(|| panic!("{:?}", d.decisions));
    assert_eq!(f.term.name, "relaxation_spectrum", "{:?}", f.term);
    assert_eq!(f.term.params["closest_exact_form"]["drive"], "the size of the change", "{:?}", f.term);
    // issue 15's bar: at least 65 % below the baseline held out, every held-out step better
    assert!(d.final_.heldout_rmse <= 0.35 * d.baseline.heldout_rmse, "{} -> {}", d.baseline.heldout_rmse, d.final_.heldout_rmse);
    assert!(d.final_.units_scored >= 10 && d.final_.units_better == d.final_.units_scored, "{:?}", d.final_.heldout_by_unit);
    // located before any term: the runs test flags the steps' early residuals
    assert!(d.located.iter().filter(|w| w.test == "second_time_constant").count() >= 5, "{:?}", d.located);
    // what the catalogue leaves (the residual is still far from white) is said, not hidden
    assert!(d.unexplained.flag && !d.unexplained.evidence.is_empty(), "{:?}", d.unexplained);
    println!("real: {:?}, held-out {:.1} → {:.1} ohm, unexplained {}", d.final_.effects, d.baseline.heldout_rmse, d.final_.heldout_rmse, d.unexplained.flag);
    // taken as loaded by hand, its sharp transients at the steps are reported as handling spikes
    let d = diagnose(std::slice::from_ref(&rec), &Default::default()).unwrap();
    // issue 17, defect 1: the held-out step's onset shift was left at the value the solver gave a
    // column with no training data (3.8e10 ohm held out against 1776 ohm fitted, on a 23 kohm span)
    let span = rec.response.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - rec.response.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(d.baseline.heldout_rmse < 3.0 * d.baseline.rmse && d.baseline.heldout_rmse < 0.5 * span, "{:?}", d.baseline);
    for c in &d.decisions {
        assert!(c.heldout_rmse < 3.0 * d.baseline.rmse, "{c:?}");
    }
    tipforge::sensor::heldout_guard::check(&d, std::slice::from_ref(&rec)).unwrap();
}

#[test]
fn simulator_baseline_finds_what_the_simulator_leaves_out_and_nothing_when_it_is_right() {
    use tipforge::sensor::diagnose::{diagnose_with, SimBaseline};
    let s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let sb = SimBaseline { sensor: &s, preload_g: 20.0 };
    let d = diagnose_with(&case(8000, |_| {}), &Default::default(), Some(&sb)).unwrap();
    assert!(d.findings.is_empty(), "{:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
    let d = diagnose_with(&case(9000, |x| x.effects.hysteresis = 0.03), &Default::default(), Some(&sb)).unwrap();
    assert_eq!(d.findings.first().map(|f| f.effect), Some("hysteresis"));
    assert!(d.baseline.model.contains("simulator"));
    // a simulator with the wrong time constants is caught as a mismatch
    let mut wrong = s.clone();
    wrong.tau_per_n_s *= 2.0;
    let sw = SimBaseline { sensor: &wrong, preload_g: 20.0 };
    let d = diagnose_with(&case(9100, |_| {}), &Default::default(), Some(&sw)).unwrap();
    assert!(d.baseline.heldout_rmse > 3.0 * 0.001, "{}", d.baseline.heldout_rmse);
    assert!(!d.findings.is_empty() || d.unexplained.flag);
}

#[test]
fn actuator_loading_excludes_no_spikes_by_flag_or_metadata() {
    let dir = std::env::temp_dir().join(format!("tipforge-act-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let bin = env!("CARGO_BIN_EXE_tipforge");
    // a sensor file with handling spikes switched on
    let sensor = std::fs::read_to_string("params/sensor.toml").unwrap();
    let spiky = sensor.replacen("[effects.handling_spikes]\namplitude_v = 0.0", "[effects.handling_spikes]\namplitude_v = 0.2", 1);
    assert_ne!(spiky, sensor);
    let sp = dir.join("sensor.toml");
    std::fs::write(&sp, &spiky).unwrap();
    let o = Command::new(bin).args(["simulate", "--trials", "2", "--seed", "31000", "--sensor"]).arg(&sp).arg("-o").arg(dir.join("rec.csv")).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let recs = [dir.join("rec-1.csv"), dir.join("rec-2.csv")];
    let found = |extra: &[&str], recs: &[PathBuf]| -> Vec<String> {
        let out = dir.join(format!("d{}", extra.len()));
        let o = Command::new(bin).arg("diagnose").args(recs).args(extra).arg("--out").arg(&out).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
        j["findings"].as_array().unwrap().iter().map(|f| f["effect"].as_str().unwrap().to_string()).collect()
    };
    assert!(found(&[], &recs).contains(&"handling_spikes".to_string()));
    assert!(!found(&["--actuator"], &recs).contains(&"handling_spikes".to_string()));
    // the same said by the recordings themselves
    let tagged: Vec<PathBuf> = recs
        .iter()
        .map(|r| {
            let p = r.with_extension("tagged.csv");
            std::fs::write(&p, format!("# loading=actuator\n{}", std::fs::read_to_string(r).unwrap())).unwrap();
            p
        })
        .collect();
    assert!(!found(&[], &tagged).contains(&"handling_spikes".to_string()));
}

/// The final refit takes the improved model to the floor: on a second relaxation (its part-1 fits
/// lengthen τ and its τ2 is chosen on a grid), the improved model's error to the truth is within
/// 15 % of the same model refitted to the same noise without the effect. Before the refit iterated
/// with the filtered-sample model's own derivatives it was 2–7 times the floor.
#[test]
fn improved_model_reaches_the_floor_of_the_same_model_without_the_effect() {
    use tipforge::sensor::diagnose::refitted_baseline;
    let fx = |x: &mut SensorParams| x.effects.second_fraction = 0.05;
    for seed in [70_000, 70_100] {
        let d = diagnose(&case(seed, fx), &Default::default()).unwrap();
        assert!(d.findings.iter().any(|f| f.effect == "second_time_constant"), "seed {seed}");
        let (eb, ei) = truth_errors(&d, seed, fx);
        let floor = refitted_baseline(&case(seed, |_| {}), &Default::default()).unwrap();
        let (ef, _) = truth_errors(&floor, seed, |_| {});
        assert!(ei <= 1.15 * ef && ei < 0.1 * eb, "seed {seed}: improved {ei:.3e}, floor {ef:.3e}, baseline {eb:.3e}");
    }
}

#[test]
fn edge_misfit_of_a_large_second_relaxation_is_not_excluded_as_handling_spikes() {
    // A share of each step in an 8 s relaxation: at some step edges the first-order curve leaves
    // the data for a few tenths of a second, and the spike detectors flag it. Where excluding
    // those windows makes the held-out prediction worse, they stay in and are reported as located
    // failures, and the second relaxation is found on the data as given. Designed on a CLI case
    // (seed 30 000, 22 %); these seeds were not looked at before. Before the check, all six
    // excluded such windows (improved error to the truth 0.52–0.63 × the baseline's); with it,
    // those that keep them reach ~0.28 ×. Where exclusion lowers the held-out error a little, the
    // windows are still excluded (a known limit, BENCHMARKS.md).
    //
    // Since the edge detector tries a step's own course (the divider's bend, a time constant that
    // glides with the load) before it calls a spike (stop 30), a 22 % share leaves no edge flagged
    // in any of the six; a 30 % share still does (5 of 6 at stop 30, where the share was chosen), and
    // exercises the check.
    for (share, min_kept) in [(0.22, 0), (0.30, 2)] {
        let mut kept_cases = 0;
        for seed in [71_000u64, 71_100, 71_200, 71_300, 71_400, 71_500] {
            let set = move |s: &mut SensorParams| s.effects.second_fraction = share;
            let d = diagnose(&case(seed, set), &Default::default()).unwrap();
            let found: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
            assert_eq!(found.first(), Some(&"second_time_constant"), "{share} seed {seed}: {found:?}");
            let kept = d.located.iter().filter(|w| w.test == "handling_spikes" && w.statistic.contains("not excluded")).count();
            match d.findings.iter().find(|f| f.effect == "handling_spikes") {
                Some(f) => {
                    assert!(share > 0.22, "seed {seed}: a 22 % share's edges were called handling spikes");
                    assert_eq!(kept, 0, "{share} seed {seed}");
                    assert!(f.heldout_rmse_after <= f.heldout_rmse_before, "{share} seed {seed}: exclusion kept though it worsened held-out prediction");
                }
                None if kept > 0 => {
                    kept_cases += 1;
                    let (eb, ei) = truth_errors(&d, seed, set);
                    // (excluded, such windows left 0.52–0.63 × the baseline's error at 22 %)
                    assert!(ei < 0.45 * eb, "{share} seed {seed}: error to the truth {eb} -> {ei}");
                }
                None => {}
            }
            assert!(d.final_.heldout_rmse < 0.5 * d.baseline.heldout_rmse, "{share} seed {seed}");
        }
        if min_kept == 0 {
            assert_eq!(kept_cases, 0, "a 22 % share: edges flagged and kept in {kept_cases} of 6 cases");
        } else {
            assert!(kept_cases >= min_kept, "a {share} share: edge misfits kept in {kept_cases} of 6 cases");
        }
    }
}

/// Issue 17, defect 6: recordings made with a preload the simulator was not given. The mismatch is
/// named first, as a preload, and is not taken for effects that were never simulated; with the
/// right preload nothing of the kind is named.
#[test]
fn a_preload_mismatch_is_named_as_such_first() {
    use tipforge::sensor::diagnose::{diagnose_with, SimBaseline};
    let s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let p = ProtocolParams::from_source(&load("params/protocol-200g.toml")).unwrap();
    let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.6, None, 4100 + k).0).collect();
    let d = diagnose_with(&recs, &Default::default(), Some(&SimBaseline { sensor: &s, preload_g: 0.0 })).unwrap();
    let f = d.findings.first().unwrap_or_else(|| panic!("no finding"));
    assert_eq!(f.effect, "preload_mismatch", "{:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
    let fitted = f.term.params["preload_g_fitted"].as_f64().unwrap();
    assert!((fitted - 20.6).abs() < 2.0, "fitted preload {fitted} g");
    assert!(f.heldout_rmse_after < 0.5 * f.heldout_rmse_before, "{f:?}");
    // none of the catalogue's effects is taken for the preload
    assert!(d.findings.iter().skip(1).all(|f| f.confidence != "high"), "{:?}", d.findings.iter().map(|f| (f.effect, f.confidence)).collect::<Vec<_>>());
    let d = diagnose_with(&recs, &Default::default(), Some(&SimBaseline { sensor: &s, preload_g: 20.6 })).unwrap();
    assert!(d.findings.iter().all(|f| f.effect != "preload_mismatch"), "{:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
}

/// The FSR402-like protocol (one 1 kg step held 10 min) and its sensor.
fn fsr402() -> (ProtocolParams, SensorParams) {
    (ProtocolParams::from_source(&load("params/protocol-1kg-hold.toml")).unwrap(), SensorParams::from_source(&load("params/sensor-fsr402.toml")).unwrap())
}

/// The FSR402-like sensor as a lab has it: a preload of 8 g, the loaded hold at 89 % of the
/// divider's span, σ 18 mV with 70 % of it AR(1) at ρ 0.9, and no creep.
fn fsr402_preloaded() -> (ProtocolParams, SensorParams) {
    let (proto, mut s) = fsr402();
    (s.preload_g, s.g_ref_s, s.noise_v) = (8.0, 8.0e-5, 0.018);
    (s.nuisance.noise_ar_rho, s.nuisance.noise_ar_share) = (0.9, 0.7);
    s.effects.creep_per_decade = 0.0;
    (proto, s)
}

/// A creep of the conductance of `per_decade` of each change per decade, superposed over the load
/// history (seen through the divider).
fn conductance_creep(s: &mut SensorParams, per_decade: f64) {
    s.effects.creep_per_decade = per_decade;
    s.effects.creep_superposed = true;
    s.effects.creep_in_conductance = true;
}

/// One simulated recording of `s` under `proto` at `seed` (with the sensor's own preload, as
/// `tipforge simulate` without a rig: until stop 58 this passed none, so the "preloaded" cases here
/// ran at zero preload), diagnosed; and the names it found.
fn diagnose_one(s: &SensorParams, proto: &ProtocolParams, seed: u64) -> (tipforge::sensor::diagnose::Diagnosis, Vec<&'static str>) {
    let (rec, _) = simulate(s, proto, s.preload_g, None, seed);
    let d = diagnose(std::slice::from_ref(&rec), &Default::default()).unwrap();
    let names = d.findings.iter().map(|f| f.effect).collect();
    (d, names)
}

/// Issue 15, item 7: an Interlink FSR402-like case (params/sensor-fsr402.toml: 10-bit Arduino,
/// 5 V divider, 10 Hz) under one 1 kg weight placed by hand, held 10 min, lifted, 5 min of
/// recovery. The load lands within a sample and the rubber creeps (about 9 % of the resistance over
/// the hold). `fit` says the loading step's τ describes creep; `diagnose` scores the single
/// recording inside its holds (forward in time), models the landing as a jump, names creep and is
/// at least 25 % better held out; without the creep it finds nothing. Seeds not looked at before.
/// (The bar was 30 % until stop 40. A third of the samples, at rest, read the ADC's floor, 0 V;
/// they are now replaced by their expected value below it and carry the noise the floor cut off.
/// The held-out mean square falls by as much as before, 91 mV² on seed 90 001, but from a higher
/// start: 31 % became 27 %.)
#[test]
fn fsr402_like_single_step_names_creep_and_nothing_without_it() {
    let (proto, with) = fsr402();
    assert!(with.effects.creep_per_decade > 0.0);
    let mut without = with.clone();
    without.effects.creep_per_decade = 0.0;
    for seed in [90_001u64, 90_002, 90_003] {
        let (rec, _) = simulate(&with, &proto, 0.0, None, seed);
        let (report, _) = tipforge::sensor::analyze::analyze(std::slice::from_ref(&rec), &Default::default());
        let load = report.steps.iter().find(|s| s.after > s.before).unwrap();
        assert!(load.tau_describes_creep.is_some(), "seed {seed}: τ {:?} not flagged", load.lsq.as_ref().map(|f| f.tau_s));
        let d = diagnose(std::slice::from_ref(&rec), &Default::default()).unwrap();
        let names: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(names, vec!["creep"], "seed {seed}: {:?}", d.decisions);
        assert!(d.final_.heldout_rmse <= 0.75 * d.baseline.heldout_rmse, "seed {seed}: {} -> {}", d.baseline.heldout_rmse, d.final_.heldout_rmse);
        assert!(d.notes.iter().any(|n| n.contains("describes the slow creep")), "seed {seed}: diagnosis.json carries the creep-dominated note: {:?}", d.notes);
        let (rec0, _) = simulate(&without, &proto, 0.0, None, seed);
        let d0 = diagnose(std::slice::from_ref(&rec0), &Default::default()).unwrap();
        assert!(d0.findings.is_empty(), "seed {seed}: {:?}", d0.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
    }
}

/// The same FSR402-like case whose conductance creeps (4.3 % of the change per decade, about 12 % of
/// the resistance over the hold), superposed over the load history and seen through the 5 V divider:
/// the lift-off's slow recovery is the creep carried over, which the divider shows far larger than
/// the loaded hold's. `diagnose` names creep alone, in the conductance, with its per-decade fraction
/// within 10 % (the form taken exactly through the divider, not linearised), and is at least 30 %
/// better held out. Seeds not looked at before.
#[test]
fn fsr402_like_conductance_creep_is_named_through_the_divider() {
    let (proto, mut s) = fsr402();
    conductance_creep(&mut s, 0.043);
    for seed in [90_011u64, 90_012, 90_013] {
        let (d, names) = diagnose_one(&s, &proto, seed);
        assert_eq!(names, vec!["creep"], "seed {seed}: {:?}", d.decisions);
        let p = &d.findings[0].term.params;
        assert_eq!(p["in_conductance"].as_bool(), Some(true), "seed {seed}: {p}");
        let per_decade = p["per_decade_fraction"].as_f64().unwrap();
        assert!((per_decade / 0.043 - 1.0).abs() < 0.10, "seed {seed}: per decade {per_decade}");
        assert!(d.final_.heldout_rmse <= 0.7 * d.baseline.heldout_rmse, "seed {seed}: {} -> {}", d.baseline.heldout_rmse, d.final_.heldout_rmse);
    }
}

/// Issue 15, item 7 (the FSR402-like case as a lab has it): a preload keeps the sensor conducting
/// at "zero" weight, the divider's top compresses the loaded hold's creep to about the noise, and the
/// noise is correlated (AR(1), ρ 0.9). The creep's evidence is the recovery after the lift, one
/// hold; with ten forecast blocks per hold it had nine units and could not reach the paired test's
/// z at any gain (gain 0.88–0.92 at z 2.1–2.3 before the blocks were bounded by time). And the
/// divider converts the response with the preload's in it (the trial's offset; left out, the top's
/// creep was overstated and the per-decade fraction came out 0.065 for 0.05). Now creep alone is
/// named, ≥ 50 % better held out, its per-decade fraction within 10 %; a null under the same
/// conditions names nothing. Seeds not looked at before.
#[test]
fn a_preloaded_fsr402_like_creep_is_found_from_its_recovery_at_zero_load() {
    let (proto, mut s) = fsr402_preloaded();
    for seed in [90_021u64, 90_022] {
        let (d, names) = diagnose_one(&s, &proto, seed);
        assert!(names.is_empty(), "null, seed {seed}: {:?}", d.decisions);
    }
    conductance_creep(&mut s, 0.03);
    for seed in [90_023u64, 90_024, 90_025] {
        let (d, names) = diagnose_one(&s, &proto, seed);
        assert_eq!(names, vec!["creep"], "seed {seed}: {:?}", d.decisions);
        assert!(d.final_.heldout_rmse <= 0.5 * d.baseline.heldout_rmse, "seed {seed}: {} -> {}", d.baseline.heldout_rmse, d.final_.heldout_rmse);
        // the preload's response (the trial's offset) is part of the level the divider converts
        let per_decade = d.findings[0].term.params["per_decade_fraction"].as_f64().unwrap();
        assert!((per_decade / 0.03 - 1.0).abs() < 0.10, "seed {seed}: per decade {per_decade}");
    }
}

/// Issue 15 (the FSR402-like case), family B's form of its creep: a Prony spectrum of the
/// conductance (6 terms over 1–1 000 s, most of its weight at the slow end) under 40 mV of noise and
/// a 25 g preload. The load lands within one sample, so no ramp of the load is sought
/// (`baseline::lands_at_once`): before, a ramp of 1.5 s was taken because it let the steps' τ
/// (4 000 s, onsets hours back) absorb the creep, and the two real jumps then read as handling
/// spikes, the only finding. Now no spike is named, the load changes at once, and the model found
/// predicts the held-out data at least 80 % better than the baseline. (Which name the slow
/// relaxation takes is not asserted here: its weight lies past the hold, where one step cannot
/// tell a spread spectrum from one slow time constant.) Seeds not looked at before; on the old rule
/// seed 90 045 took the ramp and named the spikes (and creep), as did 4 of the 6 seeds probed with
/// the CLI (11, 12, 22, 23; 21 and 24 did not).
#[test]
fn a_slow_prony_creep_after_a_jump_is_no_ramp_and_no_spike() {
    let (proto, mut s) = fsr402_preloaded();
    (s.preload_g, s.noise_v) = (25.0, 0.04);
    conductance_creep(&mut s, 0.04);
    (s.effects.creep_spectrum_terms, s.effects.creep_spectrum_min_s, s.effects.creep_spectrum_max_s, s.effects.creep_spectrum_tilt) = (6, 1.0, 1000.0, 1.0);
    for seed in 90_041u64..=90_046 {
        let (d, names) = diagnose_one(&s, &proto, seed);
        assert!(!names.contains(&"handling_spikes"), "seed {seed}: {names:?}");
        assert!(d.baseline.load_ramp.is_none(), "seed {seed}: {:?}", d.baseline.load_ramp);
        assert!(!names.is_empty() && d.final_.heldout_rmse <= 0.2 * d.baseline.heldout_rmse, "seed {seed}: {names:?}, {} -> {}", d.baseline.heldout_rmse, d.final_.heldout_rmse);
    }
}

/// Issue 15 (the FSR402-like case): the load lands within one sample, so the steps' τ is a jump's
/// nominal one, far under the sample interval. The second relaxation's τ2 grid was built on it
/// (0.01–0.13 s): a 5 % second relaxation of 30 s after a 10 Hz jump gained 1 % at best, and the
/// relaxation spectrum took its residual and was named creep. Now the grid reaches an eighth of a
/// hold (`tau2_scale`): the second time constant is named, alone, with τ2 and its share within
/// 20 %. Seeds not looked at before.
#[test]
fn a_second_relaxation_after_a_jump_is_sought_on_the_holds_scale() {
    let (proto, mut s) = fsr402_preloaded();
    (s.effects.second_fraction, s.effects.second_tau_s) = (0.05, 30.0);
    for seed in [90_031u64, 90_032] {
        let (d, names) = diagnose_one(&s, &proto, seed);
        assert_eq!(names, vec!["second_time_constant"], "seed {seed}: {:?}", d.decisions);
        let p = &d.findings[0].term.params;
        let (tau2, share) = (p["tau2_s"].as_f64().unwrap(), p["fraction"].as_f64().unwrap());
        assert!((tau2 / 30.0 - 1.0).abs() < 0.2 && (share / 0.05 - 1.0).abs() < 0.2, "seed {seed}: {p}");
    }
}

/// Issue 16, item 1 (honest naming): a name stands alone when the drop-one test is decisive. The
/// effects of the tuning family at 1σ each stand alone (no alternatives: the rule is not so loose
/// that every finding gets one), and so does a 2 % hysteresis at zero preload (until stop 40 it
/// brought a weak extra slow relaxation there, the zero-load level's misfit where the ADC's floor
/// cut the noise off). A 1e-5 V/s drift at zero preload leaves a residual a creep or a hysteresis
/// explains about as well: it carries them as alternatives, each with a paired z under
/// Z_SEPARATE, is not of high confidence, and its sentence says so.
#[test]
fn a_name_stands_alone_only_when_the_data_separate_it() {
    use tipforge::sensor::diagnose::Z_SEPARATE;
    let cases: [(&str, fn(&mut SensorParams)); 4] = [
        ("creep", |s| s.effects.creep_per_decade = 2.630e-3),
        ("hysteresis", |s| s.effects.hysteresis = 5.492e-3),
        ("second_time_constant", |s| s.effects.second_fraction = 2.186e-2),
        ("baseline_drift", |s| s.effects.drift_v_per_s = 2.598e-5),
    ];
    for (name, f) in cases {
        let d = diagnose(&case(10_000, f), &Default::default()).unwrap();
        assert_eq!(d.findings.first().map(|f| f.effect), Some(name));
        assert!(d.findings.iter().all(|f| f.alternatives.is_empty() && f.ambiguity.is_none()), "{name}: {:?}", d.findings);
    }
    let at_zero = |f: &dyn Fn(&mut SensorParams), seeds: std::ops::Range<u64>| {
        let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
        f(&mut s);
        let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
        let recs: Vec<_> = seeds.map(|k| simulate(&s, &p, 0.0, None, k).0).collect();
        diagnose(&recs, &Default::default()).unwrap()
    };
    let d = at_zero(&|s| s.effects.hysteresis = 0.02, 7..10);
    let named: Vec<_> = d.findings.iter().map(|f| (f.effect, f.alternatives.len())).collect();
    assert_eq!(named, vec![("hysteresis", 0)]);
    let d = at_zero(&|s| s.effects.drift_v_per_s = 1e-5, 3..6);
    let f = d.findings.iter().find(|f| f.effect == "baseline_drift").expect("the drift is named");
    assert_ne!(f.confidence, "high");
    // (with hysteresis as well until stop 40: the floor's samples, censored at 0 V and fitted over
    // blocks across the logged changes, left a misfit at the steps to zero load that a hysteresis
    // took up as well as the drift; censored at half the ADC's step, over blocks that stop at the
    // changes, only creep explains the drift's residual about as well)
    for alt in ["creep"] {
        let a = f.alternatives.iter().find(|a| a.effect == alt).unwrap_or_else(|| panic!("no {alt} alternative: {:?}", f.alternatives));
        // in the drift's place it predicts about as well: within the separation and within 10 %
        assert!(a.z_named_over_this.abs() < Z_SEPARATE && (a.heldout_rmse / f.heldout_rmse_after - 1.0).abs() < 0.10, "{a:?} vs {}", f.heldout_rmse_after);
    }
    let s = f.ambiguity.as_deref().unwrap();
    assert!(s.starts_with("baseline_drift or creep: this recording cannot tell them apart"), "{s}");
}

/// Issue 16, item 5: a resistance recording without divider metadata (clean simulated data, the
/// divider's voltage turned back into ohms) has noise that grows with the resistance (tenfold at
/// zero load); it must not be taken for handling spikes (25 false spikes when the issue was filed).
#[test]
fn a_resistance_recording_without_divider_metadata_has_no_false_spikes() {
    let d = std::env::temp_dir().join(format!("tipforge-ohm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let mut paths = Vec::new();
    for (k, rec) in case(3000, |_| {}).iter().enumerate() {
        let mut text = String::from("# sample_rate_hz=100\ntime_s,resistance_ohm,load_g\n");
        for i in 0..rec.len() {
            let v = rec.response[i].max(1e-4);
            text += &format!("{:.4},{:.2},{}\n", rec.time_s[i], 1000.0 * (3.3 - v) / v, rec.protocol[i]);
        }
        let p = d.join(format!("r-{}.csv", k + 1));
        std::fs::write(&p, text).unwrap();
        paths.push(p);
    }
    let recs: Vec<_> = paths.iter().map(|p| tipforge::sensor::recording::read(p).unwrap()).collect();
    assert_eq!(recs[0].unit, "ohm");
    let diag = diagnose(&recs, &Default::default()).unwrap();
    assert!(diag.findings.iter().all(|f| f.effect != "handling_spikes"), "{:?}", diag.findings.iter().map(|f| (f.effect, f.windows.len())).collect::<Vec<_>>());
    let _ = std::fs::remove_dir_all(&d);
}

/// Issue 16, item 4: the report shows each named term's contribution as a curve. Hysteresis only
/// acts on the unloading branch: its contribution is nil while the load rises to the top and not
/// after the first removal.
#[test]
fn each_terms_contribution_is_where_its_physics_acts() {
    let d = diagnose(&case(5000, |s| s.effects.hysteresis = 0.03), &Default::default()).unwrap();
    assert_eq!(d.findings.first().map(|f| f.effect), Some("hysteresis"));
    let p = &d.predictions[0];
    let (_, c) = p.contributions.iter().find(|(n, _)| *n == "hysteresis").expect("hysteresis contribution");
    assert_eq!(c.len(), p.time_s.len());
    // the protocol: 10 s at zero, five 20 s holds up (to 110 s), five down
    let max_in = |a: f64, b: f64| p.time_s.iter().zip(c).filter(|(t, _)| **t >= a && **t < b).map(|(_, v)| v.abs()).fold(0.0, f64::max);
    let (rising, falling) = (max_in(0.0, 100.0), max_in(135.0, 200.0));
    assert!(falling > 0.01 && rising < 0.05 * falling, "rising {rising}, falling {falling}");
}

/// Issue 15, item 1: an actuator's load ramps in over seconds (an S-curve of 3.75–11.25 s ending
/// where it lands, logged 0.3 s later). Diagnosed as `--actuator`, the baseline's steps are driven
/// by a fitted ramp: on clean data nothing is found and the baseline predicts held-out data to
/// within a few times the filtered noise (stepping at once it missed by 0.42 V on such data: 140 ×
/// the raw noise); a concealed hysteresis is named. Seeds 81 000–81 200, not looked at before.
#[test]
fn an_actuators_ramp_is_fitted_and_clean_data_stays_clean() {
    let s0 = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    (p.touch_s, p.hold_s, p.top_hold_s, p.baseline_s, p.final_rest_s) = (7.5, 40.0, 40.0, 30.0, 30.0);
    let mut opts = tipforge::sensor::analyze::Options::default();
    opts.pre.handling = false;
    let recs = |s: &SensorParams, seed: u64| (0..3).map(|k| simulate(s, &p, 20.0, None, seed + k).0).collect::<Vec<_>>();
    for seed in [81_000u64, 81_100] {
        let d = diagnose(&recs(&s0, seed), &opts).unwrap();
        let ramp = d.baseline.load_ramp.unwrap_or_else(|| panic!("seed {seed}: no ramp fitted"));
        assert!((4.0..=12.0).contains(&ramp.duration_s), "seed {seed}: {ramp:?}");
        assert!(d.findings.is_empty(), "seed {seed}: {:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
        // the filtered noise is 3 mV / √10 ≈ 1 mV
        assert!(d.baseline.heldout_rmse < 3e-3, "seed {seed}: {}", d.baseline.heldout_rmse);
    }
    let mut s = s0.clone();
    s.effects.hysteresis = 0.05;
    let d = diagnose(&recs(&s, 81_200), &opts).unwrap();
    assert_eq!(d.findings.first().map(|f| f.effect), Some("hysteresis"), "{:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>());
    assert!(d.final_.heldout_rmse < 0.5 * d.baseline.heldout_rmse);
    // loads placed by hand keep the step at once
    assert!(diagnose(&case(1000, |_| {}), &Default::default()).unwrap().baseline.load_ramp.is_none());
}

/// `fit --actuator` on an actuator's ramps (issue 15, items 1 and 6): the steps are fitted from
/// each ramp's end, so the time constants are the sensor's first-order ones (τ = 0.25 + 0.178·F s),
/// not the ramp's or a creep's (the step at once gave 270 s on every step of such data).
#[test]
fn fit_on_an_actuators_ramps_recovers_the_first_order_time_constants() {
    let s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    (p.touch_s, p.hold_s, p.top_hold_s, p.baseline_s, p.final_rest_s) = (7.5, 40.0, 40.0, 30.0, 30.0);
    let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 0.0, None, 82_000 + k).0).collect();
    let mut opts = tipforge::sensor::analyze::Options::default();
    opts.pre.handling = false;
    opts.pre.ramp = tipforge::sensor::diagnose::load_ramp(&recs, &opts);
    assert!(opts.pre.ramp.is_some());
    let (report, _) = tipforge::sensor::analyze::analyze(&recs, &opts);
    let loading: Vec<_> = report.steps.iter().filter(|st| st.phase == tipforge::sensor::preprocess::Phase::Loading).collect();
    assert_eq!(loading.len(), 5);
    for st in loading {
        let f = st.lsq.as_ref().expect("fitted");
        let tau = s.tau(st.after / 1000.0 * tipforge::sensor::sim::G_N_PER_KG);
        assert!((f.tau_s - tau).abs() < 0.15 * tau, "{} g: τ {} s, truth {tau} s", st.after, f.tau_s);
    }
}

/// Issue 15, item 3, and issue 16, item 1: creep that carries over between steps (family A's
/// superposed creep: every change's own log-time creep keeps going). The forward selection offers
/// the restarting creep, which gains nothing here; a second relaxation of 25–40 s took the name,
/// with a drift or hysteresis beside it at 3σ, and stood alone (family A's "creep superposed"
/// variation: 0.00). Now creep is put in each named term's place in both forms, and one effect may
/// stand in for two: at 3σ and 1.85σ creep is named (superposed) or is an alternative of a finding
/// in every case, and at 3σ it is named alone in at least 2 of 3 (the merge or swap a recorded
/// decision; before: 0). Seeds
/// 98 000–98 200, not looked at before (the rule was worked out on 97 000–97 200 and the
/// discovery bench's tuning seeds).
#[test]
fn creep_that_carries_over_is_named_creep_or_its_alternative() {
    for (per_decade, strict_at_least) in [(0.0044, 2), (0.0027, 0)] {
        let mut strict = 0;
        for seed in [98_000u64, 98_100, 98_200] {
            let set = |s: &mut SensorParams| {
                s.effects.creep_per_decade = per_decade;
                s.effects.creep_superposed = true;
            };
            let d = diagnose(&case(seed, set), &Default::default()).unwrap();
            let found: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
            let superposed = |p: &serde_json::Value| p.get("superposed").and_then(|v| v.as_bool()) == Some(true);
            if found == ["creep"] && superposed(&d.findings[0].term.params) {
                assert!(d.decisions.iter().any(|x| x.candidate == "creep" && x.accepted), "seed {seed}: {:?}", d.decisions);
                strict += 1;
            }
            let named = d.findings.iter().any(|f| f.effect == "creep" && superposed(&f.term.params));
            let alternative = d.findings.iter().any(|f| f.alternatives.iter().any(|a| a.effect == "creep" && superposed(&a.params)));
            assert!(named || alternative, "{per_decade} seed {seed}: {:?}", d.findings.iter().map(|f| (f.effect, &f.alternatives)).collect::<Vec<_>>());
            assert!(d.final_.heldout_rmse < 0.7 * d.baseline.heldout_rmse, "seed {seed}");
        }
        assert!(strict >= strict_at_least, "{per_decade}: creep named alone in {strict} of 3");
    }
}

/// Issue 15 (creep that carries over) and 16 (honest naming): creep and a second relaxation that
/// a recording cannot tell apart are named by what the holds show. A superposed creep of 0.15 % of
/// the level per decade (20 s holds; its best single τ2 is longer than a hold) is named creep alone,
/// where stop 31's code named it a second time constant on each of these seeds (creep its
/// alternative); a second relaxation of 8 s (1σ), which settles within the 20 s holds, stays a
/// second time constant. Seeds 97 000–97 500, not looked at before.
#[test]
fn a_relaxation_is_named_by_whether_the_holds_show_it_settle() {
    for seed in [97_000u64, 97_100, 97_200] {
        let d = diagnose(
            &case(seed, |s| {
                s.effects.creep_per_decade = 0.0015;
                s.effects.creep_superposed = true;
            }),
            &Default::default(),
        )
        .unwrap();
        let found: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(found, ["creep"], "seed {seed}: {:?}", d.decisions);
    }
    for seed in [97_300u64, 97_400, 97_500] {
        let d = diagnose(&case(seed, |s| s.effects.second_fraction = 0.0219), &Default::default()).unwrap();
        let found: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(found, ["second_time_constant"], "seed {seed}: {:?}", d.decisions);
    }
}

/// Issue 15 (the trials' nuisances take the effects' place): a per-trial rest relaxation (how long
/// each trial's sensor rested) is validated inside its held-out trial on the part before the first
/// unloading, where a peak's memory does not act yet. Fitted on every other step of the trial, with
/// the trial's offset it mimicked a raised unloading branch, took hysteresis' place and left it
/// under the gate (family A's trial-nuisance variation, report seeds: hysteresis 0.25). With the
/// lab's nuisances (gains ±3 %, rests up to 2σ with τ 100 s, AR noise), a 1.5σ hysteresis is named
/// on every seed (stop 30's code: 2 of these 4). Seeds 99 000–99 300, not looked at before.
#[test]
fn the_trials_rest_states_do_not_take_hysteresis_place() {
    for seed in [99_000u64, 99_100, 99_200, 99_300] {
        let set = |s: &mut SensorParams| {
            trial_nuisances(s);
            s.effects.hysteresis = 8.278e-3;
        };
        let d = diagnose(&case(seed, set), &Default::default()).unwrap();
        assert!(d.findings.iter().any(|f| f.effect == "hysteresis"), "seed {seed}: {:?} {:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>(), d.decisions);
    }
}

/// Issue 15 (a hand's touch before each logged change): the touch — the load lowered, pressed and
/// let go over 0.25–0.75 s — is no sensor physics and differs at every placement. Fitted and
/// scored, its few tenths of a second per step outweighed a hold's worth of a 1σ creep in the
/// held-out error. The window it takes around the onsets is now measured on the baseline's
/// residuals and left out of the fit and the score, as spikes are. With the trials' gains, rests
/// and AR noise as well, a 1σ creep is named on 7 of these 8 fresh seeds (stop 32's code: 2); the
/// eighth case's touches were excluded as handling spikes, and it has no window. Seeds 95 000–
/// 95 700, measured once on the final rule and not tuned on.
#[test]
fn a_hands_touch_is_handling_and_hides_no_creep() {
    let (mut named, mut windows) = (0, 0);
    for seed in (0..8u64).map(|k| 95_000 + 100 * k) {
        let set = |s: &mut SensorParams| {
            trial_nuisances(s);
            s.effects.creep_per_decade = 2.63e-3;
        };
        let touch = |p: &mut ProtocolParams| {
            p.touch_s = 0.5;
            p.press_fraction = 0.12;
        };
        let d = diagnose(&case_with(seed, set, touch), &Default::default()).unwrap();
        if let Some(w) = d.baseline.touch_window {
            assert!(w.before_onset_s >= 0.1 && w.before_onset_s <= 1.0 && w.after_onset_s <= 1.5, "seed {seed}: {w:?}");
            windows += 1;
        }
        named += usize::from(d.findings.iter().any(|f| f.effect == "creep"));
    }
    assert!(windows >= 7, "a touch window in {windows} of 8");
    assert!(named >= 6, "creep named on {named} of 8");
}

fn case_with(seed0: u64, f: impl Fn(&mut SensorParams), g: impl Fn(&mut ProtocolParams)) -> Vec<tipforge::sensor::recording::Recording> {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    f(&mut s);
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    g(&mut p);
    (0..3).map(|k| simulate(&s, &p, 20.0, None, seed0 + k).0).collect()
}

/// Handling spikes of 0.3σ (14.7 mV at every placement, the standard table's smallest) are named,
/// and no touch window is measured where there is no touch. Only the 0.2 V spikes had a test. It
/// is a guard, not a proof against stop 34's reverted window beside part 1's spikes: on these fresh
/// seeds that variant named 15 of 16, this code 16 of 16 (the tuning block 40 000 and the report
/// seeds showed the loss, 0.75 and 0.62). Fresh seeds 98 000–98 700.
#[test]
fn small_handling_spikes_are_named() {
    let named = (0..8u64)
        .map(|k| 98_000 + 100 * k)
        .filter(|&seed| {
            let d = diagnose(&case(seed, |s| s.effects.spike_v = 1.47e-2), &Default::default()).unwrap();
            assert!(d.baseline.touch_window.is_none(), "seed {seed}: no touch, no window");
            d.findings.iter().any(|f| f.effect == "handling_spikes")
        })
        .count();
    assert!(named >= 7, "0.3σ handling spikes named on {named} of 8");
}

/// Issue 15, item 3: hysteresis whose peak memory fades (family A's `memory_s`: the remembered
/// peak force fades toward the present force). A 1 % hysteresis fading over 60 s on 20 s holds is
/// named hysteresis (as the permanent form names it), and the final model carries a fading memory
/// within 20 % of 60 s: its error to the noise-free truth stays under 0.13 mV, where the permanent
/// memory left 0.215 mV (0.087–0.090 mV with the fading one, memory 61.5–62.8 s; other seeds). A
/// permanent memory keeps none. Fresh seeds.
#[test]
fn a_fading_hysteresis_is_modelled_with_its_memory() {
    for (memory_s, seed) in [(60.0, 95_001u64), (60.0, 95_011), (0.0, 95_021)] {
        let f = |s: &mut SensorParams| {
            s.effects.hysteresis = 0.01;
            s.effects.hysteresis_memory_s = memory_s;
        };
        let d = diagnose(&case(seed, f), &Default::default()).unwrap();
        let names: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        let h = d.findings.iter().find(|f| f.effect == "hysteresis").unwrap_or_else(|| panic!("seed {seed}: {names:?}"));
        let fitted = h.term.params.get("memory_s").and_then(|m| m.as_f64());
        let (_, improved) = truth_errors(&d, seed, f);
        if memory_s > 0.0 {
            let m = fitted.unwrap_or_else(|| panic!("seed {seed}: no memory in {}", h.term.params));
            assert!((m / 60.0 - 1.0).abs() < 0.2, "seed {seed}: memory {m} s");
            assert!(improved < 0.13e-3, "seed {seed}: improved error to the truth {improved} V");
        } else {
            assert_eq!(fitted, None, "seed {seed}: a permanent memory fitted as fading: {}", h.term.params);
            assert!(improved < 0.13e-3, "seed {seed}: improved error to the truth {improved} V");
        }
    }
}

/// The physics' sign holds in the final model as in the selection: a hysteresis that entered a 3 %
/// second relaxation's model third (+0.8 % held out, the onsets at part 1's values) turns negative
/// once the final refit frees the onsets (`bench-advice`'s cases, 0 g preload, seeds 11 and 19). It
/// is left out of the final model with a note, so every creep and hysteresis reported has its
/// physics' sign and the twin can carry the model.
#[test]
fn a_term_of_the_other_sign_after_the_final_refit_leaves_the_model() {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    s.effects.second_fraction = 0.03;
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    for seed0 in [11, 19] {
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 0.0, None, seed0 + k).0).collect();
        let d = diagnose(&recs, &Default::default()).unwrap();
        assert!(d.findings.iter().any(|f| f.effect == "second_time_constant"), "seed {seed0}: {:?}", d.final_.effects);
        for f in d.findings.iter().filter(|f| matches!(f.effect, "creep" | "hysteresis")) {
            let frac = f
                .term
                .params
                .get("fraction")
                .or_else(|| f.term.params.get("per_decade_fraction"))
                .or_else(|| f.term.params.get("conductance_fraction"))
                .and_then(|v| v.as_f64())
                .unwrap_or(0.0);
            assert!(frac >= 0.0, "seed {seed0}: {} of fraction {frac} in the final model", f.effect);
        }
        assert!(d.final_.effects.iter().all(|e| d.findings.iter().any(|f| f.effect == *e) || *e == "rest_relaxation"), "seed {seed0}: {:?}", d.final_.effects);
    }
}

/// A weight lowered slowly by hand (over 2.5–7.5 s, ending at the landing) is not a step at once:
/// the steps at once gave a baseline held-out RMSE of 4.7–6.9 mV here (1 mV of noise; 181 mV at no
/// preload, with a false creep). The hand's ramp is fitted as an actuator's is, taken only when it
/// at least halves the baseline's held-out error, so quick placements keep the step at once
/// (`an_actuators_ramp_is_fitted_and_clean_data_stays_clean` checks that on the paper's protocol).
#[test]
fn a_slow_placement_by_hand_takes_a_ramp() {
    let s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    (p.touch_s, p.hold_s, p.top_hold_s, p.baseline_s, p.final_rest_s) = (5.0, 30.0, 30.0, 30.0, 30.0);
    for seed in [82_000u64, 82_100] {
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.0, None, seed + k).0).collect();
        let d = diagnose(&recs, &Default::default()).unwrap();
        let ramp = d.baseline.load_ramp.unwrap_or_else(|| panic!("seed {seed}: no ramp fitted"));
        assert!((1.5..=10.0).contains(&ramp.duration_s), "seed {seed}: {ramp:?}");
        assert!(d.baseline.heldout_rmse < 3e-3, "seed {seed}: {}", d.baseline.heldout_rmse);
    }
}

/// Issue 15, item 4 (a rail before the noise), with the lab's nuisances: compressed top levels
/// (exponent 0.85, the top load at 85 % of the span), the trials' gains, rests and AR noise, and a
/// hand's touch. The rail cuts the top one or two levels; its evidence lies in the three rises into
/// it, one per trial, whose held-out errors differ by two orders of magnitude (seed 24 800: cut
/// 60×, 170× and 2.4×, z of the differences 1.98, so stop 39 named nothing, at a held-out gain of
/// 34 %). A group of units that all halve their errors now passes where no rank test over so few
/// could. Family A's tuning seeds, the rail below the fourth level and half way to the top one.
#[test]
fn a_rail_before_the_noise_is_found_under_the_trials_gains() {
    for (seed, case) in [(24_800u64, 0u64), (24_820, 2)] {
        let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
        (s.exponent, s.effects.saturation_before_noise) = (0.85, true);
        s.g_ref_s = (0.85 / 0.15) / (s.circuit.r_m_ohm * (1.02 * 9.80665f64).powf(0.85));
        trial_nuisances(&mut s);
        let level = |g: f64| s.v_eq((g + 20.0) / 1000.0 * 9.80665);
        s.effects.saturation_v = match case {
            0 => level(800.0) - 0.25 * (level(800.0) - level(600.0)),
            _ => level(800.0) + 0.5 * (level(1000.0) - level(800.0)),
        };
        let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
        (p.touch_s, p.press_fraction) = (0.5, 0.12);
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.0, None, seed + k).0).collect();
        let d = diagnose(&recs, &Default::default()).unwrap();
        assert!(d.findings.iter().any(|f| f.effect == "saturation"), "seed {seed}: {:?} {:?}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>(), d.decisions);
    }
}

/// Samples at the ADC's floor (issue 15's FSR402 on an Arduino reads 0 counts at rest): with no
/// preload the zero-load level sits on 0 V, the simulator's ADC cannot read below it, and the
/// samples left above it put the level about 0.4 σ too high. Every step to or from zero load then
/// misfitted, and a drift or a creep took up the misfit: on family A's advice bench (no preload,
/// 40 cases) stop 39 named 21 false findings and missed 4 truths, among them this 0.4 %
/// hysteresis (named a drift) and this 1e-5 V/s drift (named creep). With the floor's samples
/// replaced by their expected value below it, both are named, and the diagnosis says why.
#[test]
fn samples_at_the_adc_floor_make_no_false_drift() {
    let cases: [(&str, &dyn Fn(&mut SensorParams)); 2] = [("hysteresis", &|s| s.effects.hysteresis = 0.004), ("baseline_drift", &|s| s.effects.drift_v_per_s = 1e-5)];
    for (want, f) in cases {
        let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
        f(&mut s);
        let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 0.0, None, 11 + k).0).collect();
        assert!(recs.iter().all(|r| r.response.iter().filter(|&&v| v == 0.0).count() > 100), "the zero-load level is read at the floor");
        let d = diagnose(&recs, &Default::default()).unwrap();
        let named: Vec<_> = d.findings.iter().map(|f| (f.effect, f.alternatives.iter().map(|a| a.effect).collect::<Vec<_>>())).collect();
        assert!(named.iter().any(|(e, alts)| *e == want || alts.contains(&want)), "{want}: {named:?}");
        assert!(named.iter().all(|(e, alts)| *e == want || alts.contains(&want)), "{want}: a false finding in {named:?}");
        assert!(d.notes.iter().filter(|n| n.contains("the ADC's floor")).count() == 3, "{:?}", d.notes);
        // the predictions' measured column is the recording as read
        for (p, r) in d.predictions.iter().zip(&recs) {
            assert_eq!(p.measured, r.response.iter().step_by(p.stride).copied().collect::<Vec<_>>());
        }
    }
}

/// Samples at the ADC's floor, fitted over blocks that stop at the logged changes and censored at
/// half the ADC's step: a conductance creep of 0.2 % per decade seen through the divider, with no
/// preload (family A's advice case, seed 3). Stop 40 (blocks across the changes, censored at 0 V)
/// named a warm-up drift and a second relaxation, each with creep as an alternative; now creep
/// alone.
#[test]
fn a_conductance_creep_read_at_the_floor_is_named_creep() {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    (s.effects.creep_per_decade, s.effects.creep_superposed, s.effects.creep_in_conductance) = (0.002, true, true);
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 0.0, None, 3 + k).0).collect();
    let d = diagnose(&recs, &Default::default()).unwrap();
    let named: Vec<_> = d.findings.iter().map(|f| (f.effect, f.alternatives.iter().map(|a| a.effect).collect::<Vec<_>>())).collect();
    assert_eq!(named, vec![("creep", vec![])], "{:?}", d.decisions);
}

/// Issue 15, item 4 (saturation when the rail comes before the noise), with the rail's height set
/// as every other effect's: by its RMS contribution, 1σ (the noise-free signal with the rail minus
/// the one without it, over the trial). On 40 g and 200 g steps such a rail cuts only the top
/// level, by a few σ; the staircase's top increment falls to about 0.89 and 0.96 of the
/// continuation of the two below it. Stop 41 proposed a rail only under 0.85, so it never
/// competed (family A's rows: 0 / 8 on both; family B's rail cases: 0 / 6). Fresh seeds 97 000 and
/// 97 100, not looked at before.
#[test]
fn a_rail_of_one_sigma_is_found_on_40_g_and_200_g_steps() {
    for (w, seed) in [(40.0, 97_000u64), (200.0, 97_100)] {
        let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
        s.effects.saturation_before_noise = true;
        let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
        p.weights_g = vec![w; 5];
        let clean = simulate(&s, &p, 20.0, None, seed).1.clean_v;
        let top = clean.iter().copied().fold(f64::MIN, f64::max);
        // the rail whose RMS contribution is 1σ (bisection on its depth below the top)
        let (mut lo, mut hi) = (0.0, top);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            s.effects.saturation_v = top - mid;
            let with = simulate(&s, &p, 20.0, None, seed).1.clean_v;
            let rms = (with.iter().zip(&clean).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / clean.len() as f64).sqrt();
            if rms < s.noise_v {
                lo = mid
            } else {
                hi = mid
            }
        }
        s.effects.saturation_v = top - 0.5 * (lo + hi);
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.0, None, seed + k).0).collect();
        let d = diagnose(&recs, &Default::default()).unwrap();
        let named: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert_eq!(named, vec!["saturation"], "{w} g, seed {seed}: {:?}", d.decisions);
    }
}

/// Issue 15, item 4 and item 5: an amplifier's rail before the noise under the trials' raised rests
/// (family A's row 35 set-up: 40 g steps, five times the noise, the lab's nuisances, a hand's touch
/// with a press, 40 s holds), the rail three quarters of the way from the fourth level to the top
/// one. The rests dominate the held-out error, and neither they nor the rail passes alone in
/// some trial sets; together they do (`select::together`). Seeds not looked at before.
#[test]
fn a_rail_under_the_trials_rests_is_found_with_them() {
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    s.noise_v *= 5.0;
    trial_nuisances(&mut s);
    (s.nuisance.rest_v, s.nuisance.rest_raised) = (2.0 * s.noise_v, true);
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    p.weights_g = vec![40.0; 5];
    (p.hold_s, p.top_hold_s, p.touch_s, p.press_fraction) = (40.0, 40.0, 0.5, 0.12);
    let force = |g: f64| (g + 20.0) / 1000.0 * 9.80665;
    let (l4, l5) = (s.v_eq(force(160.0)), s.v_eq(force(200.0)));
    s.effects.saturation_v = l4 + 0.75 * (l5 - l4);
    s.effects.saturation_before_noise = true;
    let (mut named, mut with_rests) = (0, 0);
    for seed in (0..8).map(|k| 96_000 + 10 * k as u64) {
        let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.0, None, seed + k).0).collect();
        let d = diagnose(&recs, &Default::default()).unwrap();
        let names: Vec<_> = d.findings.iter().map(|f| f.effect).collect();
        assert!(names.iter().all(|&n| n == "saturation"), "seed {seed}: {names:?}");
        // a rest relaxation taken as a partner, and the round after it taking the rail
        let together = d.decisions.iter().find(|dc| dc.stage == "together" && dc.accepted).is_some_and(|t| {
            assert!(t.z >= 3.0, "seed {seed}: {t:?}");
            d.decisions.iter().any(|dc| dc.stage == "forward" && dc.step == t.step + 1 && dc.candidate == "saturation" && dc.accepted)
        });
        named += names.len();
        with_rests += usize::from(together && names == ["saturation"] && d.nuisances.iter().any(|n| n.name == "rest_relaxation"));
    }
    // (on this build 7 of 8 are named, 2 of them through `together`, whose round would otherwise
    // have taken nothing and ended the selection)
    assert!(named >= 7 && with_rests >= 1, "named {named} of 8, {with_rests} with the rests");
}
