//! A model's parameters in the sensor's terms, shared by the stages that report them: a term's
//! parameters (its coefficients and shape, its size in the response unit) and the first-order part
//! (a level per load, a time constant per step).

use super::*;

/// A term's parameters in the fitted model (the coefficients of its columns and its shape).
pub(super) fn term_params(d: &Design, c: &Config, x: &[f64], e: Effect, hat: &Hat) -> serde_json::Value {
    let k = term_col(d, c, e);
    // the terms scale with the model's levels: their sizes in the response unit, for the change
    // from zero load to the highest load
    let span = hat.max_level() - hat.level_of(d.loads[0]);
    let at = |i: usize| x.get(i).copied().unwrap_or(f64::NAN);
    match e {
        Effect::Creep if c.creep.through() => {
            // a fraction of each change of the sensor's conductance per decade
            serde_json::json!({"per_decade_fraction": at(k), "time_s": catalogue::creep::TIME_S, "superposed": true, "in_conductance": true})
        }
        Effect::Creep if c.creep.superposed() => {
            serde_json::json!({"per_decade_fraction": at(k), "time_s": catalogue::creep::TIME_S, "per_decade_at_top_load": at(k) * span, "superposed": true})
        }
        Effect::Creep => serde_json::json!({"per_decade_fraction": at(k), "time_s": catalogue::creep::TIME_S, "per_decade_at_top_load": at(k) * span}),
        Effect::Hysteresis if c.hyst_through => {
            // a share of the gap in the sensor's conductance between the remembered peak's load
            // and the present one
            let mut v = serde_json::json!({"conductance_fraction": at(k), "in_conductance": true});
            if let Some(m) = c.hyst_memory_s {
                v["memory_s"] = serde_json::json!(m);
            }
            v
        }
        Effect::Hysteresis => match c.hyst_memory_s {
            Some(m) => serde_json::json!({"fraction": at(k), "offset_at_lowest_load": at(k) * span, "memory_s": m}),
            None => serde_json::json!({"fraction": at(k), "offset_at_lowest_load": at(k) * span}),
        },
        Effect::RestRelaxation => {
            let r0 = d.rest_col(c);
            serde_json::json!({"tau_s": c.rest_tau, "amplitude_at_start_by_trial": (0..d.n_rests(c)).map(|q| at(r0 + q)).collect::<Vec<_>>()})
        }
        Effect::SecondTimeConstant if c.drive == Drive::Size => {
            serde_json::json!({"drive": c.drive.label(), "after_loading_fraction": at(k), "after_unloading_fraction": at(k + 1), "tau2_s": c.tau2, "jump_after_loading_full_change": at(k) * span.abs(), "jump_after_unloading_full_change": at(k + 1) * span.abs()})
        }
        Effect::SecondTimeConstant if c.drive == Drive::Through => serde_json::json!({"drive": c.drive.label(), "fraction": at(k), "tau2_s": c.tau2, "in_conductance": true}),
        Effect::SecondTimeConstant => serde_json::json!({"drive": c.drive.label(), "fraction": at(k), "tau2_s": c.tau2}),
        Effect::BaselineDrift => match c.drift_tau {
            Some(tau) => serde_json::json!({"form": "exponential warm-up", "initial_rate_per_s": at(k), "warmup_tau_s": tau, "amplitude": at(k) * tau}),
            None => serde_json::json!({"rate_per_s": at(k)}),
        },
        Effect::Saturation if c.clip_rail => serde_json::json!({"level": c.clip, "before_noise": true}),
        Effect::Saturation => serde_json::json!({"level": c.clip}),
        Effect::HandlingSpikes => serde_json::json!({}),
        Effect::Relaxation => {
            let Some(rx) = &c.relax else { return serde_json::json!({}) };
            let n = rx.taus.len();
            let amps: Vec<f64> = (0..2 * n).map(|j| at(k + j)).collect();
            let shape = catalogue::relaxation::name(&rx.taus, &amps);
            let (peak_l, share_l) = catalogue::relaxation::peak(&rx.taus, &amps[..n]);
            let (peak_u, share_u) = catalogue::relaxation::peak(&rx.taus, &amps[n..]);
            let mut v = serde_json::json!({
                "shape": match shape { catalogue::relaxation::Shape::Creep => "broad band (creep)", catalogue::relaxation::Shape::SecondTimeConstant => "one narrow peak (second time constant)", catalogue::relaxation::Shape::ChangeDriven => "one sign after loading and unloading (change-driven)" },
                "tau_s": rx.taus,
                "after_loading_per_unit_change": &amps[..n],
                "after_unloading_per_unit_change": &amps[n..],
                "peak_tau_after_loading_s": peak_l, "peak_share_after_loading": share_l,
                "peak_tau_after_unloading_s": peak_u, "peak_share_after_unloading": share_u,
                "penalty": rx.lambda,
                "first_order_share_after_loading": if rx.own_tau { at(k + rx.sets() * n) } else { 0.0 }, "first_order_share_after_unloading": if rx.own_tau { at(k + rx.sets() * n + 1) } else { 0.0 },
            });
            // the spectrum's own ramp, or (an actuator's) the steps' own ramps it is driven by
            if let KernelDrive::Ramp { ramp_s, end_s } = rx.drive {
                v["ramp_s"] = serde_json::json!(ramp_s);
                v["ramp_end_after_logged_change_s"] = serde_json::json!(end_s);
            } else {
                v["driven_by_the_steps_ramps"] = serde_json::json!(true);
            }
            v
        }
    }
}

