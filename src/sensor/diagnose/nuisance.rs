//! Nuisances: what differs between the trials of one data set and is not physics of the sensor
//! (the guide's "room temperature, the hand, how long the sensor rested"). A nuisance enters the
//! model before any catalogue term, so that no physics term stands in for it, and only when it
//! predicts held-out data better under the same rule as a term. A per-trial term is validated
//! inside its trial (see `trial_gain_halves`): the held-out trial's own value is fitted on half of
//! its steps and scored on the other half.

use super::*;

pub const GAIN_EXPLANATION: &str = "the trials' steps differ in size by a common factor per trial (the sensor's temperature, how it sits, the hand): a nuisance of the set-up, fitted as one gain per trial and validated inside each trial, not physics of the sensor";

/// A nuisance the model carries, with the held-out evidence for it.
#[derive(Debug, Clone, Serialize)]
pub struct NuisanceTerm {
    pub name: &'static str,
    pub explanation: &'static str,
    pub params: serde_json::Value,
    pub heldout_rmse_before: f64,
    pub heldout_rmse_after: f64,
    pub z: f64,
    pub delta_bic: f64,
}

/// Per-trial gains, when they pass the rule every term passes (lower held-out error, paired z ≥
/// MIN_Z, ΔBIC ≤ MIN_DBIC) against the model without them.
pub(super) fn try_gains(d: &Design, trials: &[Trial], cur: &Config, cur_score: &Score, hat: &Hat) -> Option<(Config, Score, Vec<f64>, NuisanceTerm)> {
    if d.prior || trials.len() < 2 || cur.gains {
        return None;
    }
    let mut c = cur.clone();
    c.gains = true;
    let (s, x) = score(d, trials, &c, hat)?;
    let z = paired_z(&cur_score.units, &s.units);
    let dbic = s.bic - cur_score.bic;
    if !(s.heldout_rmse < cur_score.heldout_rmse && z >= MIN_Z && dbic <= MIN_DBIC) {
        return None;
    }
    let g0 = d.gain_col(&c);
    // the gain at the top level: the change of level and of its square, both at the top
    let gains: Vec<f64> = (0..trials.len()).map(|k| 1.0 + x[g0 + GAIN_COLS * k] + x[g0 + GAIN_COLS * k + 1]).collect();
    let nt = NuisanceTerm {
        name: "trial_gain",
        explanation: GAIN_EXPLANATION,
        params: serde_json::json!({
            "gain_at_top_level_by_trial": gains,
            "recordings": trials.iter().map(|t| t.name.clone()).collect::<Vec<_>>(),
        }),
        heldout_rmse_before: cur_score.heldout_rmse,
        heldout_rmse_after: s.heldout_rmse,
        z,
        delta_bic: dbic,
    };
    Some((c, s, x, nt))
}

/// The rest relaxation's time constant is at most this share of the shortest trial.
pub const REST_MAX_SHARE: f64 = 1.0 / 3.0;

/// The rest relaxation's time constants tried (s), up to [`REST_MAX_SHARE`] of the shortest trial.
pub const REST_TAUS_S: [f64; 9] = [10.0, 20.0, 35.0, 60.0, 100.0, 170.0, 300.0, 500.0, 1000.0];

/// The rest relaxation's candidates: one per time constant up to a third of the shortest trial
/// (with two trials or more; it competes with the physics terms in the forward selection).
pub(super) fn rest_candidates(d: &Design, trials: &[Trial], cur: &Config) -> Vec<Config> {
    if cur.rest_tau.is_some() {
        return vec![];
    }
    REST_TAUS_S
        .into_iter()
        .filter(|&t| rest_allowed(d, trials, t))
        .map(|tau| {
            let mut c = cur.clone();
            c.effects.push(Effect::RestRelaxation);
            c.rest_tau = Some(tau);
            c
        })
        .collect()
}

/// Whether a rest relaxation with time constant `tau` may be fitted: two trials or more (it is fitted
/// per trial), no simulator baseline, and a relaxation that fades within the trial: τ at most
/// REST_MAX_SHARE of the shortest one (a longer one is a trend per trial, which would stand in for
/// drift and hysteresis: the later, unloading half raised).
pub(super) fn rest_allowed(d: &Design, trials: &[Trial], tau: f64) -> bool {
    let shortest = trials.iter().map(Trial::span_s).fold(f64::INFINITY, f64::min);
    !d.prior && trials.len() >= 2 && tau <= REST_MAX_SHARE * shortest
}

/// A nuisance the forward selection took, as the diagnosis reports it.
pub(super) fn as_nuisance(e: Effect, params: serde_json::Value, before: &Score, after: &Score, z: f64) -> NuisanceTerm {
    NuisanceTerm {
        name: e.name(),
        explanation: e.explanation(),
        params,
        heldout_rmse_before: before.heldout_rmse,
        heldout_rmse_after: after.heldout_rmse,
        z,
        delta_bic: after.bic - before.bic,
    }
}

/// Whether a per-trial rest relaxation (config `c`, scored `s`) predicts the held-out data better
/// than the same decay shared by the trials (one amplitude: the drift's warm-up with the rest's τ)
/// under the rule a nuisance passes (paired z ≥ MIN_Z, gain ≥ MIN_ROBUST_GAIN). Trials that agree
/// have no nuisance to report; a model with a drift already has its shared form.
pub(super) fn beats_its_shared_form(d: &Design, trials: &[Trial], c: &Config, s: &Score, hat: &Hat) -> bool {
    let Some(tau) = c.rest_tau else { return true };
    if c.effects.contains(&Effect::BaselineDrift) {
        return true;
    }
    let mut shared = c.clone();
    shared.effects.retain(|e| *e != Effect::RestRelaxation);
    shared.rest_tau = None;
    shared.effects.push(Effect::BaselineDrift);
    shared.drift_tau = Some(tau);
    let Some((sh, _)) = score(d, trials, &shared, hat) else { return true };
    let gain = (sh.heldout_rmse - s.heldout_rmse) / sh.heldout_rmse.max(1e-300);
    gain >= MIN_ROBUST_GAIN && paired_z(&sh.units, &s.units) >= MIN_Z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Trials whose gains differ by ±5 % get a gain per trial, validated inside each held-out
    /// trial; trials of one gain do not.
    #[test]
    fn per_trial_gains_enter_only_when_the_trials_differ() {
        for (jitter, want) in [(0.05, true), (0.0, false)] {
            let b = fixture::built(&fixture::recs(73_000, |s| s.nuisance.gain_jitter = jitter));
            let (s, _) = score(&b.d, &b.trials, &b.base_cfg, &b.hat).unwrap();
            let got = try_gains(&b.d, &b.trials, &b.base_cfg, &s, &b.hat);
            assert_eq!(got.is_some(), want, "jitter {jitter}");
            if let Some((c, s2, _, nt)) = got {
                assert!(c.gains && nt.name == "trial_gain" && s2.heldout_rmse < s.heldout_rmse);
            }
        }
    }
}
