//! The catalogue of physics the paper's first-order model leaves out: one module per effect, each
//! with (a) its signature in the residuals (`signature`: the windows where it shows, each with its
//! statistic), (b) its model term (columns added to the step model, linear given their shape
//! parameters) and (c) a sentence a lab user understands (`EXPLANATION`).
//!
//! The terms read the steps through [`Steps`], so they do not depend on how the diagnosis stores
//! its model; the signatures read the residuals of one hold at a time through [`Hold`].

pub mod baseline_drift;
pub mod creep;
pub mod handling_spikes;
pub mod hysteresis;
pub mod relaxation;
pub mod saturation;
pub mod second_time_constant;

use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Effect {
    Creep,
    Hysteresis,
    SecondTimeConstant,
    BaselineDrift,
    Saturation,
    HandlingSpikes,
    /// A relaxation spectrum over every load change: reported as creep or a second time
    /// constant, whichever its fitted shape is ([`relaxation::name`]).
    Relaxation,
    /// A relaxation per trial from its first sample (what the sample brings from before the
    /// recording): a nuisance that competes with the physics terms, reported with the nuisances.
    RestRelaxation,
}

/// The effects with a model term, in the order the forward selection tries them.
pub const MODELLED: [Effect; 6] = [Effect::Creep, Effect::Hysteresis, Effect::SecondTimeConstant, Effect::BaselineDrift, Effect::Saturation, Effect::Relaxation];

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::Creep => "creep",
            Effect::Hysteresis => "hysteresis",
            Effect::SecondTimeConstant => "second_time_constant",
            Effect::BaselineDrift => "baseline_drift",
            Effect::Saturation => "saturation",
            Effect::HandlingSpikes => "handling_spikes",
            Effect::Relaxation => "relaxation",
            Effect::RestRelaxation => "rest_relaxation",
        }
    }
    pub fn explanation(self) -> &'static str {
        match self {
            Effect::Creep => creep::EXPLANATION,
            Effect::Hysteresis => hysteresis::EXPLANATION,
            Effect::SecondTimeConstant => second_time_constant::EXPLANATION,
            Effect::BaselineDrift => baseline_drift::EXPLANATION,
            Effect::Saturation => saturation::EXPLANATION,
            Effect::HandlingSpikes => handling_spikes::EXPLANATION,
            Effect::Relaxation => relaxation::EXPLANATION,
            Effect::RestRelaxation => REST_EXPLANATION,
        }
    }
}

pub const REST_EXPLANATION: &str = "each trial starts with a relaxation of its own that fades from its first sample (what the sensor brings from before the recording: how long it rested, what it carried): a nuisance of the set-up, fitted per trial and validated inside each trial, not physics of the sensor";

/// Time since an onset `t0_s` at `t` (s), 0 before it. A design row is active from half a filtered
/// span before its step's onset; a decay over the step's own τ taken there at a negative time
/// grows as e^(half span/τ) — for a jump (τ a share of one sample) to 10⁴² — and one such sample
/// leaves a term's column worthless (family A, a hand's quick lift: the hysteresis's coefficient
/// fitted 10⁻⁴⁴). Before its onset a step has not begun.
pub fn since(t: f64, t0_s: f64) -> f64 {
    (t - t0_s).max(0.0)
}

/// e^(−x), and exactly 0 past x = 700 (e^−700 ≈ 1e−304): libm's exp takes a slow path for every
/// result that underflows, and a term's decay is evaluated at every sample of an hours-long
/// recording for every step before it.
#[inline]
pub fn decay(x: f64) -> f64 {
    if x > 700.0 {
        0.0
    } else {
        (-x).exp()
    }
}

