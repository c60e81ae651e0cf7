//! The conductance's creep through the read-out in place of the slow terms (stage 4, once the
//! catalogue's forward and backward steps and honest naming stand): every change's own
//! log-time creep of the sensor's conductance, superposed over the load history and seen through the
//! read-out (`TrialSteps::creep_through_column`, taken exactly at its fitted size by
//! `terms::through_exactly`).
//!
//! It is not offered in the forward step: there, one such term took the place of a hysteresis and
//! a second time constant together (family A's hysteresis + second τ pair: named 1.00 → 0.00). Here,
//! once the catalogue's names stand (after honest naming), it stands in for the slow terms named
//! (creep, a second time constant, a drift; any subset of them, or none) when it predicts the
//! held-out data better than the whole model by a paired z of MIN_Z and, as the relaxation spectrum
//! must, by more than SPECTRUM_MARGIN: a replacement chosen after the fact among up to eight subsets.
//! With MIN_ROBUST_GAIN (3 %) instead, on family A's tuning seeds it took a null's place under the
//! trial nuisances (4.7 %, z 4.1, beside a rest relaxation) and a true second time constant's under
//! an actuator's ramps (6.1 %, z 3.1), before honest naming also a drift's that naming would have
//! given to the second time constant.

use super::*;

/// The slow terms the conductance's creep may stand in for.
const SLOW: [Effect; 3] = [Effect::Creep, Effect::SecondTimeConstant, Effect::BaselineDrift];

/// The best model with the conductance's creep in place of a subset of the slow terms in `cur`
/// (scored, solved, and the effects it replaced), when every trial's read-out is known.
fn best_in_place(d: &Design, trials: &[Trial], hat: &Hat, cur: &Config) -> Option<(Config, Score, Vec<f64>, Vec<Effect>)> {
    if d.prior || !through_known(trials) {
        return None;
    }
    let present: Vec<Effect> = SLOW.into_iter().filter(|e| cur.effects.contains(e)).collect();
    let mut best: Option<(Config, Score, Vec<f64>, Vec<Effect>)> = None;
    for mask in 0..1usize << present.len() {
        let gone: Vec<Effect> = (0..present.len()).filter(|&b| mask >> b & 1 == 1).map(|b| present[b]).collect();
        // creep is one term: a creep kept leaves no place for this one
        if present.contains(&Effect::Creep) && !gone.contains(&Effect::Creep) {
            continue;
        }
        let mut base = cur.clone();
        for e in &gone {
            if let Some(idx) = base.effects.iter().position(|x| x == e) {
                base = without(&base, idx);
            }
        }
        let mut c = base;
        c.effects.push(Effect::Creep);
        c.creep = CreepForm::Through { at: None };
        let Some((b, _)) = train_bic(d, trials, &c, hat) else { continue };
        let (c, _) = through_exactly(d, trials, hat, (c, b));
        let Some((s, x)) = score(d, trials, &c, hat) else { continue };
        if of_its_sign(d, &c, &x, Effect::Creep) && best.as_ref().is_none_or(|b| s.heldout_rmse < b.1.heldout_rmse) {
            best = Some((c, s, x, gone));
        }
    }
    best
}