/// The first-order part of a solved model: (load, level) for every load (the trials' mean offset
/// plus the shared level) and (load, τ) for every step.
pub(super) fn first_order_part(d: &Design, cfg: &Config, x: &[f64], trials: &[Trial]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let n = d.n_trials;
    let offset = x.iter().take(n).sum::<f64>() / n.max(1) as f64;
    let levels = d.loads.iter().enumerate().map(|(j, &l)| [l, offset + if j == 0 { 0.0 } else { x.get(n + j - 1).copied().unwrap_or(f64::NAN) }]).collect();
    // τ as the model has it: a clip's fixed τ, or the step's τ with its shape correction
    // (coefficient −Δ ln τ); a jump (faster than a sample) has no τ to tell
    let taus = trials
        .iter()
        .enumerate()
        .flat_map(|(i, tr)| {
            tr.segs.iter().enumerate().filter(|(_, sg)| !is_jump(tr, sg)).map(move |(s, sg)| {
                let mut tau = cfg.tau_of(i, s, sg);
                if cfg.tau_free && !d.prior && cfg.fixed(i, s).is_none() {
                    tau *= (-x.get(d.n_levels() + sg.key).copied().unwrap_or(0.0)).exp();
                }
                [sg.load, tau]
            })
        })
        .collect();
    (levels, taus)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The improved model's first-order part as reported: a level per load (rising) and a τ per
    /// step near the simulator's; a drift term's parameters in the response unit per second.
    #[test]
    fn the_model_is_reported_in_the_sensors_terms() {
        let rate = 1e-4;
        let (recs, truth) = fixture::recs_and_truth(93_000, |s| s.effects.drift_v_per_s = rate);
        let b = fixture::built(&recs);
        let (levels, taus) = first_order_part(&b.d, &b.base_cfg, &b.xb, &b.trials);
        assert_eq!(levels.len(), 6);
        assert!(levels.windows(2).all(|w| w[1][1] > w[0][1]), "{levels:?}");
        assert_eq!(taus.len(), 30);
        let truth_tau: Vec<f64> = truth.iter().flat_map(|t| t.steps.iter().map(|s| s.tau_s)).collect();
        assert!(taus.iter().zip(&truth_tau).all(|(m, t)| (m[1] / t - 1.0).abs() < 0.35), "{taus:?} vs {truth_tau:?}");
        let steps = ClipSteps::of(&b.trials, None, false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let c = candidate(Effect::BaselineDrift, &b.base_cfg, &ctx).unwrap();
        let (_, x) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
        let p = term_params(&b.d, &c, &x, Effect::BaselineDrift, &b.hat);
        let fitted = p.get("rate_per_s").or(p.get("initial_rate_per_s")).and_then(|v| v.as_f64()).unwrap();
        assert!((fitted / rate - 1.0).abs() < 0.25, "{p}");
    }
}
