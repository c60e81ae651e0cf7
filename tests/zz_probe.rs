#[path = "common/nuisances.rs"]
mod nuisances;
use nuisances::trial_nuisances;
use tipforge::params::sensor::{ProtocolParams, SensorParams};
use tipforge::params::SourceFile;
use tipforge::sensor::diagnose::diagnose;
use tipforge::sensor::sim::simulate;

fn load(path: &str) -> SourceFile {
    SourceFile::parse(path, std::fs::read_to_string(path).unwrap()).unwrap()
}
fn compress(s: &mut SensorParams, n: f64, share: f64) {
    s.exponent = n;
    let x = share / (1.0 - share);
    s.g_ref_s = x / (s.circuit.r_m_ohm * (1.020 * 9.80665f64).powf(n));
}
fn rail_case(s: &SensorParams, p: &ProtocolParams, case: u64) -> f64 {
    let level = |k: usize| s.v_eq((p.weights_g.iter().take(k).sum::<f64>() + 20.0) / 1000.0 * 9.80665);
    let n = p.weights_g.len();
    let (l3, l4, l5) = (level(n - 2), level(n - 1), level(n));
    match case % 4 {
        0 => l4 - 0.25 * (l4 - l3),
        k => l4 + 0.25 * k as f64 * (l5 - l4),
    }
}

#[test]
fn probe() {
    let seed: u64 = std::env::var("SEED").unwrap().parse().unwrap();
    let case: u64 = std::env::var("CASE").unwrap_or("0".into()).parse().unwrap();
    let nuis = std::env::var("NUIS").map(|v| v == "1").unwrap_or(true);
    let mut s = SensorParams::from_source(&load("params/sensor.toml")).unwrap();
    let mut p = ProtocolParams::from_source(&load("params/protocol-1000g.toml")).unwrap();
    compress(&mut s, 0.85, 0.85);
    s.effects.saturation_before_noise = true;
    if nuis {
        trial_nuisances(&mut s);
        p.touch_s = 0.5;
        p.press_fraction = 0.12;
    }
    if std::env::var("SAT").map(|v| v == "1").unwrap_or(true) {
        s.effects.saturation_v = rail_case(&s, &p, case);
    }
    let levels: Vec<f64> = (0..=5).map(|k| s.v_eq((p.weights_g.iter().take(k).sum::<f64>() + 20.0) / 1000.0 * 9.80665)).collect();
    eprintln!("rail {} levels {:?}", s.effects.saturation_v, levels);
    let recs: Vec<_> = (0..3).map(|k| simulate(&s, &p, 20.0, None, seed + k).0).collect();
    let d = diagnose(&recs, &Default::default()).unwrap();
    eprintln!("findings {:?}", d.findings.iter().map(|f| f.effect.to_string()).collect::<Vec<_>>());
    eprintln!("nuisances {:?}", d.nuisances.iter().map(|f| f.name.to_string()).collect::<Vec<_>>());
    eprintln!("baseline {:.3} mV final {:.3} mV", d.baseline.heldout_rmse * 1e3, d.final_.heldout_rmse * 1e3);
    for x in &d.decisions {
        eprintln!("  {} {} gain {:.3} z {:.2} dbic {:.0} {}", x.step, x.candidate, x.gain, x.z, x.delta_bic, x.accepted);
    }
    for n in &d.notes {
        eprintln!("note: {n}");
    }
}