/// The conductance's creep takes the place of the slow terms it predicts the held-out data clearly
/// better than (their findings removed, a creep finding added; its decision recorded when tried).
/// True when it took their place.
#[allow(clippy::too_many_arguments)]
pub(super) fn replace_slow(
    d: &Design,
    trials: &[Trial],
    hat: &mut Hat,
    (cur, cur_score, cur_x): (&mut Config, &mut Score, &mut Vec<f64>),
    findings: &mut Vec<Finding>,
    decisions: &mut Vec<Decision>,
    clip: Option<f64>,
    report: &Report,
) -> bool {
    let Some((c, s, x, gone)) = best_in_place(d, trials, hat, cur) else { return false };
    let gain = s.gain_over(cur_score);
    let z = z_over(cur_score, &s);
    let accepted = gain > least_gain(&c) && z >= MIN_Z;
    let step = decisions.last().map(|x| x.step + 1).unwrap_or(0);
    decisions.push(Decision { step, stage: "through", candidate: Effect::Creep.name(), heldout_rmse: s.heldout_rmse, gain, z, delta_bic: s.bic - cur_score.bic, accepted });
    if !accepted {
        return false;
    }
    // the held-out error before it: the first replaced finding's, else the model's
    let before = findings.iter().filter(|f| gone.iter().any(|e| e.name() == f.effect)).map(|f| f.heldout_rmse_before).fold(cur_score.heldout_rmse, f64::max);
    let dbic = s.bic - cur_score.bic;
    findings.retain(|f| gone.iter().all(|e| e.name() != f.effect));
    findings.push(Finding {
        effect: Effect::Creep.name(),
        confidence: confidence(dbic, (before - s.heldout_rmse) / before.max(1e-300)),
        explanation: catalogue::creep::THROUGH_EXPLANATION.to_string(),
        windows: entry_windows(Effect::Creep, d, trials, cur_x, cur, hat, clip, report),
        term: Term { name: "creep_term".into(), params: term_params(d, &c, &x, Effect::Creep, hat) },
        heldout_rmse_before: before,
        heldout_rmse_after: s.heldout_rmse,
        delta_bic: dbic,
        alternatives: vec![],
        ambiguity: None,
    });
    *cur = c;
    *cur_score = s;
    *cur_x = x;
    // its u is built on the levels (two-stage): take them from the model with it (the baseline's
    // have absorbed part of the creep), and take it exactly again
    for _ in 0..2 {
        let next = d.levels_in(cur_x);
        let Some((b, _)) = train_bic(d, trials, cur, &next) else { break };
        let (c, _) = through_exactly(d, trials, &next, (cur.clone(), b));
        let Some((s, x)) = score(d, trials, &c, &next) else { break };
        (*hat, *cur, *cur_score, *cur_x) = (next, c, s, x);
    }
    if let Some(f) = findings.last_mut() {
        f.heldout_rmse_after = cur_score.heldout_rmse;
        f.term.params = term_params(d, cur, cur_x, Effect::Creep, hat);
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On family A's sensor whose conductance creeps (1.2 % of each change per decade, superposed,
    /// through the divider), the conductance's creep takes the slow terms' place and carries the
    /// fitted fraction within 10 %; on family A's own creep of the response (restarting at every
    /// step) and on a hysteresis with a second time constant, the catalogue's model stands; without
    /// the read-out, nothing is tried.
    #[test]
    fn the_conductance_creep_replaces_the_slow_terms_only_where_it_is() {
        let through = |s: &mut crate::params::sensor::SensorParams| {
            s.effects.creep_per_decade = 0.012;
            s.effects.creep_superposed = true;
            s.effects.creep_in_conductance = true;
        };
        let restarting = |s: &mut crate::params::sensor::SensorParams| s.effects.creep_per_decade = 0.01;
        let pair = |s: &mut crate::params::sensor::SensorParams| {
            s.effects.hysteresis = 0.0165;
            s.effects.second_fraction = 0.066;
        };
        let cases: [(&dyn Fn(&mut crate::params::sensor::SensorParams), bool); 3] = [(&through, true), (&restarting, false), (&pair, false)];
        for (k, (f, want)) in cases.into_iter().enumerate() {
            let b = fixture::built(&fixture::recs(36_000 + 10 * k as u64, f));
            let steps = ClipSteps::of(&b.trials, None, false);
            let (clean, xc) = score(&b.d, &b.trials, &b.base_cfg, &b.hat).unwrap();
            let sel = select::select(&b.base_cfg, clean, xc, b.hat.clone(), &fixture::ctx(&b, &steps, &b.hat), &b.report);
            let (mut cur, mut s, mut x, mut findings, mut decisions) = (sel.cfg, sel.score, sel.x, sel.findings, sel.decisions);
            let named: Vec<_> = findings.iter().map(|f| f.effect).collect();
            let mut hat = sel.hat.clone();
            replace_slow(&b.d, &b.trials, &mut hat, (&mut cur, &mut s, &mut x), &mut findings, &mut decisions, None, &b.report);
            assert_eq!(cur.creep.through(), want, "case {k}: {named:?} -> {:?}; {:?}", findings.iter().map(|f| f.effect).collect::<Vec<_>>(), decisions.last());
            if want {
                let f = findings.iter().find(|f| f.effect == "creep").unwrap();
                let frac = f.term.params["per_decade_fraction"].as_f64().unwrap();
                assert!((frac / 0.012 - 1.0).abs() < 0.1, "fraction {frac}");
                assert_eq!(f.term.params["in_conductance"].as_bool(), Some(true));
                let mut blind = b.trials.clone();
                blind.iter_mut().for_each(|tr| tr.readout = None);
                assert!(best_in_place(&b.d, &blind, &sel.hat, &cur).is_none());
            }
        }
    }
}
