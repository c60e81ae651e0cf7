//! When simulation and recordings differ: locate the mismatch, name the physics left out, model
//! it, refit, and keep a term only when it predicts held-out data better.
//!
//! Model ("the simulation"): every trial is a superposition of first-order steps,
//!   V(t) = o_i + Σ_s [level(L_s) − level(L_{s−1})] · (1 − e^{−(t − t0_s)/τ_s}),
//! with levels shared across trials per load (loading and unloading alike), τ_s from the exact
//! per-step fit and t0 the onsets found in each trial. Catalogue terms add to it (all linear given
//! their shape parameter): creep, hysteresis, a second time constant, baseline drift, a relaxation
//! spectrum and saturation (a clip); handling spikes are reported and excluded, never modelled.
//! A term enters when it lowers the held-out error (leave one trial out; with one recording, leave
//! one step out or forecast the later blocks of each hold) with a paired z of at least `MIN_Z`
//! over units (`gate::change_z`: for a clip, over the units it can change), a held-out gain above
//! `MIN_TERM_GAIN` and BIC lower by at least `MIN_DBIC` (the least in-sample gain);
//! of the terms that pass, the one that predicts held-out data best (issue 15, item 5).
//!
//! The pipeline (`run`), one stage per file, on recordings whose samples piled at an ADC's floor
//! (0 V) were first replaced by their expected value below it (`diagnose_with`, through
//! `sensor::censored`):
//! 1. `baseline` — an actuator's load ramp chosen once per data set by the baseline's own
//!    cross-validation (`with_ramp`; the ramp's response and each step's own ramp are `input`'s);
//!    part 1's step fits as trials (`trials_from`, the types in `model`); the paper's model fitted
//!    and scored held out (`heldout`, solved through `normal`), or the simulator's prediction;
//!    without a ramp, the window a hand's touch takes around the onsets (`touch`), whose samples
//!    are then neither fitted nor scored;
//! 2. `spikes` — the handling spikes' check: excluded unless that raises the held-out error (a tie
//!    within 3 % is decided by the largest excursion, at least 6 raw σ);
//! 3. `locate` — where the baseline fails: the whiteness test and every effect's signature;
//! 4. `select` — nuisances (`nuisance`), then the catalogue's terms (`terms`, with `clip` for
//!    saturation) forward and backward through the `gate`; the other names that explain the same
//!    residual (`alternatives`); the relaxation spectrum in place of the exact forms (`spectrum`);
//! 5. `refit` and `report` — the final refit of the first-order shape with the terms, the
//!    predictions, and the diagnosis.
//!
//! Shared by the stages, and calling none of them: `model`, `first_order` (the filtered first-order
//! rise and its derivatives), `input`, `normal`, `heldout`, `gate` and `parameters` (a term's
//! parameters and the first-order part as reported). A stage calls only those and the stages before
//! it; the report's types (`Finding`, `Decision`, …) are data every stage may build.

mod alternatives;
mod baseline;
mod clip;
mod first_order;
#[cfg(test)]
mod fixture;
mod gate;
mod heldout;
mod input;
mod locate;
mod model;
mod normal;
mod nuisance;
mod parameters;
mod refit;
mod report;
mod select;
mod spectrum;
mod spikes;
mod terms;
mod through;
mod touch;

use super::analyze::{self, Options, Prepared, Report};
use super::catalogue::second_time_constant::Drive;
use super::catalogue::{self, Steps, MODELLED as CATALOGUE};
use super::preprocess::Phase;
use super::recording::Recording;
use baseline::*;
use clip::*;
use first_order::*;
use gate::*;
use heldout::*;
use input::*;
use locate::*;
use model::*;
use nalgebra::{DMatrix, DVector};
use normal::*;
use parameters::*;
use select::Selected;
use serde::Serialize;
use spectrum::*;
use terms::*;
use through::*;

pub use super::catalogue::Effect;
pub use alternatives::Alternative;
pub use baseline::{SimBaseline, MIN_PRELOAD_GAIN};
pub use gate::{MIN_ROBUST_GAIN, MIN_TERM_GAIN, Z_SEPARATE};
pub use heldout::Score;
pub use nuisance::NuisanceTerm;
pub use report::*;

