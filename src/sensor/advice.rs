//! Advice computed, not canned (issue 16, item 2). For every finding whose name does not stand
//! alone (it has alternatives), the recording's sensor is built twice as a twin: once with the
//! named term, once with the best alternative's term fitted in its place. Both are simulated,
//! noise-free and with the same seed, on the recording's own protocol (as the simulator states
//! it) and on protocol changes that pull slow effects apart: a long hold at the top load, a long
//! rest at zero after the last removal, every hold longer, a repeated cycle, a slower ramp. The
//! separation of the two predicted signals is given as the paired z the diagnosis's own held-out
//! test would reach between the two names on such a recording: per unit (a step, in each of the
//! recording's trials) the wrong name's extra squared error is the sum of the squared difference
//! of the two predictions over it, and its noise is what the recording itself shows: the spread
//! over its held-out units of the two names' squared-error difference per sample (at least the
//! white-noise floor 2σ‖d‖ of the unit),
//!
//!   z = √trials · Σ_u Σ_{i∈u} d_i² / √(Σ_u sd_u²),  sd_u = max(s · n_u, 2σ √(Σ_{i∈u} d_i²)).
//!
//! The twins state each name in the simulator's forms, which can differ more than the fitted models
//! did: every expected z is scaled by (|z reached on the recording| + 1) / (z the twins give on
//! its own protocol + 1), never up. The scaled z on the recording's own protocol is given beside
//! the advised one, and the z the recording actually reached. The advice is the shortest change that reaches [`MIN_SEPARATION_SIGMA`],
//! else the one that separates most (and it says that it will not decide the question). It is
//! written as a protocol file `simulate --protocol` reads. Nothing is advised when nothing is
//! ambiguous.

use super::analyze::Report;
use super::diagnose::Diagnosis;
pub use super::diagnose::{Advice, Candidate};
use super::recording::Recording;
use super::sim;
use crate::params::sensor::{ProtocolParams, SensorParams};

/// The separation (in noise σ) at which the advised recording decides between the two names.
pub const MIN_SEPARATION_SIGMA: f64 = 3.0;
/// A long hold or rest: this many times the recording's hold, and at least `LONG_MIN_S`.
const LONG_FACTOR: f64 = 5.0;
const LONG_MIN_S: f64 = 600.0;
/// The seed of the advice's noise-free simulations: both names' twins draw the same touches (the
/// slower ramp's durations), so their difference is the names' alone.
const SEED: u64 = 16;

/// The advice for every ambiguous finding, and a note for each one that could not be advised
/// (why: no divider metadata, a term the simulator has no form for, …).
pub fn advise(d: &Diagnosis, report: &Report, rec: &Recording, actuator: bool) -> (Vec<Advice>, Vec<String>) {
    let ambiguous: Vec<usize> = (0..d.findings.len()).filter(|&i| !d.findings[i].alternatives.is_empty()).collect();
    if ambiguous.is_empty() {
        return (vec![], vec![]);
    }
    let mut notes = Vec::new();
    if let Err(why) = super::twin::can_write(rec) {
        notes.push(format!("no protocol advice: {why}"));
        return (vec![], notes);
    }
    let Some(base) = protocol_of(rec) else {
        notes.push("no protocol advice: the recording's load column is not a staircase the simulator can repeat".into());
        return (vec![], notes);
    };
    let trials = d.recordings.len().max(1);
    let mut out = Vec::new();
    for i in ambiguous {
        let f = &d.findings[i];
        if !simulable(f.effect, &f.term.params) || f.term.name == "relaxation_spectrum" {
            notes.push(format!("no protocol advice for {}: the simulator has no form for its term", f.effect));
            continue;
        }
        let Some(alt) = f.alternatives.iter().filter(|a| simulable(a.effect, &a.params)).min_by(|a, b| a.heldout_rmse.total_cmp(&b.heldout_rmse)) else {
            notes.push(format!("no protocol advice for {}: the simulator has no form for its alternatives' terms", f.effect));
            continue;
        };
        let mut d2 = d.clone();
        d2.findings[i].effect = alt.effect;
        d2.findings[i].term.name = format!("{}_term", alt.effect);
        d2.findings[i].term.params = alt.params.clone();
        // the alternative's own first-order part: fitted with it in place, it takes up what it can
        d2.final_.levels = alt.first_order.0.clone();
        d2.final_.taus = alt.first_order.1.clone();
        // every found term in both twins; when a fitted value of another term is outside what the
        // simulator accepts, both twins carry only this finding's term (the others are common to
        // both names), and the advice says so
        let only = |dd: &Diagnosis| Diagnosis { findings: vec![dd.findings[i].clone()], ..dd.clone() };
        let pair = match (twin(d, report, rec), twin(&d2, report, rec)) {
            (Ok(a), Ok(b)) => Ok((a, b, None)),
            (Err(why), _) | (_, Err(why)) => match (twin(&only(d), report, rec), twin(&only(&d2), report, rec)) {
                (Ok(a), Ok(b)) => Ok((a, b, Some(format!("the twins carry only this finding's term and the first-order part: with every term, {why}")))),
                (Err(w), _) | (_, Err(w)) => Err(w),
            },
        };
        match pair {
            Ok((named, other, caveat)) => {
                let noise = Noise { sigma: named.noise_v, z_observed: alt.z_named_over_this, unit_sd_per_sample: alt.unit_sd_per_sample, trials };
                let mut a = advise_one(i, f.effect, alt.effect, (&named, &other), (&base, actuator), &noise);
                if let Some(c) = caveat {
                    a.sentence = format!("{} ({c})", a.sentence);
                }
                out.push(a);
            }
            Err(why) => notes.push(format!("no protocol advice for {}: the twins cannot be built ({why})", f.effect)),
        }
    }
    (out, notes)
}