/// The steps of one trial as the model terms see them (all in the response unit and seconds).
pub trait Steps {
    /// Onset of step q.
    fn t0(&self, q: usize) -> f64;
    /// First-order time constant of step q.
    fn tau(&self, q: usize) -> f64;
    /// Change of the equilibrium level at step q (after − before).
    fn dv(&self, q: usize) -> f64;
    /// Equilibrium level of step q's load above the zero-load level.
    fn level(&self, q: usize) -> f64;
    /// The highest load's level minus step q's level.
    fn below_top(&self, q: usize) -> f64;
    /// Step q removes load.
    fn unloading(&self, q: usize) -> bool;
    /// Step q begins after the highest load was reached (the contact's peak memory holds): every
    /// unloading step, and in a repeated cycle the loading steps after the first top too.
    fn after_peak(&self, q: usize) -> bool {
        self.unloading(q)
    }
}

/// One hold of one trial (from a step's onset to the next) with the residuals of a model.
#[derive(Debug, Clone)]
pub struct Hold<'a> {
    pub recording: &'a str,
    pub t: &'a [f64],
    pub r: &'a [f64],
    /// Noise of one sample.
    pub sigma: f64,
    pub t0_s: f64,
    pub end_s: f64,
    pub tau_s: f64,
    pub load: f64,
    /// The load before the step.
    pub prev: f64,
    /// Index of the trial (holds of one trial share it).
    pub trial: usize,
}

impl Hold<'_> {
    /// The residuals from `from_s` to the hold's end.
    pub fn residuals_from(&self, from_s: f64) -> Vec<f64> {
        (0..self.t.len()).filter(|&j| self.t[j] >= from_s && self.t[j] < self.end_s).map(|j| self.r[j]).collect()
    }
}

/// The offset of mean(a) from mean(b) and its size in standard errors (autocorrelation-corrected);
/// None with fewer than 10 samples on a side.
pub fn offset_z(a: &[f64], b: &[f64]) -> Option<(f64, f64)> {
    if a.len() < 10 || b.len() < 10 {
        return None;
    }
    let ((ma, sa), (mb, sb)) = (mean_se(a), mean_se(b));
    Some((ma - mb, (ma - mb) / (sa * sa + sb * sb).sqrt().max(1e-300)))
}

/// A window where an effect's signature shows, with its statistic.
#[derive(Debug, Clone, Serialize)]
pub struct Located {
    pub recording: String,
    pub start_s: f64,
    pub end_s: f64,
    pub statistic: String,
    /// The statistic's size in standard errors (for ranking).
    #[serde(skip)]
    pub z: f64,
}

/// A signature's statistic must reach this many standard errors to flag a window.
pub const MIN_SIGNATURE_Z: f64 = 4.0;

/// Effective number of independent samples in an autocorrelated series (AR(1): n·(1 − ρ)/(1 + ρ)).
pub fn effective_n(r: &[f64]) -> f64 {
    let n = r.len() as f64;
    if r.len() < 3 {
        return n;
    }
    let mean = r.iter().sum::<f64>() / n;
    let var = r.iter().map(|e| (e - mean).powi(2)).sum::<f64>().max(1e-300);
    let rho = (r.windows(2).map(|p| (p[0] - mean) * (p[1] - mean)).sum::<f64>() / var).clamp(0.0, 0.99);
    (n * (1.0 - rho) / (1.0 + rho)).max(2.0)
}

/// Mean and its standard error (from the spread, corrected for autocorrelation).
pub fn mean_se(r: &[f64]) -> (f64, f64) {
    let n = r.len() as f64;
    if r.len() < 2 {
        return (r.first().copied().unwrap_or(0.0), f64::INFINITY);
    }
    let mean = r.iter().sum::<f64>() / n;
    let sd = (r.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd / effective_n(r).sqrt())
}