/// A term must improve held-out prediction with a paired z of at least this over units.
pub const MIN_Z: f64 = 3.0;
/// A term (and the set-up's per-trial gains) must also lower BIC by this much: the least in-sample
/// gain, never the ranking. Without it, a creep restarting at every step entered at a held-out gain
/// of 0.06 % (z 5.9, ΔBIC 0) on an FSR402-like recording whose conductance creeps, and the trials'
/// gains entered on a clean sensor with a 1e-5 V/s drift (ΔBIC +49, 26 % better held out at z 5.7)
/// and moved the drift's alternative from creep to hysteresis (`tests/advice.rs`, seed 3).
pub const MIN_DBIC: f64 = -10.0;
/// The relaxation spectrum is preferred to an exact form (creep, one second time constant) that
/// also passes only when its held-out RMSE (both with their first-order shape refitted) is lower
/// by more than this share. Set on family A: a 5 % second relaxation (seed 70 000) came out 4.7 %
/// better held out with the spectrum, yet 2.8 × the floor's error to the truth; the exact form
/// reaches the floor. On the shared recording the spectrum is 38 % better.
pub const SPECTRUM_MARGIN: f64 = 0.10;
pub const SCHEMA: &str = "tipforge.diagnosis/1";

/// The diagnosis of recordings against the paper's model (see [`diagnose_with`]).
pub fn diagnose(recs: &[Recording], opts: &Options) -> Option<Diagnosis> {
    diagnose_with(recs, opts, None)
}

/// With `sim`, the simulator's first-order prediction for each trial's logged protocol (at the
/// onsets found in the data) is the baseline; only per-trial offsets and catalogue terms are fitted.
///
/// A simulator whose preload is not the recordings' is corrected first: the preload that fits the
/// recordings best is sought, and when it predicts held-out data better it is named as a preload
/// (or offset) mismatch, the first finding, and the rest of the diagnosis runs on the corrected
/// simulator (a wrong preload changes every level and time constant, and would otherwise be
/// taken for other effects).
pub fn diagnose_with(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>) -> Option<Diagnosis> {
    let (read, floor_notes) = floor_replaced(recs);
    let mut d = diagnose_read(&read, opts, sim)?;
    if !floor_notes.is_empty() {
        // the predictions' `measured` column is the recording as read, the floor's samples at 0 V
        for (p, rec) in d.predictions.iter_mut().zip(recs) {
            p.measured = rec.response.iter().step_by(p.stride.max(1)).copied().collect();
        }
    }
    d.notes.splice(0..0, floor_notes);
    Some(d)
}

/// The recordings with their samples at an ADC's floor (0 V) replaced by their expected values below
/// it (`censored`), and a note for each recording that had them.
fn floor_replaced(recs: &[Recording]) -> (std::borrow::Cow<'_, [Recording]>, Vec<String>) {
    let fixed: Vec<Option<(Recording, super::censored::Censored)>> = recs.iter().map(super::censored::uncensored).collect();
    if fixed.iter().all(Option::is_none) {
        return (std::borrow::Cow::Borrowed(recs), vec![]);
    }
    let notes = recs.iter().zip(&fixed).filter_map(|(r, f)| f.as_ref().map(|(_, c)| super::censored::note(&r.source, c, r.len()))).collect();
    let recs = recs.iter().zip(fixed).map(|(r, f)| f.map(|(x, _)| x).unwrap_or_else(|| r.clone())).collect();
    (std::borrow::Cow::Owned(recs), notes)
}

/// [`diagnose_with`] on recordings whose floor is taken care of.
fn diagnose_read(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>) -> Option<Diagnosis> {
    let Some(sb) = sim else { return run_spike_checked(recs, opts, None, false) };
    let Some((given, best, best_score)) = preload_search(recs, opts, sb) else { return run_spike_checked(recs, opts, sim, false) };
    let gain = (given.heldout_rmse - best_score.heldout_rmse) / given.heldout_rmse.max(1e-300);
    if gain < MIN_PRELOAD_GAIN || (best - sb.preload_g).abs() < 1.0 {
        return run_spike_checked(recs, opts, sim, false);
    }
    let corrected = SimBaseline { sensor: sb.sensor, preload_g: best };
    let mut d = run_spike_checked(recs, opts, Some(&corrected), false)?;
    d.findings.insert(0, preload_finding(sb.preload_g, best, (&given, &best_score)));
    d.final_.effects.insert(0, "preload_mismatch");
    d.baseline.rmse = given.rmse;
    d.baseline.heldout_rmse = given.heldout_rmse;
    d.baseline.bic = given.bic;
    Some(d)
}

/// The load's ramp of an actuator's recordings as `diagnose` fits it (None for loads placed by
/// hand, or when no ramp beats the step at once): for `fit`, whose step fits then take the level
/// before each ramp and fit from its end.
pub fn load_ramp(recs: &[Recording], opts: &Options) -> Option<super::preprocess::Ramp> {
    let lsq = Options { method: analyze::Method::Lsq, ..opts.clone() };
    with_ramp(&floor_replaced(recs).0, &lsq).0.pre.ramp
}