/// The effects the simulator has a form for, with the parameters the twin writes.
fn simulable(effect: &str, params: &serde_json::Value) -> bool {
    match effect {
        "creep" | "hysteresis" | "baseline_drift" | "saturation" => true,
        "second_time_constant" => {
            params.get("drive").and_then(|v| v.as_str()) != Some(super::catalogue::second_time_constant::Drive::Size.label()) && params.get("fraction").is_some()
        }
        _ => false,
    }
}

fn twin(d: &Diagnosis, report: &Report, rec: &Recording) -> Result<SensorParams, String> {
    let text = super::twin::sensor_toml(d, report, rec)?;
    let src = crate::params::SourceFile::parse("twin", text).map_err(|e| e.to_string())?;
    SensorParams::from_source(&src).map_err(|e| e.to_string())
}

/// The recording's protocol as the simulator states it: the weights stacked up to the top load,
/// the median hold, the hold at the top, the rests before the first and after the last change,
/// the cycles (returns to the starting load). Logged at the landing, no touch.
pub fn protocol_of(rec: &Recording) -> Option<ProtocolParams> {
    let (t, p) = (&rec.time_s, &rec.protocol);
    let g = |x: f64| rec.protocol_kind.grams(x);
    let mut changes: Vec<(f64, f64)> = Vec::new();
    for k in 1..p.len() {
        if (p[k] - p[k - 1]).abs() > 1e-9 * p[k].abs().max(1.0) {
            changes.push((t[k], p[k]));
        }
    }
    if changes.is_empty() {
        return None;
    }
    let start = p[0];
    let top = changes.iter().map(|c| c.1).fold(f64::NEG_INFINITY, f64::max);
    let i_top = changes.iter().position(|c| c.1 == top)?;
    let mut weights: Vec<f64> = Vec::new();
    let mut prev = start;
    for c in &changes[..=i_top] {
        if c.1 > prev {
            weights.push(g(c.1)? - g(prev)?);
        }
        prev = c.1;
    }
    if weights.is_empty() {
        return None;
    }
    let mut holds: Vec<f64> = changes.windows(2).map(|w| w[1].0 - w[0].0).collect();
    let top_hold = changes.get(i_top + 1).map(|c| c.0 - changes[i_top].0)?;
    holds.sort_by(f64::total_cmp);
    let hold = holds.get(holds.len() / 2).copied().unwrap_or(top_hold);
    let cycles = changes.iter().filter(|c| (c.1 - start).abs() <= 1e-9 * start.abs().max(1.0)).count().clamp(1, 10);
    Some(ProtocolParams {
        weights_g: weights,
        hold_s: hold.max(1.0),
        baseline_s: (changes[0].0 - t[0]).max(1.0),
        logging_offset_s: 0.0,
        logging_jitter_s: 0.0,
        touch_s: 0.0,
        press_fraction: 0.0,
        top_hold_s: top_hold.max(1.0),
        final_rest_s: (t[t.len() - 1] - changes[changes.len() - 1].0).max(1.0),
        cycles,
    })
}

