//! When simulation and recordings differ: locate the mismatch, name the physics left out, model
//! it, refit, and keep a term only when it predicts held-out data better.
//!
//! Model ("the simulation"): every trial is a superposition of first-order steps,
//!   V(t) = o_i + Σ_s [level(L_s) − level(L_{s−1})] · (1 − e^{−(t − t0_s)/τ_s}),
//! with levels shared across trials per load (loading and unloading alike), τ_s from the exact
//! per-step fit and t0 the onsets found in each trial. Catalogue terms add to it (all linear given
//! their shape parameter): creep, hysteresis, a second time constant, baseline drift, and
//! saturation (a clip); handling spikes are reported and excluded, never modelled. Selection is
//! forward: a term enters when it lowers the held-out error (leave one trial out; with one
//! recording, leave one step out) with a paired z of at least `MIN_Z` over trial × step units, and
//! BIC by at least `MIN_DBIC`.

mod alternatives;
mod baseline;
mod clip;
mod first_order;
mod gate;
mod input;
mod locate;
mod model;
mod normal;
mod nuisance;
mod refit;
mod report;
mod heldout;
mod select;
mod spectrum;
mod terms;

use super::analyze::{self, Options, Prepared, Report};
use super::preprocess::Phase;
use super::recording::Recording;
use nalgebra::{DMatrix, DVector};
use input::*;
use normal::*;
pub use alternatives::{Alternative, Z_SEPARATE};
pub use nuisance::NuisanceTerm;
use serde::Serialize;
use select::Selected;
use spectrum::*;
use baseline::*;
use clip::*;
use first_order::*;
use gate::*;
use locate::*;
use model::*;
use terms::*;
pub use baseline::{SimBaseline, MIN_PRELOAD_GAIN};
pub use gate::MIN_ROBUST_GAIN;
pub use report::*;
pub use heldout::Score;
use heldout::*;
use refit::refit_onsets;

/// A term must improve held-out prediction with a paired z of at least this over units.
pub const MIN_Z: f64 = 3.0;
pub const MIN_DBIC: f64 = -10.0;
/// The relaxation spectrum is preferred to an exact form (creep, one second time constant) that
/// also passes only when its held-out RMSE (both with their first-order shape refitted) is lower
/// by more than this share. Set on family A: a 5 % second relaxation (seed 70 000) came out 4.7 %
/// better held out with the spectrum, yet 2.8 × the floor's error to the truth; the exact form
/// reaches the floor. On the shared recording the spectrum is 38 % better.
pub const SPECTRUM_MARGIN: f64 = 0.10;
pub const SCHEMA: &str = "tipforge.diagnosis/1";

use super::catalogue::second_time_constant::Drive;
pub use super::catalogue::Effect;
use super::catalogue::{self, Steps, MODELLED as CATALOGUE};

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
    let Some(sb) = sim else { return run_spike_checked(recs, opts, None, false) };
    let Some((given, best, best_score)) = preload_search(recs, opts, sb) else { return run_spike_checked(recs, opts, sim, false) };
    let gain = (given.heldout_rmse - best_score.heldout_rmse) / given.heldout_rmse.max(1e-300);
    if gain < MIN_PRELOAD_GAIN || (best - sb.preload_g).abs() < 1.0 {
        return run_spike_checked(recs, opts, sim, false);
    }
    let corrected = SimBaseline { sensor: sb.sensor, preload_g: best };
    let mut d = run_spike_checked(recs, opts, Some(&corrected), false)?;
    let dbic = best_score.bic - given.bic + (given.n.max(2) as f64).ln();
    d.findings.insert(
        0,
        Finding {
            effect: "preload_mismatch",
            confidence: if gain > 0.25 { "high" } else { "medium" },
            explanation: format!(
                "the recordings sit where the simulator puts a preload of {} g, not the {} g it was given (--rig manifest or the sensor file's rig.preload_g): a constant load the logged protocol leaves out (the plunger's mass, a pre-tensioned cover) or a level offset; corrected before any other term was sought",
                catalogue::sig3(best),
                catalogue::sig3(sb.preload_g)
            ),
            windows: vec![],
            term: Term { name: "preload_mismatch".into(), params: serde_json::json!({"preload_g_given": sb.preload_g, "preload_g_fitted": best}) },
            heldout_rmse_before: given.heldout_rmse,
            heldout_rmse_after: best_score.heldout_rmse,
            delta_bic: dbic,
            alternatives: vec![],
            ambiguity: None,
        },
    );
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
    with_ramp(recs, &lsq).pre.ramp
}

