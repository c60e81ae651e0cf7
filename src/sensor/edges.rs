//! A step's edge in each trial: where part 1's model puts the step's onset, and with what τ.
//!
//! Three kinds. A step that lands within one sample is a **jump** ([`fit::jump_time`]). A step
//! whose pooled fit puts a trial's onset further before the detected change than the data allow
//! (more than max(2 s, 5 samples of the slowest recording), plus the load's ramp when one is
//! modelled) is **bounded**: its τ, which the data do not determine, follows the slow course of
//! the hold (a fading hysteresis, a creep), and its curve would start in the step before. It
//! takes the data set's typical τ and onset (the median τ, and the median lead over the detected
//! onset, of the steps whose curves start within the bound in every trial). Every other step's
//! edge is the one **fitted**.
//!
//! Read by the search for handling spikes at the steps' edges (`analyze`) and by the diagnosis's
//! baseline, so both see one edge.

use super::analyze::StepReport;
use super::fit::{self, StepFit};
use super::preprocess::{self, Ramp};
use super::recording::Recording;
use serde::Serialize;

/// How a trial's edge was set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EdgeKind {
    Jump,
    Fitted,
    Bounded,
}

/// A trial's step edge: the onset of its first-order curve and its τ.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Edge {
    pub t0_s: f64,
    pub tau_s: f64,
    pub kind: EdgeKind,
}

/// A step whose onset is bounded: the data set's typical τ and lead over the detected onset
/// (t0 − t_on, ≤ 0), and why, in words.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Bounded {
    pub tau_s: f64,
    pub lead_s: f64,
    pub why: String,
}

/// Sets every step's `edges` (one per trial of its pooled fit) and `bounded`, from the steps' fits
/// and jumps. `ramp`: the load's modelled ramp, if any.
pub fn set(steps: &mut [StepReport], recs: &[Recording], ramp: Option<Ramp>) {
    let ramp_s = ramp.filter(|r| r.duration_s > 0.0).map_or(0.0, |r| r.duration_s);
    let lead_s = onset_bound(recs) + ramp_s;
    let typical = typical_step(steps, lead_s);
    for sr in steps.iter_mut() {
        let Some(f) = sr.lsq.as_ref() else { continue };
        let bounded = typical.filter(|_| far_back(sr, f, lead_s)).map(|(tau_s, lead)| Bounded { tau_s, lead_s: lead, why: why(sr, f, lead_s, (tau_s, lead)) });
        let edges = f
            .trials
            .iter()
            .enumerate()
            .map(|(q, tp)| match (sr.jump(q), &bounded) {
                (Some(tj), _) => {
                    let rate = recs.iter().find(|r| r.source == tp.recording).map_or(f64::INFINITY, Recording::sample_rate_hz);
                    Edge { t0_s: tj, tau_s: fit::JUMP_TAU_SHARE / rate, kind: EdgeKind::Jump }
                }
                (None, Some(b)) => Edge { t0_s: tp.t_on + b.lead_s, tau_s: b.tau_s, kind: EdgeKind::Bounded },
                (None, None) => Edge { t0_s: tp.t0, tau_s: f.tau_s, kind: EdgeKind::Fitted },
            })
            .collect();
        sr.edges = edges;
        sr.bounded = bounded;
    }
}

/// The bounded step's note: the farthest fitted onset of a trial that is no jump, the fitted τ and
/// what the step takes (without a ramp: with one, the onset is the data set's ramp's end).
fn why(sr: &StepReport, f: &StepFit, lead_s: f64, (tau_s, lead): (f64, f64)) -> String {
    let back = f.trials.iter().enumerate().filter(|(q, _)| sr.jump(*q).is_none()).map(|(_, tp)| tp.t_on - tp.t0).fold(0.0, f64::max);
    format!(
        "the fit puts the onset up to {back:.1} s before the detected change (the data allow {lead_s:.1} s), with τ = {:.3} s ± {:.3} s: that τ follows the slow course of the hold, not the step; the step is modelled with the data set's typical τ = {tau_s:.3} s and onset {:.2} s before the detected change",
        f.tau_s,
        f.se_tau_s,
        -lead
    )
}

/// How far before the detected onset a step's fitted curve may begin
/// (`fit::ONSET_LEAD_S`, at least five samples of the slowest recording).
pub fn onset_bound(recs: &[Recording]) -> f64 {
    recs.iter().map(|r| 5.0 / r.sample_rate_hz()).fold(fit::ONSET_LEAD_S, f64::max)
}