/// `n` significant digits (no exponent; whole numbers keep all their digits).
pub fn sig(v: f64, n: i32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (n - 1 - v.abs().max(1e-300).log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// Three significant digits.
pub fn sig3(v: f64) -> String {
    sig(v, 3)
}

/// Test steps: the load goes up to a level `top` at `t0[0]` and down to `after` at `t0[1]`
/// (levels above zero load), each step with its first-order τ `tau_s`.
#[cfg(test)]
pub(crate) struct UpDown {
    pub t0: [f64; 2],
    pub top: f64,
    pub after: f64,
    pub tau_s: [f64; 2],
}

#[cfg(test)]
impl Steps for UpDown {
    fn t0(&self, q: usize) -> f64 {
        self.t0[q]
    }
    fn tau(&self, q: usize) -> f64 {
        self.tau_s[q]
    }
    fn dv(&self, q: usize) -> f64 {
        [self.top, self.after - self.top][q]
    }
    fn level(&self, q: usize) -> f64 {
        [self.top, self.after][q]
    }
    fn below_top(&self, q: usize) -> f64 {
        [0.0, self.top - self.after][q]
    }
    fn unloading(&self, q: usize) -> bool {
        q == 1
    }
}

/// A test hold: noise 3 mV, τ = 0.5 s, trial 0.
#[cfg(test)]
pub(crate) fn test_hold<'a>(t: &'a [f64], r: &'a [f64], t0_s: f64, end_s: f64, load: f64, prev: f64) -> Hold<'a> {
    Hold { recording: "a", t, r, sigma: 0.003, t0_s, end_s, tau_s: 0.5, load, prev, trial: 0 }
}

/// Gaussian test noise (xorshift + Box–Muller), deterministic per seed.
#[cfg(test)]
pub(crate) fn test_noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut u = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        ((x >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    (0..n).map(|_| sigma * (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step faster than one sample (its τ a share of the interval), evaluated within half a
    /// filtered span before its onset, as a design row is: every term's column holds the value
    /// before the step (finite), where e^(half span/τ) made it 10⁴² (family A, a hand's quick lift).
    #[test]
    fn a_jump_s_columns_hold_before_its_onset() {
        // up to 2 at 0 s (τ 1 s), down to 1 at 10 s in a jump (τ 0.5 ms)
        let jump = UpDown { t0: [0.0, 10.0], top: 2.0, after: 1.0, tau_s: [1.0, 5e-4] };
        let (before, at) = (10.0 - 0.05, 10.0);
        let hyst = |t: f64| hysteresis::column(&jump, 1, t);
        assert!((hyst(before) - hyst(at)).abs() < 1e-12 && hyst(at).abs() < 1e-9, "{} {}", hyst(before), hyst(at));
        let fading = |t: f64| hysteresis::fading_column(&jump, (1, t), 60.0, (0.0, |q: usize| [200.0, 100.0][q]), |l| l / 100.0);
        assert!(fading(before).is_finite() && (fading(before) - fading(at)).abs() < 1e-12, "{} {}", fading(before), fading(at));
        let creep = |t: f64| creep::column(&jump, 1, t);
        assert!(creep(before).is_finite() && (creep(before) - creep(at)).abs() < 1e-12, "{} {}", creep(before), creep(at));
        for drive in [second_time_constant::Drive::Change, second_time_constant::Drive::Size] {
            let col = |t: f64| {
                let mut out = [0.0; 2];
                second_time_constant::columns(&jump, &[1], t, 30.0, drive, &mut out[..drive.columns()]);
                out
            };
            let (b, a) = (col(before), col(at));
            assert!(b.iter().zip(&a).all(|(x, y)| x.is_finite() && (x - y).abs() < 1e-12), "{b:?} {a:?}");
        }
    }

    #[test]
    fn test_noise_is_white_with_its_sigma() {
        let e = test_noise(20000, 0.003, 1);
        let (m, se) = mean_se(&e);
        assert!(m.abs() < 4.0 * se);
        let sd = (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
        assert!((sd / 0.003 - 1.0).abs() < 0.03, "{sd}");
        assert!(effective_n(&e) > 18000.0);
    }

    #[test]
    fn effective_n_shrinks_with_autocorrelation() {
        let white: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        assert!((effective_n(&white) - 1000.0).abs() < 1.0);
        let smooth: Vec<f64> = (0..1000).map(|i| (i as f64 / 50.0).sin()).collect();
        assert!(effective_n(&smooth) < 20.0);
    }
}
