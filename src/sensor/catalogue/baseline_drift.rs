//! `baseline_drift`: a load-independent offset that changes steadily with time.
//!
//! Signature: the level at zero load over time — the residual mean of each trial's last zero-load
//! hold against its first, in standard errors.
//! Term: a linear trend in time from the trial's start.
//! Physics: thermal or electronic drift.

use super::{mean_se, sig3, Hold, Located, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "a load-independent offset changes steadily with time (thermal or electronic drift), modelled as a linear trend";

/// The term's column at time t of a trial that starts at `t_start`.
pub fn column(t: f64, t_start: f64) -> f64 {
    t - t_start
}

/// Per trial: the zero-load holds (the lowest load) when the last one's residual has moved from
/// the first one's. The first hold of a trial is the stretch before its first step (`load` = the
/// lowest load, `t0_s` = the trial's start).
pub fn signature(holds: &[Hold]) -> Vec<Located> {
    let mut out = Vec::new();
    let lowest = holds.iter().map(|h| h.load).fold(f64::INFINITY, f64::min);
    let mut trials: Vec<usize> = holds.iter().map(|h| h.trial).collect();
    trials.dedup();
    for k in trials {
        let zero: Vec<&Hold> = holds.iter().filter(|h| h.trial == k && h.load == lowest).collect();
        let (Some(first), Some(last)) = (zero.first(), zero.last()) else { continue };
        if zero.len() < 2 {
            continue;
        }
        let settled = |h: &Hold| -> Vec<f64> { (0..h.t.len()).filter(|&j| h.t[j] >= h.t0_s + 3.0 * h.tau_s && h.t[j] < h.end_s).map(|j| h.r[j]).collect() };
        let (a, b) = (settled(first), settled(last));
        if a.len() < 10 || b.len() < 10 {
            continue;
        }
        let ((ma, sa), (mb, sb)) = (mean_se(&a), mean_se(&b));
        let z = (mb - ma) / (sa * sa + sb * sb).sqrt().max(1e-300);
        if z.abs() >= MIN_SIGNATURE_Z {
            let dt = 0.5 * (last.t0_s + last.end_s) - 0.5 * (first.t0_s + first.end_s);
            let stat = format!("level at zero load moved by {} over {:.0} s (z = {:.1})", sig3(mb - ma), dt, z);
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
        let run = |last: &[f64]| {
            let first = Hold { recording: "a", t: &t1, r: &a, sigma: 0.003, t0_s: 0.0, end_s: 10.0, tau_s: 0.3, load: 0.0, prev: 0.0, trial: 0 };
            let end = Hold { recording: "a", t: &t2, r: last, sigma: 0.003, t0_s: 200.0, end_s: 210.0, tau_s: 0.3, load: 0.0, prev: 1.0, trial: 0 };
            signature(&[first, end]).len()
        };
        assert_eq!(run(&moved), 2);
        assert_eq!(run(&b), 0);
        assert_eq!(column(15.0, 5.0), 10.0);
    }
}
