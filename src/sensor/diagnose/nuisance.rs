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
    let z = z_over(cur_score, &s);
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
    REST_TAUS_S.into_iter().filter(|&t| rest_allowed(d, trials, t)).map(|tau| with_rest(cur, tau)).collect()
}

/// The model `cur` with a rest relaxation per trial of time constant `tau`.
pub(super) fn with_rest(cur: &Config, tau: f64) -> Config {
    let mut c = cur.clone();
    c.effects.push(Effect::RestRelaxation);
    c.rest_tau = Some(tau);
    c
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
    gain >= MIN_ROBUST_GAIN && z_over(&sh, s) >= MIN_Z
}

/// Student's t that a one-sided test at 1 % needs, for 1 to 9 degrees of freedom (the normal's
/// 2.33 beyond).
const T_ONE_PERCENT: [f64; 9] = [31.82, 6.965, 4.541, 3.747, 3.365, 3.143, 2.998, 2.896, 2.821];

/// Whether a decay from each trial's start with time constant `tau` (a warm-up of the read-out, in
/// the model `wo` without it) is one the trials share, as a random effect's test sees it: fitted per
/// trial (its amplitudes, on every sample, with the trials' offsets and gains), the amplitudes'
/// mean differs from zero by Student's t at 1 % over their spread between the trials. A decay whose
/// size the trials do not agree on (each started from its own rest) has a mean its spread does not
/// separate from nothing: the guide's two hypotheses, a term shared by all trials and one fitted
/// per trial, told apart by the trials themselves. (Held out, the two cannot be set side by side
/// fairly: a per-trial term is validated inside its own trial, which favours it by its own noise;
/// restricted to the samples before the first unloading, it loses by the confound with the gains.)
pub(super) fn shared_by_the_trials(d: &Design, trials: &[Trial], wo: &Config, tau: f64, hat: &Hat) -> bool {
    if d.prior || trials.len() < 2 {
        return true;
    }
    let c = with_rest(wo, tau);
    let Some((_, x)) = train_bic(d, trials, &c, hat) else { return true };
    let amps: Vec<f64> = (0..trials.len()).map(|k| x[d.rest_col(&c) + k]).collect();
    t_over_spread(&amps) >= T_ONE_PERCENT.get(amps.len() - 2).copied().unwrap_or(2.33)
}

/// The one-sample t of `a`: |mean| over its standard error from the spread (infinite when the
/// values agree exactly and are not all zero).
fn t_over_spread(a: &[f64]) -> f64 {
    let n = a.len() as f64;
    let mean = a.iter().sum::<f64>() / n;
    let sd = (a.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    if sd == 0.0 {
        return if mean == 0.0 { 0.0 } else { f64::INFINITY };
    }
    mean.abs() / (sd / n.sqrt())
}

/// The trials' rest states in a shared term's place (model `wo` without it, scored `s_wo`; scored
/// `cur_score` with it): their time constant chosen on the training fit as the forward step chooses it; taken when it
/// explains the residual against `wo` (lower held-out error, paired z ≥ MIN_Z), as every
/// alternative must.
///
/// A drift may still act beside the rest states (a warm-up shared by trials that rested
/// differently): the drift is tried again with them, the two time constants chosen together on the
/// training fit, and when it passes the forward step's rule on the rests alone, both stand (the
/// better explanation is then the drift with the rests beside it).
pub(super) fn in_its_place((wo, s_wo): (&Config, &Score), cur_score: &Score, ctx: &Ctx) -> Option<alternatives::Better> {
    let c = candidate(Effect::RestRelaxation, wo, ctx)?;
    let (s, x) = score(ctx.d, ctx.trials, &c, ctx.hat)?;
    let explains = s.heldout_rmse < s_wo.heldout_rmse && z_over(s_wo, &s) >= MIN_Z;
    if !explains {
        return None;
    }
    let beside = drift_beside_rests(wo, ctx).and_then(|cd| {
        let (sd, xd) = score(ctx.d, ctx.trials, &cd, ctx.hat)?;
        // the forward step's rule: its least gain, z and ΔBIC, and the physics' sign
        let passes = sd.gain_over(&s) > MIN_TERM_GAIN && z_over(&s, &sd) >= MIN_Z && sd.bic - s.bic <= MIN_DBIC && of_its_sign(ctx.d, &cd, &xd, Effect::BaselineDrift);
        passes.then_some((cd, sd, xd))
    });
    Some(match beside {
        Some((cd, sd, xd)) => alternatives::Better { effect: Effect::BaselineDrift, z: -z_over(&sd, cur_score), cfg: cd, score: sd, x: xd },
        None => alternatives::Better { effect: Effect::RestRelaxation, z: -z_over(&s, cur_score), cfg: c, score: s, x },
    })
}

/// A drift and the trials' rest states together on `wo`, the rests' time constant and the drift's
/// form chosen jointly on the training fit (the least BIC).
fn drift_beside_rests(wo: &Config, ctx: &Ctx) -> Option<Config> {
    let mut best: Option<(Config, f64)> = None;
    for r in rest_candidates(ctx.d, ctx.trials, wo) {
        let Some(cd) = candidate(Effect::BaselineDrift, &r, ctx) else { continue };
        let Some((b, _)) = train_bic(ctx.d, ctx.trials, &cd, ctx.hat) else { continue };
        if best.as_ref().is_none_or(|x| b < x.1) {
            best = Some((cd, b));
        }
    }
    best.map(|x| x.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The random effect's test: a decay from each trial's start that the trials share (8 mV each,
    /// τ 60 s) is shared; rests of one sign but of different sizes (4, 8 and 12 mV) are not, though
    /// their mean is far from zero; and none at all is not.
    #[test]
    fn a_decay_is_shared_only_when_the_trials_agree_on_its_size() {
        for (amps, want) in [([0.008; 3], true), ([0.004, 0.008, 0.012], false), ([0.0; 3], false)] {
            let b = fixture::built(&fixture::with_decays(fixture::recs(74_100, |_| {}), amps, 60.0, (0.0, 1.0)));
            assert_eq!(shared_by_the_trials(&b.d, &b.trials, &b.base_cfg, 60.0, &b.hat), want, "{amps:?}");
        }
        assert_eq!(t_over_spread(&[1.0, 1.0]), f64::INFINITY);
        assert!((t_over_spread(&[4.0, 8.0, 12.0]) - 8.0 / (4.0 / 3f64.sqrt())).abs() < 1e-12);
    }

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
