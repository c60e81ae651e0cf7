//! `baseline_drift`: a load-independent offset that changes steadily with time.
//!
//! Signature: the level at zero load over time — the residual mean of each trial's last zero-load
//! hold against its first, in standard errors.
//! Term: a linear trend in time from the trial's start, or an exponential warm-up from it,
//! τ (1 − e^(−t/τ)) (its initial rate is the coefficient; long τ is the line), shared by the trials.
//! Physics: thermal or electronic drift; a warm-up is the read-out settling after power-on.

use super::{offset_z, sig3, Hold, Located, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "a load-independent offset changes steadily with time (thermal or electronic drift), modelled as a linear trend, or as an exponential warm-up from each trial's start, shared by the trials";

/// Warm-up time constants tried (s), chosen on the training fit with the linear form.
pub const WARMUP_TAUS_S: [f64; 6] = [20.0, 40.0, 80.0, 160.0, 320.0, 640.0];

/// The term's column at time t of a trial that starts at `t_start`: linear, or a warm-up with
/// time constant `warmup_tau`.
pub fn column(t: f64, t_start: f64, warmup_tau: Option<f64>) -> f64 {
    let dt = t - t_start;
    match warmup_tau {
        Some(tau) => tau * (1.0 - super::decay(dt / tau)),
        None => dt,
    }
}

/// Per trial: the zero-load holds (the lowest load) when the last one's residual has moved from
/// the first one's. The first hold of a trial is the stretch before its first step (`load` = the
/// lowest load, `t0_s` = the trial's start).
pub fn signature(holds: &[Hold]) -> Vec<Located> {
    let mut out = Vec::new();
    let lowest = holds.iter().map(|h| h.load).fold(f64::INFINITY, f64::min);
    let mut trials: Vec<usize> = holds.iter().map(|h| h.trial).collect();
    trials.sort_unstable();
    trials.dedup();
    for k in trials {
        let zero: Vec<&Hold> = holds.iter().filter(|h| h.trial == k && h.load == lowest).collect();
        let (Some(first), Some(last)) = (zero.first(), zero.last()) else { continue };
        if zero.len() < 2 {
            continue;
        }
        let settled = |h: &Hold| h.residuals_from(h.t0_s + 3.0 * h.tau_s);
        let Some((d, z)) = offset_z(&settled(last), &settled(first)) else { continue };
        if z.abs() >= MIN_SIGNATURE_Z {
            let dt = 0.5 * (last.t0_s + last.end_s) - 0.5 * (first.t0_s + first.end_s);
            let stat = format!("level at zero load moved by {} over {:.0} s (z = {:.1})", sig3(d), dt, z);
            for h in [first, last] {
                out.push(Located { recording: h.recording.to_string(), start_s: h.t0_s, end_s: h.end_s, statistic: stat.clone(), z: z.abs() });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signature_flags_a_moved_zero_level_only() {
        let t1: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        let t2: Vec<f64> = (0..1000).map(|i| 200.0 + i as f64 * 0.01).collect();
        let a = super::super::test_noise(1000, 0.003, 7);
        let b = super::super::test_noise(1000, 0.003, 8);
        let moved: Vec<f64> = b.iter().map(|e| e + 0.004).collect();
        let run = |last: &[f64]| signature(&[super::super::test_hold(&t1, &a, 0.0, 10.0, 0.0, 0.0), super::super::test_hold(&t2, last, 200.0, 210.0, 0.0, 1.0)]).len();
        assert_eq!(run(&moved), 2);
        assert_eq!(run(&b), 0);
        assert_eq!(column(15.0, 5.0, None), 10.0);
        // a warm-up starts at the line's slope and levels off at τ
        assert!((column(5.001, 5.0, Some(40.0)) - 0.001).abs() < 1e-7 && (column(1e4, 0.0, Some(40.0)) - 40.0).abs() < 1e-9);
    }
}
