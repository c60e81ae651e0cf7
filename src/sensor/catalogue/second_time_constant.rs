//! `second_time_constant`: part of each step relaxes with a second, slower time constant.
//!
//! Signature: too few sign runs in the residual over the first ten time constants of a step (a
//! runs test): the early residual is one smooth excursion, not noise.
//! Term: with the change (a dome or cover relaxing on its own), the step's change split between its
//! own time constant and τ2, dv·(e^(−t/τ) − e^(−t/τ2)); or with the size of the change (any
//! change disturbs the material, which recovers over τ2, whichever way the load moved),
//! |dv|·e^(−t/τ2), one coefficient after loading steps and one after unloading steps; or with the
//! change of the sensor's conductance, seen through the read-out (the diagnosis's
//! `TrialSteps::second_through_column`, which knows the read-out). τ2 and the drive are shape
//! parameters chosen on the training fit.

use super::{Hold, Located, Steps, MIN_SIGNATURE_Z};

pub const EXPLANATION: &str = "part of each step relaxes with a second, slower time constant (the dome or a cover relaxing on its own), modelled as a mixture of two exponentials";

pub const THROUGH_EXPLANATION: &str = "part of each change of the sensor's conductance relaxes with a second, slower time constant, seen through the read-out (a divider shows it in full near no load and compressed at its top), modelled as a mixture of two exponentials in the conductance";

pub const EXPLANATION_SIZE: &str = "every change of load, up or down alike, sets off a second, slower relaxation of its own: the response jumps with the change and relaxes back over τ2, whichever way the load moved — the conductive network is disturbed by any deformation and re-forms slowly (seen in carbon-black elastomers); modelled as a decaying jump in proportion to the size of the change, after loading and unloading steps apart";

/// What sets the second relaxation's amplitude.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// The step's change, with its sign.
    Change,
    /// The size of the change, either way.
    Size,
    /// The change of the sensor's conductance, with its sign, seen through the read-out.
    Through,
}

impl Drive {
    pub fn columns(self) -> usize {
        match self {
            Drive::Change | Drive::Through => 1,
            Drive::Size => 2,
        }
    }
    pub fn label(self) -> &'static str {
        match self {
            Drive::Change => "the change",
            Drive::Size => "the size of the change",
            Drive::Through => "the change of the conductance",
        }
    }
    pub fn explanation(self) -> &'static str {
        match self {
            Drive::Change => EXPLANATION,
            Drive::Size => EXPLANATION_SIZE,
            Drive::Through => THROUGH_EXPLANATION,
        }
    }
}

/// A step's share relaxing at τ2 instead of at its own τ, `since` seconds after its onset: the
/// change's kernel, e^(−t/τ) − e^(−t/τ2) (0 before the onset).
pub fn split(since: f64, tau_s: f64, tau2_s: f64) -> f64 {
    super::decay(since / tau_s) - super::decay(since / tau2_s)
}

/// The term's columns at time t (`out` holds `drive.columns()` values), from the steps begun; the
/// conductance's form (`Drive::Through`) needs the read-out and is the diagnosis's: here it is
/// taken in the response, as `Drive::Change`.
pub fn columns(s: &impl Steps, active: &[usize], t: f64, tau2_s: f64, drive: Drive, out: &mut [f64]) {
    for &q in active {
        let since = super::since(t, s.t0(q));
        match drive {
            Drive::Change | Drive::Through => out[0] += s.dv(q) * split(since, s.tau(q), tau2_s),
            // the size drive holds |dv| over the half filtered span before the onset (its value at
            // the onset, as e^(half span/τ2) ≈ 1 gave before `since`); 0 there, as the spectrum's kernels
            // are, let a false 2 s second τ in on a creep (`tests/advice.rs`,
            // nothing_ambiguous_nothing_advised; stop 46)
            Drive::Size => out[usize::from(s.unloading(q))] += s.dv(q).abs() * super::decay(since / tau2_s),
        }
    }
}

/// Steps whose early residual (first ten time constants) has too few sign runs.
pub fn signature(holds: &[Hold]) -> Vec<Located> {
    let mut out = Vec::new();
    for h in holds {
        let stop = (h.t0_s + 10.0 * h.tau_s).min(h.end_s);
        let r: Vec<f64> = (0..h.t.len()).filter(|&j| h.t[j] >= h.t0_s && h.t[j] < stop).map(|j| h.r[j]).filter(|e| *e != 0.0).collect();
        if r.len() < 20 {
            continue;
        }
        let np = r.iter().filter(|e| **e > 0.0).count() as f64;
        let nm = r.len() as f64 - np;
        if np < 1.0 || nm < 1.0 {
            out.push(Located {
                recording: h.recording.to_string(),
                start_s: h.t0_s,
                end_s: stop,
                statistic: format!("early residual of one sign over {} samples", r.len()),
                z: r.len() as f64,
            });
            continue;
        }
        let n = np + nm;
        let runs = 1.0 + r.windows(2).filter(|p| (p[0] > 0.0) != (p[1] > 0.0)).count() as f64;
        let mu = 2.0 * np * nm / n + 1.0;
        let var = (mu - 1.0) * (mu - 2.0) / (n - 1.0);
        let z = (runs - mu) / var.max(1e-300).sqrt();
        // a filtered series has fewer runs than white noise: judge against the whole hold's own
        // run rate (late part), not against independence
        let late = h.residuals_from(stop);
        let late_rate = if late.len() >= 20 { late.windows(2).filter(|p| (p[0] > 0.0) != (p[1] > 0.0)).count() as f64 / (late.len() - 1) as f64 } else { 0.5 };
        let expected = 1.0 + late_rate * (n - 1.0);
        let z_rel = (runs - expected) / var.max(1e-300).sqrt();
        if z.min(z_rel) <= -MIN_SIGNATURE_Z && z_rel <= -MIN_SIGNATURE_Z {
            out.push(Located {
                recording: h.recording.to_string(),
                start_s: h.t0_s,
                end_s: stop,
                statistic: format!("{runs:.0} sign runs in the first 10τ where {expected:.0} were expected (runs test z = {z_rel:.1})"),
                z: -z_rel,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn change_drive_follows_the_sign_and_size_drive_does_not() {
        let steps = super::super::UpDown { t0: [0.0, 20.0], top: 1.0, after: 0.0, tau_s: [1.0; 2] };
        let mut a = [0.0];
        columns(&steps, &[0, 1], 21.0, 8.0, Drive::Change, &mut a);
        let mut b = [0.0];
        columns(&steps, &[0], 1.0, 8.0, Drive::Change, &mut b);
        assert!(b[0] < 0.0 && a[0] > 0.0, "{a:?} {b:?}");
        let mut c = [0.0; 2];
        columns(&steps, &[0, 1], 21.0, 8.0, Drive::Size, &mut c);
        assert!(c[0] > 0.0 && c[1] > 0.0 && (c[1] - (-1.0f64 / 8.0).exp()).abs() < 1e-12);
    }

    #[test]
    fn signature_flags_a_smooth_early_excursion_only() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 0.01).collect();
        let e = super::super::test_noise(2000, 0.003, 9);
        let slow: Vec<f64> = t.iter().zip(&e).map(|(x, n)| n + 0.02 * ((-x / 8.0).exp() - (-x / 0.5).exp())).collect();
        let flags = |r: &[f64]| signature(&[super::super::test_hold(&t, r, 0.0, 20.0, 1.0, 0.0)]).len();
        assert_eq!(flags(&slow), 1);
        assert_eq!(flags(&e), 0);
    }
}