/// An actuator's slower ramp: its travel (s), and every hold and rest at least this many times it
/// (family A's actuator row, where the diagnosis is measured: 7.5 s ramps, 40 s holds).
const SLOW_RAMP_S: f64 = 5.0;
const HOLDS_PER_RAMP: f64 = 8.0;

/// The protocol changes tried, each from the recording's own protocol. A slower ramp only for an
/// actuator's recordings, with its holds lengthened to [`HOLDS_PER_RAMP`] times the ramp: a weight
/// lowered slowly by hand is handling, whose samples the diagnosis neither fits nor scores, so it
/// cannot separate two names; and on family A's 20 s holds, each weight lowered over 2.5–7.5 s,
/// the diagnosis of a sensor without effects named a drift and handling spikes (and before the
/// hand's ramp, a creep or a second relaxation at a baseline error of 15–304 mV). Advised by hand
/// in family A's advice bench (stop 38), the slower ramp named the truth in 0 of 3 cases.
fn candidates(base: &ProtocolParams, actuator: bool) -> Vec<(&'static str, ProtocolParams)> {
    let long = (LONG_FACTOR * base.hold_s).max(LONG_MIN_S);
    let mut v = vec![("the recording's own protocol", base.clone())];
    v.push(("a long hold at the top load", ProtocolParams { top_hold_s: base.top_hold_s.max(long), ..base.clone() }));
    v.push(("a long rest at zero load after the last removal", ProtocolParams { final_rest_s: base.final_rest_s.max(long), ..base.clone() }));
    v.push(("every hold four times longer", ProtocolParams { hold_s: 4.0 * base.hold_s, top_hold_s: 4.0 * base.top_hold_s, ..base.clone() }));
    if base.cycles < 10 {
        v.push(("one more load-unload cycle", ProtocolParams { cycles: base.cycles + 1, ..base.clone() }));
    }
    if actuator {
        let hold = HOLDS_PER_RAMP * SLOW_RAMP_S;
        let slow = ProtocolParams {
            touch_s: SLOW_RAMP_S,
            hold_s: base.hold_s.max(hold),
            top_hold_s: base.top_hold_s.max(hold),
            baseline_s: base.baseline_s.max(hold),
            final_rest_s: base.final_rest_s.max(hold),
            ..base.clone()
        };
        v.push(("a slower ramp (each weight lowered over 5 s, every hold and rest at least 40 s)", slow));
    }
    v
}

fn duration(p: &ProtocolParams) -> f64 {
    sim::schedule(p).1
}

/// What the comparison of two names is measured against.
struct Noise {
    sigma: f64,
    /// The paired z the recording reached between the two names.
    z_observed: f64,
    unit_sd_per_sample: f64,
    trials: usize,
}

struct Run {
    t: Vec<f64>,
    load: Vec<f64>,
    a: Vec<f64>,
    b: Vec<f64>,
    /// Samples of the recording each simulated sample stands for.
    weight: f64,
}

/// The most samples an advice simulation takes: a longer protocol is simulated at a lower rate and
/// each sample stands for `weight` of the recording's.
const MAX_SAMPLES: f64 = 200_000.0;

fn run_both(named: &SensorParams, other: &SensorParams, proto: &ProtocolParams) -> Run {
    let rate = named.circuit.sample_rate_hz;
    let slower = (MAX_SAMPLES / duration(proto).max(1.0)).min(rate);
    let at = |p: &SensorParams| {
        let mut q = p.clone();
        q.circuit.sample_rate_hz = slower;
        q
    };
    let (ra, ta) = sim::simulate(&at(named), proto, named.preload_g, None, SEED);
    let (_, tb) = sim::simulate(&at(other), proto, other.preload_g, None, SEED);
    Run { t: ra.time_s, load: ra.protocol, a: ta.clean_v, b: tb.clean_v, weight: rate / slower }
}

/// The paired z between the two names on `run`'s protocol, and the RMS of their difference.
fn separation(run: &Run, noise: &Noise) -> (f64, f64) {
    let n = run.a.len().min(run.b.len());
    let d2: Vec<f64> = (0..n).map(|i| (run.a[i] - run.b[i]).powi(2)).collect();
    let rms = (d2.iter().sum::<f64>() / n.max(1) as f64).sqrt();
    // units: from each load change to the next (the samples before the first change are not scored)
    let mut starts: Vec<usize> = (1..n).filter(|&i| run.load[i] != run.load[i - 1]).collect();
    starts.push(n);
    let (mut sum, mut var) = (0.0, 0.0);
    for w in starts.windows(2) {
        let s: f64 = run.weight * d2[w[0]..w[1]].iter().sum::<f64>();
        let sd = (noise.unit_sd_per_sample * run.weight * (w[1] - w[0]) as f64).max(2.0 * noise.sigma * s.sqrt());
        sum += s;
        var += sd * sd;
    }
    let z = if var > 0.0 { (noise.trials as f64).sqrt() * sum / var.sqrt() } else { 0.0 };
    (z, rms)
}