/// The estimation floor of the model's first-order part: [`diagnose`] with the final refit done
/// even when no term is chosen, so its `baseline` predictions are what the improved model reduces
/// to when the data hold no effect. On the same noise without an effect, their error to the truth
/// is the least error any model with the baseline's freedom (levels, time constants, onsets) plus
/// terms can be expected to reach (the discovery benchmark's floor column).
pub fn refitted_baseline(recs: &[Recording], opts: &Options) -> Option<Diagnosis> {
    run_spike_checked(&floor_replaced(recs).0, opts, None, true)
}

/// What one pass of the diagnosis gives: the diagnosis, or the finding that the handling spikes it
/// would exclude are not spikes, decided before any term is selected.
enum Outcome {
    Done(Box<Diagnosis>),
    SpikesRejected { windows: Vec<Window>, before: f64, after: f64, unit: String },
}

/// Handling spikes are excluded unless held-out evidence disagrees (`spikes::rejected`). Excluding true spikes lowers
/// the baseline's held-out error (the bench's spike cases: −36 % to −91 %); short excursions at
/// step edges that are the first-order model's misfit (a large, slow second relaxation: the curve
/// leaves the data right at the edge) look alike to the detectors, but excluding them cuts the
/// edges that pin the onsets and raises it (0.033 → 0.045 V on a 22 % second relaxation). `run`
/// compares the two baselines before selection and stops there; the diagnosis then runs on the
/// data as given, and the windows are kept as located failures of the baseline, each saying why
/// it was not excluded.
fn run_spike_checked(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool) -> Option<Diagnosis> {
    let (with_ramp, built) = if sim.is_none() { with_ramp(recs, opts) } else { (opts.clone(), None) };
    let opts = &with_ramp;
    let (windows, before, after, unit) = match run(recs, opts, sim, refit_always, built)? {
        Outcome::Done(d) => return Some(*d),
        Outcome::SpikesRejected { windows, before, after, unit } => (windows, before, after, unit),
    };
    let mut as_given = opts.clone();
    as_given.pre.handling = false;
    let Outcome::Done(mut again) = run(recs, &as_given, sim, refit_always, None)? else { return None };
    let why = format!(
        "short excursion at a step edge, not excluded as a handling spike: excluding the {} such window(s) raised the baseline's held-out RMSE {} → {} {unit}, so they are the model's misfit at the edges",
        windows.len(),
        catalogue::sig3(before),
        catalogue::sig3(after),
    );
    again.located.extend(windows.into_iter().map(|w| LocatedWindow {
        test: Effect::HandlingSpikes.name(),
        recording: w.recording,
        start_s: w.start_s,
        end_s: w.end_s,
        statistic: format!("{}; {why}", w.statistic),
    }));
    Some(*again)
}

/// The diagnosis, stage by stage; `built` is the baseline when the ramp's search built it already.
fn run(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool, built: Option<Built>) -> Option<Outcome> {
    // 1. the baseline: the paper's model from part 1's step fits (or the simulator), held out
    let b = match built {
        Some(b) => b,
        None => baseline::build(recs, opts, sim)?,
    };
    // 2. handling spikes are excluded unless that predicts held-out data worse (`spikes`)
    let (clean, xc) = if b.has_spikes { score(&b.d, &b.trials, &b.base_cfg, &b.hat)? } else { (b.base.clone(), b.xb.clone()) };
    if b.has_spikes && spikes::rejected(&b, &clean, recs) {
        let windows = signature(Effect::HandlingSpikes, &[], &b.trials, None, &b.report);
        return Some(Outcome::SpikesRejected { windows, before: b.base.heldout_rmse, after: clean.heldout_rmse, unit: b.report.unit.clone() });
    }
    // 3. locate: every test on the baseline's residuals (the clean fit), before any term is chosen
    // a clip: samples piled at one value, or an amplifier's rail before the noise (the levels'
    // staircase cut at the top; only ever modelled, never reported on its plateau)
    let piled = clip_level(&b.trials);
    let clip = piled.or_else(|| rail_level(&b.d, &b.trials, &b.hat));
    let located = located_windows(&b.d, &b.trials, &xc, &b.base_cfg, &b.hat, piled, &b.report);
    let clip_steps = ClipSteps::of(&b.trials, clip, clip.is_some() && piled.is_none());
    // 4. name the physics left out: terms selected held out, alternatives, the relaxation spectrum
    let actuator = recs.iter().any(|r| !crate::sensor::preprocess::by_hand(r, &opts.pre));
    let chosen = select::choose(&b, (&clean, &xc), clip, &clip_steps, actuator);
    // 5. model it, refit, and report
    Some(Outcome::Done(Box::new(report::diagnosis(recs, opts, sim, b, chosen, (&clean, located), piled, refit_always))))
}
