//! Test fixtures for the stages' own tests: three trials of the paper's protocol from family A's
//! simulator (`params/sensor.toml`, a 20 g preload), with an effect set by `f`, and the baseline
//! stage built on them.

use super::*;
use crate::params::sensor::{ProtocolParams, SensorParams};
use crate::params::SourceFile;

fn load(name: &str) -> SourceFile {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("params").join(name);
    SourceFile::parse(&path.display().to_string(), std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// The sensor file's parameters with `f` applied.
pub(super) fn sensor(f: impl Fn(&mut SensorParams)) -> SensorParams {
    let mut s = SensorParams::from_source(&load("sensor.toml")).unwrap();
    f(&mut s);
    s
}

/// Three trials (seeds `seed0`, +1, +2) of the 0–1000 g protocol, and their noise-free truth.
pub(super) fn recs_and_truth(seed0: u64, f: impl Fn(&mut SensorParams)) -> (Vec<Recording>, Vec<crate::sensor::sim::Truth>) {
    recs_and_truth_with(seed0, f, |_| {})
}

/// As [`recs_and_truth`], with the protocol changed by `g`.
pub(super) fn recs_and_truth_with(seed0: u64, f: impl Fn(&mut SensorParams), g: impl Fn(&mut ProtocolParams)) -> (Vec<Recording>, Vec<crate::sensor::sim::Truth>) {
    let s = sensor(f);
    let mut p = ProtocolParams::from_source(&load("protocol-1000g.toml")).unwrap();
    g(&mut p);
    (0..3).map(|k| crate::sensor::sim::simulate(&s, &p, 20.0, None, seed0 + k)).unzip()
}

/// Three trials of the 0–1000 g protocol.
pub(super) fn recs(seed0: u64, f: impl Fn(&mut SensorParams)) -> Vec<Recording> {
    recs_and_truth(seed0, f).0
}

/// Three trials of the 0–1000 g protocol changed by `g`.
pub(super) fn recs_with(seed0: u64, f: impl Fn(&mut SensorParams), g: impl Fn(&mut ProtocolParams)) -> Vec<Recording> {
    recs_and_truth_with(seed0, f, g).0
}

/// `recs` with a decay from each trial's start added (amplitudes `amps`, V, with time constant
/// `tau_s`: the trials' rest states) and a warm-up shared by the trials (`drift`: its size in V and
/// its time constant).
pub(super) fn with_decays(mut recs: Vec<Recording>, amps: [f64; 3], tau_s: f64, (drift_v, drift_tau_s): (f64, f64)) -> Vec<Recording> {
    for (r, a) in recs.iter_mut().zip(amps) {
        let t0 = r.time_s[0];
        r.response.iter_mut().zip(&r.time_s).for_each(|(v, t)| *v += a * (-(t - t0) / tau_s).exp() + drift_v * (1.0 - (-(t - t0) / drift_tau_s).exp()));
    }
    recs
}

/// The baseline stage on `recs`, with the default options (loads placed by hand).
pub(super) fn built(recs: &[Recording]) -> Built {
    build(recs, &Options::default(), None).expect("the baseline is built")
}

/// The baseline stage on `recs`, with the default options changed by `f`.
pub(super) fn built_with_options(recs: &[Recording], f: impl Fn(&mut Options)) -> Built {
    let mut o = Options::default();
    f(&mut o);
    build(recs, &o, None).expect("the baseline is built")
}

/// The context the selection's stages take, on a built baseline.
pub(super) fn ctx<'a>(b: &'a Built, clip_steps: &'a ClipSteps, hat: &'a Hat) -> Ctx<'a> {
    let tau2_scale = tau2_scale(&b.trials);
    Ctx { d: &b.d, trials: &b.trials, hat, clip: clip_level(&b.trials), clip_steps, tau2_scale }
}
