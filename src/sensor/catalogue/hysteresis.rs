//! `hysteresis`: at the same load the unloading branch stays away from the loading branch.
//!
//! Signature: the offset between the residual means of the unloading and loading holds at equal
//! load (later half of each hold), in standard errors.
//! Term: once the highest load has been reached (every unloading step, and the loading steps of a
//! later cycle), an offset proportional to the gap between the highest load's level and this
//! load's level, reached with the step's own time constant: the memory of the peak persists.
//! Physics: the contact area remembers the highest load.

use super::{offset_z, sig3, Hold, Located, Steps, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "at the same load the unloading branch stays away from the loading branch: the contact area remembers the highest load, modelled as an offset proportional to the gap to the maximum-load level";

/// The term's column at time t, with step `cur` the latest that has begun.
pub fn column(s: &impl Steps, cur: usize, t: f64) -> f64 {
    let h = |q: usize| if s.after_peak(q) { s.below_top(q) } else { 0.0 };
    let prev = if cur > 0 { h(cur - 1) } else { 0.0 };
    h(cur) + (prev - h(cur)) * super::decay((t - s.t0(cur)) / s.tau(cur))
}

/// The later half of a hold (and after 3τ).
fn late_half(h: &Hold) -> Vec<f64> {
    h.residuals_from((0.5 * (h.t0_s + h.end_s)).max(h.t0_s + 3.0 * h.tau_s))
}

/// Unloading holds whose residual sits off the loading hold's at the same load (same trial).
pub fn signature(holds: &[Hold]) -> Vec<Located> {
    let mut out = Vec::new();
    for u in holds.iter().filter(|h| h.load < h.prev) {
        let Some(l) = holds.iter().find(|h| h.trial == u.trial && h.load > h.prev && h.load == u.load) else { continue };
        let Some((d, z)) = offset_z(&late_half(u), &late_half(l)) else { continue };
        if z.abs() >= MIN_SIGNATURE_Z {
            out.push(Located {
                recording: u.recording.to_string(),
                start_s: u.t0_s,
                end_s: u.end_s,
                statistic: format!("unloading branch off the loading branch at load {}: {} (z = {:.1})", u.load, sig3(d), z),
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
    fn column_holds_the_gap_to_the_top_after_unloading() {
        let steps = super::super::UpDown { t0: [0.0, 10.0], top: 2.0, after: 1.0 };
        assert_eq!(column(&steps, 0, 5.0), 0.0);
        assert!((column(&steps, 1, 30.0) - 1.0).abs() < 1e-6);
        assert!(column(&steps, 1, 10.5) < 0.5);
    }

    /// A second cycle: up to the top, down to zero, up to half the top again. The peak's memory
    /// holds on the second cycle's loading step (the gap to the top), where an unloading-only term
    /// would drop it to nothing.
    #[test]
    fn the_peak_memory_holds_on_a_later_cycle_s_loading() {
        struct Cycles;
        impl Steps for Cycles {
            fn t0(&self, q: usize) -> f64 {
                [0.0, 10.0, 20.0][q]
            }
            fn tau(&self, _: usize) -> f64 {
                1.0
            }
            fn dv(&self, q: usize) -> f64 {
                [2.0, -2.0, 1.0][q]
            }
            fn level(&self, q: usize) -> f64 {
                [2.0, 0.0, 1.0][q]
            }
            fn below_top(&self, q: usize) -> f64 {
                [0.0, 2.0, 1.0][q]
            }
            fn unloading(&self, q: usize) -> bool {
                q == 1
            }
            fn after_peak(&self, q: usize) -> bool {
                q >= 1
            }
        }
        // after the removal: the whole gap to the top; on the later loading: its own gap
        assert!((column(&Cycles, 1, 19.9) - 2.0).abs() < 1e-3);
        assert!((column(&Cycles, 2, 40.0) - 1.0).abs() < 1e-6);
        // the trait's default (before the top is reached twice) is the unloading steps alone
        let once = super::super::UpDown { t0: [0.0, 10.0], top: 2.0, after: 1.0 };
        assert!(once.after_peak(1) && !once.after_peak(0));
    }

    #[test]
    fn signature_flags_an_offset_branch_only() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 0.01).collect();
        let a = super::super::test_noise(2000, 0.003, 5);
        let b = super::super::test_noise(2000, 0.003, 6);
        let off: Vec<f64> = b.iter().map(|e| e + 0.003).collect();
        let run = |unl: &[f64]| signature(&[super::super::test_hold(&t, &a, 0.0, 20.0, 1.0, 0.0), super::super::test_hold(&t, unl, 0.0, 20.0, 1.0, 2.0)]).len();
        assert_eq!(run(&off), 1);
        assert_eq!(run(&b), 0);
    }
}
