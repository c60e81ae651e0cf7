//! What the diagnosis reports: its public types (`Diagnosis` and its parts), a term's parameters
//! in the fitted model, the findings reported but not modelled (a clipped plateau, handling
//! spikes), the units' errors and the improved model's first-order part.

use super::*;

#[derive(Debug, Clone, Serialize)]
pub struct Window {
    pub recording: String,
    pub start_s: f64,
    pub end_s: f64,
    /// What the window was flagged for and its value (residual RMS / noise, lag-1 autocorrelation).
    pub statistic: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct Term {
    pub name: String,
    pub params: serde_json::Value,
}

#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    pub effect: &'static str,
    pub confidence: &'static str,
    pub explanation: String,
    pub windows: Vec<Window>,
    pub term: Term,
    pub heldout_rmse_before: f64,
    pub heldout_rmse_after: f64,
    pub delta_bic: f64,
    /// Other effects whose terms, in this one's place, explain the same residual about as well on
    /// this data (the drop-one test of `alternatives`); empty when the name stands alone.
    pub alternatives: Vec<Alternative>,
    /// With alternatives: the sentence that says the recording cannot tell them apart.
    pub ambiguity: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Baseline {
    pub model: String,
    pub rmse: f64,
    pub heldout_rmse: f64,
    pub bic: f64,
    /// The load's ramp the first-order steps are driven by (an actuator's recordings: chosen
    /// once per data set by the baseline's held-out RMSE); absent when the load changes at once.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load_ramp: Option<crate::sensor::preprocess::Ramp>,
    /// The window around every step's onset that a hand's touch takes (measured on the
    /// baseline's residuals; its samples neither fitted nor scored); absent when there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub touch_window: Option<TouchWindow>,
}

/// The window around every step's onset that a hand's touch takes (`touch::window`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TouchWindow {
    pub before_onset_s: f64,
    pub after_onset_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Unexplained {
    pub flag: bool,
    pub evidence: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Final {
    pub effects: Vec<&'static str>,
    pub rmse: f64,
    pub heldout_rmse: f64,
    /// Held-out units (a trial's hold, or one step of a single recording) the improved model
    /// predicts better than the baseline, of those scored by both.
    pub units_better: usize,
    pub units_scored: usize,
    /// The held-out RMSE of every unit, baseline and improved.
    pub heldout_by_unit: Vec<UnitError>,
    /// The improved model's first-order part (what a twin is calibrated from): the level at every
    /// load (the trials' mean offset plus the shared level), and every step's refitted time
    /// constant with the load it goes to. Empty with a simulator baseline.
    pub levels: Vec<[f64; 2]>,
    pub taus: Vec<[f64; 2]>,
}

/// One held-out unit's error: the hold from `start_s` (the step's onset; the trial's start for
/// the rest before its first step) of one recording.
#[derive(Debug, Clone, Serialize)]
pub struct UnitError {
    pub recording: String,
    pub start_s: f64,
    pub baseline_rmse: f64,
    pub improved_rmse: f64,
}

/// The units both scores hold, each with its start and both errors.
pub(super) fn unit_errors(trials: &[Trial], base: &Score, cur: &Score) -> Vec<UnitError> {
    let rmse = |s: &Score, k: &(usize, usize)| s.unit_keys.iter().position(|x| x == k).map(|i| (s.units[i] / s.unit_n.get(i).copied().unwrap_or(1).max(1) as f64).sqrt());
    cur.unit_keys
        .iter()
        .filter_map(|k| {
            let tr = trials.get(k.0)?;
            // multi-trial units count segments from 1 at the first onset; a single recording's
            // units are its steps from 0
            let seg = if trials.len() >= 2 {
                k.1.checked_sub(1)
            } else if cur.blocks > 0 {
                k.1.checked_sub(1).map(|x| x / cur.blocks)
            } else {
                Some(k.1)
            };
            let start_s = seg.and_then(|s| tr.segs.get(s)).map(|s| s.t0).unwrap_or(tr.t.first().copied().unwrap_or(0.0));
            Some(UnitError { recording: tr.name.clone(), start_s, baseline_rmse: rmse(base, k)?, improved_rmse: rmse(cur, k)? })
        })
        .collect()
}

#[derive(Debug, Clone, Serialize)]
pub struct Decision {
    pub step: usize,
    /// Where it was decided: `forward` (a round of forward selection), `backward` (the backward
    /// check dropping a kept term), `renamed` (honest naming: a better explanation, a merge or a
    /// settled name in a named term's place), `spectrum` (the relaxation spectrum in place of the
    /// exact forms) or `through` (the conductance's creep through the read-out).
    pub stage: &'static str,
    pub candidate: &'static str,
    pub heldout_rmse: f64,
    pub gain: f64,
    /// Paired z of the held-out improvement over units.
    pub z: f64,
    pub delta_bic: f64,
    pub accepted: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    pub schema: &'static str,
    pub recordings: Vec<String>,
    pub unit: String,
    pub baseline: Baseline,
    pub findings: Vec<Finding>,
    pub unexplained: Unexplained,
    #[serde(rename = "final")]
    pub final_: Final,
    /// Every selection decision with its numbers (the rule: lower held-out error by more than MIN_TERM_GAIN at a paired z ≥ MIN_Z and ΔBIC ≤ MIN_DBIC; of those passing in a round, the one with the lowest held-out RMSE is taken), in step order.
    pub decisions: Vec<Decision>,
    /// Where the baseline fails, before any term is chosen: each catalogue signature's windows and
    /// the whiteness test's, each with its statistic.
    pub located: Vec<LocatedWindow>,
    /// What the baseline's own fits say about themselves: steps whose fitted τ describes creep
    /// (of the order of the hold, or slower than the jump it follows).
    pub notes: Vec<String>,
    /// Nuisances of the set-up the improved model carries (per-trial gains), with their evidence.
    pub nuisances: Vec<NuisanceTerm>,
    #[serde(skip)]
    pub predictions: Vec<Prediction>,
    /// For each finding whose name does not stand alone: the recording that would separate the
    /// names, with both predicted (issue 16, item 2; set by `cli::diagnose` through `advice`).
    pub advice: Vec<Advice>,
    /// Why an ambiguous finding got no advice.
    pub advice_notes: Vec<String>,
}

/// A window where the baseline fails, with the test that flagged it.
#[derive(Debug, Clone, Serialize)]
pub struct LocatedWindow {
    /// The test: an effect's signature ("creep", …) or "whiteness".
    pub test: &'static str,
    pub recording: String,
    pub start_s: f64,
    pub end_s: f64,
    pub statistic: String,
}

/// The most rows a prediction file holds: a longer recording's predictions are given at every
/// stride-th sample.
pub const MAX_PREDICTION_ROWS: usize = 1_000_000;

/// Per recording, per sample (every `stride`-th): measured, baseline and improved predictions.
#[derive(Debug, Clone)]
pub struct Prediction {
    pub stem: String,
    pub time_s: Vec<f64>,
    pub measured: Vec<f64>,
    pub baseline: Vec<f64>,
    pub improved: Vec<f64>,
    pub windows: Vec<(f64, f64)>,
    /// Samples of the (working-rate) recording per row.
    pub stride: usize,
    /// Each modelled term's contribution to the improved prediction at these samples (the
    /// prediction minus the same model with that term's coefficients at zero), with its name.
    pub contributions: Vec<(&'static str, Vec<f64>)>,
}

/// The findings that are reported, not modelled: a clipped plateau the free levels absorbed (the
/// plateau is its own evidence: samples piled at one value with no noise on them), and handling
/// spikes (excluded from every fit; their held-out numbers are the baseline's on the data as given
/// and without them).
pub(super) fn reported_only(trials: &[Trial], cur: &Config, cur_score: &Score, clip: Option<f64>, report: &Report, (base, clean): (&Score, &Score)) -> Vec<Finding> {
    let mut out = Vec::new();
    // saturation the free levels absorbed: the clipped plateau is its own evidence (samples piled
    // at one value with no noise on them)
    if let (Some(level), false) = (clip, cur.effects.contains(&Effect::Saturation)) {
        let windows = signature(Effect::Saturation, &[], trials, clip, report);
        if !windows.is_empty() {
            out.push(Finding {
                effect: Effect::Saturation.name(),
                confidence: "medium",
                explanation: format!(
                    "{}; the per-load levels absorb the clip, so held-out prediction cannot improve: the evidence is the plateau itself",
                    Effect::Saturation.explanation()
                ),
                windows,
                term: Term { name: "saturation_term".into(), params: serde_json::json!({"level": level}) },
                heldout_rmse_before: cur_score.heldout_rmse,
                heldout_rmse_after: cur_score.heldout_rmse,
                delta_bic: 0.0,
                alternatives: vec![],
                ambiguity: None,
            });
        }
    }
    // handling spikes: reported and excluded, never modelled
    let spikes = signature(Effect::HandlingSpikes, &[], trials, clip, report);
    if !spikes.is_empty() {
        let n_spikes = spikes.len();
        out.push(Finding {
            effect: Effect::HandlingSpikes.name(),
            confidence: if spikes.len() >= 2 { "high" } else { "medium" },
            explanation: Effect::HandlingSpikes.explanation().to_string(),
            windows: spikes,
            term: Term { name: "excluded".into(), params: serde_json::json!({"windows_excluded": n_spikes}) },
            heldout_rmse_before: base.heldout_rmse,
            heldout_rmse_after: clean.heldout_rmse,
            delta_bic: clean.bic - base.bic,
            alternatives: vec![],
            ambiguity: None,
        });
    }
    out
}

// The advice's data (computed by `sensor::advice`, which reads the diagnosis; kept here so the
// diagnosis names no module downstream of it).

/// One protocol change and the separation it gives.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    pub change: &'static str,
    pub duration_s: f64,
    pub separation_sigma: f64,
    /// RMS of the difference between the two predicted signals, in the response unit.
    pub rms_difference: f64,
}

/// The advice for one ambiguous finding.
#[derive(Debug, Clone, Serialize)]
pub struct Advice {
    /// Index of the finding in `findings`.
    pub finding: usize,
    pub effect: &'static str,
    pub alternative: &'static str,
    /// The advised change (one of the candidates).
    pub change: &'static str,
    pub sentence: String,
    /// The advised protocol, relative to the output folder.
    pub protocol_file: String,
    pub plot: String,
    /// The expected paired z between the two names on the advised protocol and on the recording's own.
    pub separation_sigma: f64,
    pub separation_sigma_now: f64,
    /// The paired z by which the named model predicted the recording's held-out units better than
    /// the alternative (what the recording itself showed).
    pub z_observed: f64,
    /// The held-out RMSE each name is expected to reach on the advised recording when the other
    /// is true (√(σ² + mean squared difference)), against σ when it is the true one.
    pub heldout_rmse_if_right: f64,
    pub heldout_rmse_if_wrong: f64,
    pub candidates: Vec<Candidate>,
    #[serde(skip)]
    pub protocol_toml: String,
    /// Time, load (g), the named and the alternative's predictions on the advised protocol.
    #[serde(skip)]
    pub curves: [Vec<f64>; 4],
}

/// Stage 5, model it and report: the findings reported but not modelled, what the model leaves
/// unexplained, the final refit and its predictions (`refit`), the units' errors, the improved
/// model's first-order part, and the spectrum's finding named by its fitted shape.
#[allow(clippy::too_many_arguments)]
pub(super) fn diagnosis(
    recs: &[Recording],
    opts: &Options,
    sim: Option<&SimBaseline>,
    b: Built,
    ch: Selected,
    (clean, located): (&Score, Vec<LocatedWindow>),
    piled: Option<f64>,
    refit_always: bool,
) -> Diagnosis {
    let Built { report, trials, d, hat: hat0, base_cfg, base_eval, base_fit, base, xb, touch, .. } = b;
    let Selected { cfg: cur, score: cur_score, x: cur_x, hat, mut findings, decisions, mut nuisances, exact: spectrum_exact } = ch;
    // a clip reported on its plateau alone is one whose samples pile up (`piled`), never a rail's
    findings.extend(reported_only(&trials, &cur, &cur_score, piled, &report, (&base, clean)));
    let (cur, cur_x, cur_score, dropped, made) = refit::of_their_sign_refitted(&d, &trials, &hat, (cur, cur_x, cur_score), &mut findings);
    let unexplained = unexplained(&d, &trials, &cur_x, &cur, &hat, &report.unit);
    let (cur, cur_x, final_trials, final_base, xb) =
        refit::final_refit(&d, trials, base_eval, &base_fit, (&base_cfg, &hat0, xb), (cur, cur_x, &hat, made), &mut findings, refit_always);
    let predictions = refit::predictions(recs, &d, &final_trials, &final_base, (&base_cfg, &hat0, &xb), (&cur, &hat, &cur_x), &findings);
    let by_unit = unit_errors(&final_base, &base, &cur_score);
    let (levels, taus) = if d.prior { (vec![], vec![]) } else { first_order_part(&d, &cur, &cur_x, &final_trials) };
    // the nuisances' parameters as in the final model
    for n in nuisances.iter_mut().filter(|n| n.name == Effect::RestRelaxation.name()) {
        n.params = term_params(&d, &cur, &cur_x, Effect::RestRelaxation, &hat);
    }
    let final_names = final_names(&cur, &mut findings, spectrum_exact.as_ref());
    let step = |s: &analyze::StepReport| format!("{:?} step {} ({} → {})", s.phase, s.index + 1, s.before, s.after);
    let mut notes: Vec<String> = report.steps.iter().filter_map(|s| s.tau_describes_creep.as_ref().map(|why| format!("{}: {why}", step(s)))).collect();
    notes.extend(report.steps.iter().filter_map(|s| s.bounded.as_ref().map(|b| format!("{}, onset bounded: {}", step(s), b.why))));
    notes.extend(dropped);
    if let Some(w) = touch {
        notes.push(format!(
            "the hand's touch: from {:.1} s before each step's onset to {:.1} s after it the data leave the model by more than {} × the holds' mean square, by {} × next to the onsets (the load placed, pressed, let go); those samples are handling, neither fitted nor scored",
            w.before_onset_s,
            w.after_onset_s,
            touch::EXCESS,
            touch::START_EXCESS
        ));
    }
    Diagnosis {
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
            touch_window: touch,
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
    }
}

/// The final model's effects by name (nuisances left out); the spectrum's finding, and its name
/// there, take the name its fitted shape gives.
fn final_names(cur: &Config, findings: &mut [Finding], spectrum_exact: Option<&Exact>) -> Vec<&'static str> {
    let mut names: Vec<&'static str> = cur.effects.iter().filter(|e| **e != Effect::RestRelaxation).map(|e| e.name()).collect();
    for f in findings.iter_mut().filter(|f| f.effect == Effect::Relaxation.name()) {
        name_spectrum(f, spectrum_exact);
        let own = f.effect;
        f.alternatives.retain(|a| a.effect != own);
        alternatives::apply(f);
        for n in names.iter_mut().filter(|n| **n == Effect::Relaxation.name()) {
            *n = f.effect;
        }
    }
    names
}