/// The estimation floor of the model's first-order part: [`diagnose`] with the final refit done
/// even when no term is chosen, so its `baseline` predictions are what the improved model reduces
/// to when the data hold no effect. On the same noise without an effect, their error to the truth
/// is the least error any model with the baseline's freedom (levels, time constants, onsets) plus
/// terms can be expected to reach (the discovery benchmark's floor column).
pub fn refitted_baseline(recs: &[Recording], opts: &Options) -> Option<Diagnosis> {
    run_spike_checked(recs, opts, None, true)
}

/// What one pass of the diagnosis gives: the diagnosis, or the finding that the handling spikes it
/// would exclude are not spikes, decided before any term is selected.
enum Outcome {
    Done(Box<Diagnosis>),
    SpikesRejected {
        windows: Vec<Window>,
        before: f64,
        after: f64,
        unit: String,
    },
    /// Only the baseline was scored (a simulator preload being searched).
    Baseline(Score),
}

/// Handling spikes are excluded only when held-out evidence agrees. Excluding true spikes lowers
/// the baseline's held-out error (the bench's spike cases: −36 % to −91 %); short excursions at
/// step edges that are the first-order model's misfit (a large, slow second relaxation: the curve
/// leaves the data right at the edge) look alike to the detectors, but excluding them cuts the
/// edges that pin the onsets and raises it (0.033 → 0.045 V on a 22 % second relaxation). `run`
/// compares the two baselines before selection and stops there; the diagnosis then runs on the
/// data as given, and the windows are kept as located failures of the baseline, each saying why
/// it was not excluded.
fn run_spike_checked(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool) -> Option<Diagnosis> {
    let with_ramp = if sim.is_none() { with_ramp(recs, opts) } else { opts.clone() };
    let opts = &with_ramp;
    let (windows, before, after, unit) = match run(recs, opts, sim, refit_always, false)? {
        Outcome::Done(d) => return Some(*d),
        Outcome::SpikesRejected { windows, before, after, unit } => (windows, before, after, unit),
        Outcome::Baseline(_) => return None,
    };
    let mut as_given = opts.clone();
    as_given.pre.handling = false;
    let Outcome::Done(mut again) = run(recs, &as_given, sim, refit_always, false)? else { return None };
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

/// The diagnosis; with `baseline_only`, only the baseline's score.
fn run(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool, baseline_only: bool) -> Option<Outcome> {
    let (report, prep) = analyze::analyze(recs, opts);
    let mut trials = trials_from(&report, &prep, recs, opts);
    // the baseline is the paper's model fitted to the data as given: with handling spikes found,
    // its steps (onsets, time constants) are the part-1 fits of the series with the spikes left in
    let has_spikes = report.recordings.iter().any(|r| !r.spikes.is_empty());
    let mut given_trials: Option<Vec<Trial>> = if has_spikes {
        let mut o = opts.clone();
        o.pre.handling = false;
        let (rep_g, prep_g) = analyze::analyze(recs, &o);
        let g = trials_from(&rep_g, &prep_g, recs, opts);
        let same = g.len() == trials.len() && g.iter().zip(&trials).all(|(a, b)| a.segs.len() == b.segs.len() && a.segs.iter().zip(&b.segs).all(|(x, y)| x.key == y.key));
        same.then_some(g)
    } else {
        None
    };
    if let Some(sb) = sim {
        let kind = recs.first()?.protocol_kind;
        let force = |load: f64| kind.grams(load).map(|g| (g + sb.preload_g) / 1000.0 * super::sim::G_N_PER_KG);
        for tr in trials.iter_mut().chain(given_trials.iter_mut().flatten()) {
            let f0 = force(tr.segs.first().map(|s| s.prev).unwrap_or(0.0))?;
            tr.prior0 = Some(sb.sensor.v_eq(f0));
            for sg in &mut tr.segs {
                let (fa, fb) = (force(sg.load)?, force(sg.prev)?);
                sg.sim = Some((sb.sensor.v_eq(fa) - sb.sensor.v_eq(fb), sb.sensor.tau(fa)));
                sg.tau = sb.sensor.tau(fa);
            }
        }
    }
    let mut loads: Vec<f64> = trials.iter().flat_map(|t| t.segs.iter().flat_map(|s| [s.load, s.prev])).collect();
    loads.sort_by(|a, b| a.partial_cmp(b).unwrap());
    loads.dedup();
    if loads.len() < 2 {
        return None;
    }
    let n_keys = trials.iter().flat_map(|t| t.segs.iter().map(|s| s.key + 1)).max().unwrap_or(0);
    // steps whose edge lost a handling spike: their onsets are refitted with the shared levels
    let refit_onset: Vec<(usize, usize)> = trials
        .iter()
        .enumerate()
        .flat_map(|(k, tr)| {
            let spikes = report.recordings.iter().find(|r| r.source == tr.name).map(|r| r.spikes.clone()).unwrap_or_default();
            tr.segs
                .iter()
                .enumerate()
                .filter(move |(_, sg)| spikes.iter().any(|w| w.end_s >= sg.t0 - 0.5 && w.start_s <= sg.t0 + 1.0))
                .map(move |(s, _)| (k, s))
                .collect::<Vec<_>>()
        })
        .collect();
    let d = Design { loads: loads.clone(), n_trials: trials.len(), n_keys, refit_onset, prior: sim.is_some(), exact_shape: false };
    // levels per load for the terms built on them (two-stage): from a first fit, or the simulator's
    let hat = match sim {
        Some(sb) => {
            let kind = recs[0].protocol_kind;
            let level = loads.iter().map(|&l| kind.grams(l).map(|g| sb.sensor.v_eq((g + sb.preload_g) / 1000.0 * super::sim::G_N_PER_KG)).unwrap_or(0.0)).collect();
            Hat { loads: loads.clone(), level }
        }
        None => {
            let level_cfg = Config {
                tau_free: false,
                effects: vec![],
                tau2: 1.0,
                drive: Drive::Change,
                clip: None,
                tau_fixed: vec![],
                restart: vec![],
                relax: None,
                gains: false,
                rest_tau: None,
                drift_tau: None,
            };
            let rows = all_rows(&trials);
            let x0 = solve(&d, &trials, &rows, &level_cfg, &Hat::default())?;
            let mut level = vec![0.0];
            level.extend(x0[trials.len()..trials.len() + loads.len() - 1].iter().copied());
            Hat { loads: loads.clone(), level }
        }
    };
    let hat0 = hat.clone();
    // the baseline: first-order steps with their levels and time constants refitted jointly
    let base_cfg =
        Config { tau_free: true, effects: vec![], tau2: 1.0, drive: Drive::Change, clip: None, tau_fixed: vec![], restart: vec![], relax: None, gains: false, rest_tau: None, drift_tau: None };
    // fitted to the series as given (with the steps fitted to it), scored on the series without
    // the spikes (with the same steps); the diagnosis works on the latter, and the spikes are
    // reported and excluded below
    let base_eval: Vec<Trial> = match &given_trials {
        Some(g) => trials.iter().zip(g).map(|(tr, gt)| Trial { segs: gt.segs.clone(), ..tr.clone() }).collect(),
        None => trials.clone(),
    };
    let base_fit: Vec<Trial> =
        if has_spikes { base_eval.iter().map(|tr| Trial { t: tr.given_t.clone(), v: tr.given_v.clone(), ..tr.clone() }).collect() } else { base_eval.clone() };
    let (base, xb) = score_on(&d, &base_fit, &base_eval, &base_cfg, &hat)?;
    if baseline_only {
        return Some(Outcome::Baseline(base));
    }
    let (clean, xc) = if has_spikes { score(&d, &trials, &base_cfg, &hat)? } else { (base.clone(), xb.clone()) };
    if has_spikes && clean.heldout_rmse > base.heldout_rmse {
        let windows = signature(Effect::HandlingSpikes, &[], &trials, None, &report);
        return Some(Outcome::SpikesRejected { windows, before: base.heldout_rmse, after: clean.heldout_rmse, unit: report.unit.clone() });
    }
    let clip = clip_level(&trials);
    // locate: every test on the baseline's residuals (the clean fit), before any term is chosen
    let located = located_windows(&d, &trials, &xc, &base_cfg, &hat, clip, &report);
    let clip_steps = match clip {
        Some(c) => clipped_segments(&trials, c),
        None => ClipSteps { into: vec![], from: vec![], units: vec![] },
    };
    let actuator = !opts.pre.handling || recs.iter().any(|r| r.meta.all.get("loading").is_some_and(|l| l.trim() == "actuator"));
    let med_tau = {
        let mut t: Vec<f64> = trials.iter().flat_map(|t| t.segs.iter().map(|s| s.tau)).collect();
        super::preprocess::median(&mut t)
    };
    let Selected { cfg: mut cur, score: mut cur_score, x: mut cur_x, hat, mut findings, mut decisions, mut nuisances, round0_exact } =
        select::select(&base_cfg, clean.clone(), xc.clone(), hat, &Ctx { d: &d, trials: &trials, hat: &Hat::default(), clip, clip_steps: &clip_steps, med_tau }, &report);
    let mut spectrum_exact: Option<Exact> = None;
    // honest naming: the other effects that explain each finding's residual about as well
    for (e, alts) in alternatives::alternatives(&cur, &cur_score, &Ctx { d: &d, trials: &trials, hat: &hat, clip, clip_steps: &clip_steps, med_tau }) {
        if let Some(f) = findings.iter_mut().find(|f| f.effect == e.name()) {
            f.alternatives = alts;
            alternatives::apply(f);
        }
    }
    // the relaxation spectrum (issue 15): the exact forms of relaxation (creep, one second time
    // constant) give way to a spectrum over every change when it predicts the held-out data
    // clearly better than the whole model the catalogue found
    if !d.prior {
        spectrum_exact = replace_exact(&d, &trials, &hat, (&mut cur, &mut cur_score, &mut cur_x), &mut findings, &mut decisions, round0_exact.as_ref(), actuator, clip, &report);
    }
    // the second relaxation's τ2 was chosen on a grid (steps of ×1.371): refined between the grid
    // points around it by golden-section search on the training fit (the same rule that chose it),
    // so the final model's slow relaxation is not off by up to half a grid step. Here with the
    // simulator's first-order part; otherwise the final refit does it with the refitted shape.
    if cur.effects.contains(&Effect::SecondTimeConstant) && d.prior {
        if let Some((c, s, x)) = refine_tau2(&d, &trials, &cur, &hat) {
            cur = c;
            cur_score = s;
            cur_x = x;
        }
    }
    // the terms' parameters as in the final model (all terms fitted jointly, levels re-estimated)
    for f in findings.iter_mut() {
        if let Some(&e) = cur.effects.iter().find(|e| e.name() == f.effect) {
            f.term.params = term_params(&d, &cur, &cur_x, e, &hat);
        }
    }
    findings.extend(reported_only(&trials, &cur, &cur_score, clip, &report, (&base, &clean)));
    let remaining = locate(&d, &trials, &cur_x, &cur, &hat);
    let mut evidence: Vec<String> = remaining.iter().map(|w| format!("{} {:.1}–{:.1} s: {}", w.recording, w.start_s, w.end_s, w.statistic)).collect();
    if !remaining.is_empty() {
        if let Some(line) = step_transients(&d, &trials, &cur_x, &cur, &hat, &report.unit) {
            evidence.insert(0, line);
        }
    }
    let unexplained = Unexplained { flag: !remaining.is_empty(), evidence };
    let (cur, cur_x, final_trials, final_base, xb) = refit::final_refit(&d, trials, base_eval, &base_fit, (&base_cfg, &hat0, xb), (cur, cur_x, &hat), &mut findings, refit_always);
    let predictions = refit::predictions(recs, &d, &final_trials, &final_base, (&base_cfg, &hat0, &xb), (&cur, &hat, &cur_x), &findings);
    let by_unit = unit_errors(&final_base, &base, &cur_score);
    let (levels, taus) = if d.prior { (vec![], vec![]) } else { first_order_part(&d, &cur, &cur_x, &final_trials) };
    // the spectrum's finding takes the name its fitted shape gives
    let mut final_names: Vec<&'static str> = cur.effects.iter().filter(|e| **e != Effect::RestRelaxation).map(|e| e.name()).collect();
    // the nuisances' parameters as in the final model
    for n in nuisances.iter_mut().filter(|n| n.name == Effect::RestRelaxation.name()) {
        n.params = term_params(&d, &cur, &cur_x, Effect::RestRelaxation, &hat);
    }
    for f in findings.iter_mut().filter(|f| f.effect == Effect::Relaxation.name()) {
        name_spectrum(f, spectrum_exact.as_ref());
        let own = f.effect;
        f.alternatives.retain(|a| a.effect != own);
        alternatives::apply(f);
        for n in final_names.iter_mut().filter(|n| **n == Effect::Relaxation.name()) {
            *n = f.effect;
        }
    }
    let notes =
        report.steps.iter().filter_map(|s| s.tau_describes_creep.as_ref().map(|why| format!("{:?} step {} ({} → {}): {why}", s.phase, s.index + 1, s.before, s.after))).collect();
    let diagnosis = Diagnosis {
        advice: Vec::new(),
        advice_notes: Vec::new(),
        notes,
        nuisances,
        schema: SCHEMA,
        recordings: recs.iter().map(|r| r.source.clone()).collect(),
        unit: report.unit.clone(),
        baseline: Baseline {
            model: if sim.is_some() {
                "the simulator's first-order prediction for the logged protocol (per-trial offsets fitted)".into()
            } else {
                "first-order step per load change, levels shared across trials (the paper's model, fitted exactly)".into()
            },
            rmse: base.rmse,
            heldout_rmse: base.heldout_rmse,
            bic: base.bic,
            load_ramp: opts.pre.ramp.filter(|r| r.duration_s > 0.0 && sim.is_none()),
        },
        final_: Final {
            effects: final_names,
            rmse: cur_score.rmse,
            heldout_rmse: cur_score.heldout_rmse,
            units_better: by_unit.iter().filter(|u| u.improved_rmse < u.baseline_rmse).count(),
            units_scored: by_unit.len(),
            heldout_by_unit: by_unit,
            levels,
            taus,
        },
        findings,
        unexplained,
        decisions,
        located,
        predictions,
    };
    Some(Outcome::Done(Box::new(diagnosis)))
}
