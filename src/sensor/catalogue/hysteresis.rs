//! `hysteresis`: at the same load the unloading branch stays away from the loading branch.
//!
//! Signature: the offset between the residual means of the unloading and loading holds at equal
//! load (later half of each hold), in standard errors.
//! Term: once the highest load has been reached (every unloading step, and the loading steps of a
//! later cycle), an offset proportional to the gap between the highest load's level and this
//! load's level, reached with the step's own time constant: the memory of the peak persists; or,
//! once the names stand, a memory that fades toward the present load (`fading_column`).
//! Physics: the contact area remembers the highest load.

use super::{offset_z, sig3, Hold, Located, Steps, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "at the same load the unloading branch stays away from the loading branch: the contact area remembers the highest load, modelled as an offset proportional to the gap to the maximum-load level";

/// The explanation of the hysteresis of the sensor's conductance seen through the read-out.
pub const THROUGH_EXPLANATION: &str = "at the same load the unloading branch stays away from the loading branch: the contact area remembers the highest load, modelled as a share of the gap in the sensor's conductance between the remembered load and the present one, seen through the read-out (a divider shows it in full near no load and compressed at its top)";

/// The term's column at time t, with step `cur` the latest that has begun.
pub fn column(s: &impl Steps, cur: usize, t: f64) -> f64 {
    let h = |q: usize| if s.after_peak(q) { s.below_top(q) } else { 0.0 };
    let prev = if cur > 0 { h(cur - 1) } else { 0.0 };
    h(cur) + (prev - h(cur)) * super::decay(super::since(t, s.t0(cur)) / s.tau(cur))
}

/// The fading memories (s) the final model's hysteresis is tried with, beside the permanent one: a log
/// grid over the minutes a contact's memory of its peak can last.
pub const MEMORY_S: [f64; 7] = [15.0, 30.0, 60.0, 120.0, 240.0, 480.0, 960.0];

/// The term's column when the peak's memory fades with the time `memory_s`: the remembered load
/// follows the load up at once and, below it, fades toward the present load,
/// dP/dt = −(P − F)/T; the column is the gap in level between the remembered load and the present
/// one (`level_at`, the level at any load, relative as `Steps::level`), each step's reached with
/// its own time constant from the gap before it. `load(q)` is step q's load, `start` the load
/// before the first step. Without fading (T → ∞) and on a staircase up and down, it is
/// [`column`].
pub fn fading_column(s: &impl Steps, (cur, t): (usize, f64), memory_s: f64, (start, load): (f64, impl Fn(usize) -> f64), level_at: impl Fn(f64) -> f64) -> f64 {
    // the remembered load at each step's onset, carried from the step before
    let (mut peak, mut prev_peak) = (start, start);
    for q in 0..=cur {
        if q > 0 {
            prev_peak = peak;
            peak = load(q - 1) + (peak - load(q - 1)) * (-(s.t0(q) - s.t0(q - 1)) / memory_s).exp();
        }
        peak = peak.max(load(q));
    }
    // the gap in level at t from a remembered load at an onset, fading toward the step's load
    let gap = |p: f64, q: usize| {
        let now = load(q) + (p - load(q)).max(0.0) * (-super::since(t, s.t0(q)) / memory_s).exp();
        level_at(now) - level_at(load(q))
    };
    let now = gap(peak, cur);
    let before = if cur > 0 { gap(prev_peak.max(load(cur - 1)), cur - 1) } else { 0.0 };
    now + (before - now) * super::decay(super::since(t, s.t0(cur)) / s.tau(cur))
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
        let steps = super::super::UpDown { t0: [0.0, 10.0], top: 2.0, after: 1.0, tau_s: [1.0; 2] };
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
        let once = super::super::UpDown { t0: [0.0, 10.0], top: 2.0, after: 1.0, tau_s: [1.0; 2] };
        assert!(once.after_peak(1) && !once.after_peak(0));
    }

    /// A staircase up three levels and down again, 20 s a hold. A memory far longer than the
    /// recording gives the permanent memory's column; one of 30 s closes the gap within a hold
    /// (e^(−20/30) of it left at the next step), and the next removal's gap is the faded memory's
    /// distance to the new level, not the top's.
    #[test]
    fn a_fading_memory_closes_the_gap_to_the_peak() {
        struct Stairs;
        const L: [f64; 6] = [1.0, 2.0, 3.0, 2.0, 1.0, 0.0];
        impl Steps for Stairs {
            fn t0(&self, q: usize) -> f64 {
                20.0 * q as f64
            }
            fn tau(&self, _: usize) -> f64 {
                0.5
            }
            fn dv(&self, q: usize) -> f64 {
                L[q] - if q > 0 { L[q - 1] } else { 0.0 }
            }
            fn level(&self, q: usize) -> f64 {
                L[q]
            }
            fn below_top(&self, q: usize) -> f64 {
                3.0 - L[q]
            }
            fn unloading(&self, q: usize) -> bool {
                q >= 3
            }
        }
        // loads in grams, 100 g a level unit
        let load = |q: usize| 100.0 * L[q];
        let lin = |g: f64| g / 100.0;
        let fading = |q: usize, t: f64, m: f64| fading_column(&Stairs, (q, t), m, (0.0, load), lin);
        for q in 0..6 {
            for t in [20.0 * q as f64 + 0.3, 20.0 * q as f64 + 5.0, 20.0 * q as f64 + 19.9] {
                let (a, b) = (column(&Stairs, q, t), fading(q, t, 1e12));
                assert!((a - b).abs() < 1e-9, "step {q}, t {t}: {a} vs {b}");
            }
        }
        let m = 30.0;
        // the first removal: the gap 1, fading from the step's onset
        assert!((fading(3, 79.9, m) - (-19.9f64 / m).exp()).abs() < 1e-6);
        // the second: the memory left at its onset (2 + e^(−20/30)) less its level (1)
        let g4 = 1.0 + (-20.0f64 / m).exp();
        assert!((fading(4, 99.9, m) - g4 * (-19.9f64 / m).exp()).abs() < 1e-6);
        // no gap while the load rises
        assert_eq!(fading(2, 55.0, m), 0.0);
        // the gap is the level's at the remembered load: a read-out that compresses its top levels
        // (level ∝ √load) shows the same remembered load as a smaller gap
        let sqrt = |g: f64| (g / 100.0).sqrt();
        let p4 = 100.0 + 100.0 * (1.0 + (-20.0f64 / m).exp()) * (-19.9f64 / m).exp();
        let want = sqrt(p4) - sqrt(100.0);
        let got = fading_column(&Stairs, (4, 99.9), m, (0.0, load), sqrt);
        assert!((got - want).abs() < 1e-9 && got < fading(4, 99.9, m), "{got} vs {want}");
        // a read-out whose level falls with the load: the same gap, with the levels' sign
        let neg = |g: f64| -g / 100.0;
        assert!((fading_column(&Stairs, (4, 99.9), m, (0.0, load), neg) + fading(4, 99.9, m)).abs() < 1e-12);
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