fn advise_one(
    i: usize,
    effect: &'static str,
    alternative: &'static str,
    (named, other): (&SensorParams, &SensorParams),
    (base, actuator): (&ProtocolParams, bool),
    noise: &Noise,
) -> Advice {
    let sigma = noise.sigma;
    let mut cands = Vec::new();
    let mut runs = Vec::new();
    for (change, proto) in candidates(base, actuator) {
        let run = run_both(named, other, &proto);
        let (sep, rms) = separation(&run, noise);
        cands.push((Candidate { change, duration_s: duration(&proto), separation_sigma: sep, rms_difference: rms }, proto));
        runs.push(run);
    }
    // the twins state each name in the simulator's forms, which may differ more (or less) than
    // the fitted models did on the recording: every expected z is scaled by what the recording
    // showed against what the twins give on its own protocol (never up)
    let k = ((noise.z_observed.abs() + 1.0) / (cands[0].0.separation_sigma + 1.0)).min(1.0);
    for c in &mut cands {
        c.0.separation_sigma *= k;
    }
    let now = cands[0].0.separation_sigma;
    // the shortest change that decides; else the one that separates most
    let changes = 1..cands.len();
    let pick = changes
        .clone()
        .filter(|&k| cands[k].0.separation_sigma >= MIN_SEPARATION_SIGMA)
        .min_by(|&a, &b| cands[a].0.duration_s.total_cmp(&cands[b].0.duration_s))
        .or_else(|| changes.max_by(|&a, &b| cands[a].0.separation_sigma.total_cmp(&cands[b].0.separation_sigma)))
        .unwrap_or(0);
    let (c, proto) = (&cands[pick].0, &cands[pick].1);
    let decides = c.separation_sigma >= MIN_SEPARATION_SIGMA;
    let sentence = format!(
        "to tell {effect} from {alternative}, record {} ({:.0} s a trial): the held-out test between them is then expected at a paired z of {:.1}, against {now:.1} on this protocol{}",
        c.change,
        c.duration_s,
        c.separation_sigma,
        if decides { "" } else { " (still short of 3 σ: a longer or repeated recording is needed to decide)" }
    );
    let stem = format!("advice/protocol-{i}-{effect}-or-{alternative}.toml");
    let toml = protocol_toml(proto, &sentence);
    let run = runs.swap_remove(pick);
    Advice {
        finding: i,
        effect,
        alternative,
        change: c.change,
        sentence,
        protocol_file: stem,
        plot: format!("plots/advice-{i}.png"),
        separation_sigma: c.separation_sigma,
        separation_sigma_now: now,
        z_observed: noise.z_observed,
        heldout_rmse_if_right: sigma,
        heldout_rmse_if_wrong: (sigma * sigma + c.rms_difference * c.rms_difference).sqrt(),
        candidates: cands.into_iter().map(|(c, _)| c).collect(),
        protocol_toml: toml,
        curves: [run.t, run.load, run.a, run.b],
    }
}

