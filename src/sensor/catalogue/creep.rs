//! `creep`: slow change that continues under constant load after the first-order part settles.
//!
//! Signature: a trend of the residual against log time within holds, after three time constants.
//! Term: log-time growth under the current load, proportional to the load's level above zero load
//! (log10(1 + t/1 s)); what earlier loads built up relaxes away with the new step's time constant.
//! Physics: viscoelastic flow of the rubber.

use super::{mean_se, sig3, Hold, Located, Steps, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "the response keeps changing slowly under a constant load after the first-order part has settled: the rubber creeps (viscoelastic flow), modelled as a log-time term proportional to the load's level";

pub const SUPERPOSED_EXPLANATION: &str = "the response keeps changing slowly after every change of load, and the change carries over to the next steps: the rubber creeps (viscoelastic flow), modelled as every change's own log-time creep superposed over the load history (it predicts the held-out data better than the other names in this place)";

pub const THROUGH_EXPLANATION: &str = "the sensor's conductance keeps changing slowly after every change of load, and the change carries over to the next steps: the rubber creeps (viscoelastic flow), modelled as every change's own log-time creep of the conductance superposed over the load history, seen through the read-out (a divider shows it compressed at its top and in full at its bottom; it predicts the held-out data better than the other names in this place)";

/// The log-time clock's unit (s).
pub const TIME_S: f64 = 1.0;

/// The term's column at time t, with step `cur` the latest that has begun.
pub fn column(s: &impl Steps, cur: usize, t: f64) -> f64 {
    let mut carry = 0.0;
    for q in 0..=cur {
        let end = if q == cur { t } else { s.t0(q + 1) };
        let since = super::since(end, s.t0(q));
        carry = carry * super::decay(since / s.tau(q)) + s.level(q) * (1.0 + since / TIME_S).log10();
    }
    carry
}

/// The term's column superposed over the load history (Boltzmann): every change since the first,
/// up to step `cur`, adds its own log-time creep in proportion to its change of level, and keeps it
/// going after later changes — a creep that carries over from step to step.
pub fn superposed_column(s: &impl Steps, cur: usize, t: f64) -> f64 {
    (0..=cur).map(|q| s.dv(q) * (1.0 + super::since(t, s.t0(q)) / TIME_S).log10()).sum()
}

/// Holds whose residual trends against log time after 3τ.
pub fn signature(holds: &[Hold]) -> Vec<Located> {
    let mut out = Vec::new();
    for h in holds {
        let idx: Vec<usize> = (0..h.t.len()).filter(|&j| h.t[j] >= h.t0_s + 3.0 * h.tau_s && h.t[j] < h.end_s).collect();
        if idx.len() < 20 {
            continue;
        }
        let x: Vec<f64> = idx.iter().map(|&j| (1.0 + (h.t[j] - h.t0_s) / TIME_S).log10()).collect();
        let y: Vec<f64> = idx.iter().map(|&j| h.r[j]).collect();
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
        if sxx <= 0.0 {
            continue;
        }
        let b = x.iter().zip(&y).map(|(a, c)| (a - mx) * (c - my)).sum::<f64>() / sxx;
        // standard error from the detrended residual, corrected for autocorrelation
        let rest: Vec<f64> = x.iter().zip(&y).map(|(a, c)| c - my - b * (a - mx)).collect();
        let (_, se_mean) = mean_se(&rest);
        let se_b = se_mean * (n / sxx).sqrt();
        let z = b / se_b.max(1e-300);
        if z.abs() >= MIN_SIGNATURE_Z {
            out.push(Located {
                recording: h.recording.to_string(),
                start_s: h.t[idx[0]],
                end_s: h.end_s,
                statistic: format!("trend within the hold: {} per decade of time after 3τ (t = {:.1})", sig3(b), z),
                z: z.abs(),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_per_decade_under_load_and_relaxes_after_removal() {
        let steps = super::super::UpDown { t0: [10.0, 30.0], top: 1.0, after: 0.0, tau_s: [1.0; 2] };
        assert!((column(&steps, 0, 19.0) - 1.0).abs() < 1e-12); // log10(1 + 9) = 1
        let after = column(&steps, 1, 40.0);
        assert!(after.abs() < 1e-3 && after > 0.0, "{after}");
    }

    /// Superposed, each change's creep keeps going: after the load is removed the loading's creep
    /// still grows and the unloading's (of the opposite sign, from its own start) takes it back
    /// slowly — the carry-over the restarting form relaxes away within the new step's τ.
    #[test]
    fn superposed_creep_carries_over_after_the_load_is_removed() {
        let steps = super::super::UpDown { t0: [10.0, 30.0], top: 1.0, after: 0.0, tau_s: [1.0; 2] };
        assert!((superposed_column(&steps, 0, 19.0) - 1.0).abs() < 1e-12);
        let after = superposed_column(&steps, 1, 40.0);
        let want = (1.0f64 + 30.0).log10() - (1.0f64 + 10.0).log10();
        assert!((after - want).abs() < 1e-12 && after > 0.4, "{after}");
        assert!(column(&steps, 1, 40.0) < 1e-3);
    }

    #[test]
    fn signature_flags_a_log_trend_and_not_noise() {
        let t: Vec<f64> = (0..2000).map(|i| 10.0 + i as f64 * 0.01).collect();
        let noise = super::super::test_noise(2000, 0.003, 3);
        let trend: Vec<f64> = t.iter().zip(&noise).map(|(x, e)| e + 0.01 * (1.0 + (x - 10.0)).log10()).collect();
        let flags = |r: &[f64]| signature(&[super::super::test_hold(&t, r, 10.0, 30.0, 1.0, 0.0)]).len();
        assert_eq!(flags(&trend), 1);
        assert_eq!(flags(&noise), 0);
    }
}