/// Whether the step's part-1 fit `f` puts a trial's onset, where that trial's step is no jump,
/// more than `lead_s` before its detected onset.
pub fn far_back(sr: &StepReport, f: &StepFit, lead_s: f64) -> bool {
    f.trials.iter().enumerate().any(|(q, tp)| sr.jump(q).is_none() && tp.t0 < tp.t_on - lead_s)
}

/// The median τ and the median onset after the detected one (t0 − t_on, ≤ 0) of the part-1 step
/// fits whose onsets all lie within `lead_s` of the detected ones (the bound and the load's ramp);
/// None when no step's do.
pub fn typical_step(steps: &[StepReport], lead_s: f64) -> Option<(f64, f64)> {
    let (mut taus, mut leads) = (Vec::new(), Vec::new());
    for f in steps.iter().filter_map(|s| s.lsq.as_ref()) {
        if f.trials.iter().all(|tp| tp.t0 >= tp.t_on - lead_s) && f.tau_s.is_finite() {
            taus.push(f.tau_s);
            leads.extend(f.trials.iter().map(|tp| tp.t0 - tp.t_on));
        }
    }
    if taus.is_empty() || leads.is_empty() {
        return None;
    }
    Some((preprocess::median(&mut taus), preprocess::median(&mut leads)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::sensor::{ProtocolParams, SensorParams};
    use crate::params::SourceFile;
    use crate::sensor::analyze;

    fn load(name: &str) -> SourceFile {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("params").join(name);
        SourceFile::parse(&path.display().to_string(), std::fs::read_to_string(&path).unwrap()).unwrap()
    }

    /// Five 40 g steps up and down under five times the noise, and after the third removal a
    /// 100 mV gap that fades over 240 s, building up with the sensor's step: that step's pooled
    /// fit follows the fading and puts its onsets far back. Its edges are bounded (the typical τ,
    /// within the bound of the detected onsets) and say why; every other step's edge is its fit's.
    #[test]
    fn a_far_back_onset_is_bounded_and_the_others_are_the_fits() {
        let mut s = SensorParams::from_source(&load("sensor.toml")).unwrap();
        s.noise_v *= 5.0;
        let mut p = ProtocolParams::from_source(&load("protocol-1000g.toml")).unwrap();
        p.weights_g = vec![40.0; 5];
        p.hold_s = 40.0;
        p.top_hold_s = 40.0;
        let mut recs = Vec::new();
        for k in 0..3 {
            let (mut r, truth) = crate::sensor::sim::simulate(&s, &p, 20.0, None, 94_010 + k);
            let st = truth.steps.iter().filter(|s| s.load_after_g < s.load_before_g).nth(2).unwrap();
            for (v, &t) in r.response.iter_mut().zip(&r.time_s) {
                if t >= st.t_land_s {
                    *v += 0.1 * (-(t - st.t_land_s) / 240.0).exp() * (1.0 - (-(t - st.t_land_s) / st.tau_s).exp());
                }
            }
            recs.push(r);
        }
        let (report, _) = analyze::analyze(&recs, &analyze::Options::default());
        let bound = onset_bound(&recs);
        let (tau_med, lead_med) = typical_step(&report.steps, bound).expect("steps within the bound");
        let mut bounded = 0;
        for sr in &report.steps {
            let f = sr.lsq.as_ref().unwrap();
            assert_eq!(sr.edges.len(), f.trials.len());
            for (q, (e, tp)) in sr.edges.iter().zip(&f.trials).enumerate() {
                match e.kind {
                    EdgeKind::Jump => assert_eq!(Some(e.t0_s), sr.jump(q)),
                    EdgeKind::Fitted => assert!(e.t0_s == tp.t0 && e.tau_s == f.tau_s && sr.bounded.is_none()),
                    EdgeKind::Bounded => {
                        bounded += 1;
                        assert!(e.t0_s >= tp.t_on - bound, "{:?} {}: {} s for {} s", sr.phase, sr.index, e.t0_s, tp.t_on);
                        assert!(e.tau_s == tau_med && (e.t0_s - tp.t_on - lead_med).abs() < 1e-12);
                        assert!(far_back(sr, f, bound) && sr.bounded.as_ref().is_some_and(|b| b.why.contains("typical τ")));
                    }
                }
            }
        }
        assert!(bounded > 0, "no step's onset was bounded: the case no longer tests the bound");
    }
}