/// The advised protocol as a `kind = "protocol"` file.
pub fn protocol_toml(p: &ProtocolParams, why: &str) -> String {
    let list: Vec<String> = p.weights_g.iter().map(|w| format!("{w}")).collect();
    format!(
        "# tipforge diagnose: advised protocol\n# {why}\nkind = \"protocol\"\nweights_g = [{}]\nhold_s = {:.1}\ntop_hold_s = {:.1}\nbaseline_s = {:.1}\nfinal_rest_s = {:.1}\ncycles = {}\ntouch_s = {:.1}\nlogging_offset_s = 0.3\nlogging_jitter_s = 0.15\n",
        list.join(", "),
        p.hold_s,
        p.top_hold_s,
        p.baseline_s,
        p.final_rest_s,
        p.cycles,
        p.touch_s
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    use sim::tests::defaults;

    fn sensor() -> SensorParams {
        defaults().0
    }

    /// The simulator's protocol read back from a recording it made: weights, holds, rests, cycles.
    #[test]
    fn the_recordings_protocol_is_read_back_as_the_simulator_states_it() {
        let p = ProtocolParams {
            weights_g: vec![100.0, 200.0, 200.0],
            hold_s: 15.0,
            baseline_s: 12.0,
            logging_offset_s: 0.0,
            logging_jitter_s: 0.0,
            touch_s: 0.0,
            press_fraction: 0.0,
            top_hold_s: 40.0,
            final_rest_s: 30.0,
            cycles: 2,
        };
        let (rec, truth) = sim::simulate(&sensor(), &p, 0.0, None, 5);
        assert_eq!(truth.steps.len(), 12, "two cycles of three placements and three removals");
        let q = protocol_of(&rec).unwrap();
        assert_eq!(q.weights_g, p.weights_g);
        assert_eq!(q.cycles, 2);
        for (got, want) in [(q.hold_s, 15.0), (q.top_hold_s, 40.0), (q.baseline_s, 12.0), (q.final_rest_s, 30.0)] {
            assert!((got - want).abs() < 0.02, "{q:?}");
        }
        // the recording is as long as the protocol says
        let last = rec.time_s[rec.time_s.len() - 1];
        assert!((last - duration(&p)).abs() < 0.02, "{last} vs {}", duration(&p));
        // and the defaults of the new fields change nothing: one cycle, the top hold a hold
        let one = ProtocolParams { cycles: 1, top_hold_s: 15.0, final_rest_s: 12.0, ..p.clone() };
        let (r1, t1) = sim::simulate(&sensor(), &one, 0.0, None, 5);
        assert_eq!(t1.steps.len(), 6);
        assert!((r1.time_s[r1.time_s.len() - 1] - (12.0 + 5.0 * 15.0 + 12.0)).abs() < 0.02);
    }

    /// Two twins that differ only by a drift separate more the longer the recording runs, and the
    /// expected z is 0 between a twin and itself.
    #[test]
    fn the_separation_grows_with_what_the_protocol_change_adds() {
        let a = sensor();
        let mut b = a.clone();
        b.effects.drift_v_per_s = 2e-5;
        let base = defaults().1;
        let noise = Noise { sigma: a.noise_v, z_observed: 0.0, unit_sd_per_sample: 0.0, trials: 3 };
        let same = separation(&run_both(&a, &a, &base), &noise);
        assert_eq!(same.0, 0.0);
        let now = separation(&run_both(&a, &b, &base), &noise).0;
        let long = separation(&run_both(&a, &b, &ProtocolParams { final_rest_s: 600.0, ..base.clone() }), &noise).0;
        assert!(now > 0.0 && long > 2.0 * now, "{now} {long}");
        // a long protocol simulated at a lower rate reads about the same z
        let long_p = ProtocolParams { final_rest_s: 600.0, ..base.clone() };
        let full = separation(&run_both(&a, &b, &long_p), &noise).0;
        let (mut a2, mut b2) = (a.clone(), b.clone());
        a2.circuit.sample_rate_hz = 25.0;
        b2.circuit.sample_rate_hz = 25.0;
        let slow = Run { weight: 4.0, ..run_both(&a2, &b2, &long_p) };
        let cut = separation(&slow, &noise).0;
        assert!((cut / full - 1.0).abs() < 0.1, "{cut} vs {full}");
        // noisier units (as the recording showed) lower it
        let noisy = Noise { unit_sd_per_sample: 1e-4, ..noise };
        assert!(separation(&run_both(&a, &b, &base), &noisy).0 < now);
    }

    /// A slower ramp is tried only for an actuator's recordings, with every hold and rest long
    /// enough for it and a protocol file that loads; placed by hand, no candidate has a ramp.
    #[test]
    fn a_slower_ramp_is_tried_only_for_an_actuator() {
        let base = defaults().1;
        assert!(candidates(&base, false).iter().all(|(c, p)| !c.starts_with("a slower ramp") && p.touch_s == base.touch_s), "{:?}", candidates(&base, false));
        let with = candidates(&base, true);
        let (_, p) = with.iter().find(|(c, _)| c.starts_with("a slower ramp")).expect("a slower ramp for an actuator");
        let shortest = p.hold_s.min(p.top_hold_s).min(p.baseline_s).min(p.final_rest_s);
        assert!(p.touch_s == SLOW_RAMP_S && shortest >= HOLDS_PER_RAMP * p.touch_s, "{p:?}");
        assert!(crate::params::sensor::touch_fits(p.touch_s, shortest));
        let src = crate::params::SourceFile::parse("advised", protocol_toml(p, "test")).unwrap();
        assert!(ProtocolParams::from_source(&src).is_ok());
    }
}
