use tipforge::params::sensor::{ProtocolParams, SensorParams};
use tipforge::params::SourceFile;
use tipforge::sensor::diagnose::diagnose;
use tipforge::sensor::sim::simulate;
fn load(path: &str) -> SourceFile { SourceFile::parse(path, std::fs::read_to_string(path).unwrap()).unwrap() }
fn main() {
    let s0 = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    let cases: Vec<(&str, Box<dyn Fn(&mut SensorParams)>)> = vec![
        ("null", Box::new(|_s| {})),
        ("creep", Box::new(|s| s.effects.creep_per_decade = 0.01)),
        ("hyst", Box::new(|s| s.effects.hysteresis = 0.03)),
        ("second", Box::new(|s| s.effects.second_fraction = 0.1)),
        ("drift", Box::new(|s| s.effects.drift_v_per_s = 1e-4)),
        ("sat", Box::new(|s| s.effects.saturation_v = 1.55)),
        ("spikes", Box::new(|s| s.effects.spike_v = 0.2)),
        ("creep+drift", Box::new(|s| { s.effects.creep_per_decade = 0.01; s.effects.drift_v_per_s = 1e-4; })),
    ];
    for (name, f) in cases {
        let mut s = s0.clone(); f(&mut s);
        let recs: Vec<_> = (1..=3).map(|k| simulate(&s, &p, 20.0, None, 50 + k).0).collect();
        let t = std::time::Instant::now();
        let d = diagnose(&recs, &Default::default()).unwrap();
        println!("{name}: {:?} base {:.5} -> {:.5} ({:?}) unexplained {}", d.findings.iter().map(|f| f.effect).collect::<Vec<_>>(), d.baseline.heldout_rmse, d.final_.heldout_rmse, t.elapsed(), d.unexplained.flag);
        for dc in &d.decisions { if dc.gain > 0.0 { print!("  [{} {} g{:.3} b{:.0}]", dc.step, dc.candidate, dc.gain, dc.delta_bic); } }
        println!();
    }
}
