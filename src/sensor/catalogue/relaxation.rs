//! `relaxation`: a spectrum of relaxations superposed over every load change (issue 15, item 2).
//!
//! Term: every change of load q drives, through its change of level dv_q, a sum of decaying
//! exponentials on a fixed log grid of time constants,
//!   Σ_q dv_q · Σ_k a_k^{dir(q)} · K(t; ramp_q, τ_k),
//! with one set of amplitudes after loading changes and one after unloading changes, and each
//! kernel K the exponential's response to the load as it is applied (a linear ramp of the given
//! duration ending at the ramp's end, or a jump). The amplitudes are linear; they are found by
//! least squares penalised toward smoothness along log τ (second differences), the penalty chosen
//! by inner cross-validation (the diagnosis does that). What the fitted spectrum looks like decides
//! the name ([`name`]): a broad band is creep (relaxation over many time scales, carried over from
//! step to step), one narrow peak a second time constant; responses of one sign after loading
//! and unloading are a change-driven relaxation (the second time constant with the size of the
//! change as its drive).
//!
//! Signature: the creep and second-time-constant signatures (the residual trends and early runs
//! the spectrum explains).

pub const EXPLANATION: &str = "the response keeps relaxing after each change of load over a spread of time scales, carried over from change to change (viscoelastic creep of the rubber), modelled as a relaxation spectrum superposed over every load change";

/// Kernels per decade of τ.
pub const PER_DECADE: f64 = 4.0;

/// The grid of time constants: from `lo_s` to `hi_s`, [`PER_DECADE`] per decade (at least 4).
pub fn grid(lo_s: f64, hi_s: f64) -> Vec<f64> {
    let (lo, hi) = (lo_s.max(1e-3), hi_s.max(lo_s * 10.0));
    let n = ((hi / lo).log10() * PER_DECADE).ceil().max(3.0) as usize + 1;
    (0..n).map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64)).collect()
}

/// e^(−(t − s)/τ) for t ≥ s, averaged over onsets s spread evenly over the ramp [end − ramp, end]
/// (ramp 0: a jump at `end`).
pub fn kernel(t: f64, end: f64, ramp_s: f64, tau: f64) -> f64 {
    if ramp_s <= 0.0 {
        return if t >= end { super::decay((t - end) / tau) } else { 0.0 };
    }
    let start = end - ramp_s;
    if t <= start {
        return 0.0;
    }
    let x = (t - start) / tau;
    if x > 60.0 && t > end && (t - end) / tau > 60.0 {
        return 0.0;
    }
    // (1/D)∫_{start}^{min(t, end)} e^{−(t−s)/τ} ds
    let upper = super::decay((t - t.min(end)) / tau);
    tau / ramp_s * (upper - super::decay(x))
}

/// The second-difference penalty along log τ for `sets` consecutive sets of `k` amplitudes
/// (DᵀD, row-major k·sets square).
pub fn smoothness(k: usize, sets: usize) -> Vec<f64> {
    let n = k * sets;
    let mut p = vec![0.0; n * n];
    for s in 0..sets {
        for j in 0..k.saturating_sub(2) {
            let idx = [s * k + j, s * k + j + 1, s * k + j + 2];
            let w = [1.0, -2.0, 1.0];
            for a in 0..3 {
                for b in 0..3 {
                    p[idx[a] * n + idx[b]] += w[a] * w[b];
                }
            }
        }
    }
    p
}

/// What the spectrum is called.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// A broad band over many time scales.
    Creep,
    /// One narrow peak, the response with the change's sign.
    SecondTimeConstant,
    /// One sign of response after loading and unloading alike.
    ChangeDriven,
}

/// Share of a set's absolute amplitude within one grid step either side of its peak for it to be
/// one narrow peak.
pub const PEAK_SHARE: f64 = 0.6;

/// The peak's time constant (amplitude-weighted in log τ over the peak and its neighbours) and the
/// share of the set's absolute amplitude it holds.
pub fn peak(taus: &[f64], a: &[f64]) -> (f64, f64) {
    let total: f64 = a.iter().map(|x| x.abs()).sum();
    let Some(m) = (0..a.len()).max_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs())) else { return (f64::NAN, 0.0) };
    let near = m.saturating_sub(1)..(m + 2).min(a.len());
    let w: f64 = near.clone().map(|i| a[i].abs()).sum();
    let ln: f64 = near.map(|i| a[i].abs() * taus[i].ln()).sum::<f64>() / w.max(1e-300);
    (ln.exp(), w / total.max(1e-300))
}

/// The name the fitted amplitudes (loading set, then unloading set; response per unit change of
/// level) give: responses of one sign after loading and unloading (the drive multiplies the signed
/// change, so opposite-signed amplitudes) are change-driven; otherwise a narrow peak in both sets
/// is a second time constant, and anything broader creep.
pub fn name(taus: &[f64], amps: &[f64]) -> Shape {
    let k = taus.len();
    let (load, unload) = amps.split_at(k);
    let sum = |x: &[f64]| x.iter().sum::<f64>();
    let (sl, su) = (sum(load), sum(unload));
    let mag = |x: &[f64]| x.iter().map(|v| v.abs()).sum::<f64>();
    // the net relaxation after each kind of change, against its absolute size (a band of mixed
    // signs nets to little)
    if sl * su < 0.0 && sl.abs() > 0.5 * mag(load) && su.abs() > 0.5 * mag(unload) {
        return Shape::ChangeDriven;
    }
    let (_, pl) = peak(taus, load);
    let (_, pu) = peak(taus, unload);
    let w = mag(load) + mag(unload);
    let share = (pl * mag(load) + pu * mag(unload)) / w.max(1e-300);
    if share >= PEAK_SHARE {
        Shape::SecondTimeConstant
    } else {
        Shape::Creep
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_kernel_is_the_jump_kernel_averaged_over_the_ramp() {
        let (end, d, tau) = (10.0, 4.0, 3.0);
        for t in [5.0, 6.5, 8.0, 10.0, 12.0, 30.0] {
            let n = 20000;
            let avg: f64 = (0..n).map(|i| kernel(t, end - d + d * (i as f64 + 0.5) / n as f64, 0.0, tau)).sum::<f64>() / n as f64;
            assert!((kernel(t, end, d, tau) - avg).abs() < 1e-4, "t {t}: {} vs {avg}", kernel(t, end, d, tau));
        }
        assert_eq!(kernel(5.9, end, d, tau), 0.0);
        assert!(kernel(10.0, end, d, tau) > 0.4);
    }

    #[test]
    fn grid_spans_and_penalty_sees_curvature_not_lines() {
        let g = grid(0.3, 1000.0);
        assert!((g[0] - 0.3).abs() < 1e-12 && (g[g.len() - 1] - 1000.0).abs() < 1e-9 && g.len() >= 14);
        let k = 5;
        let p = smoothness(k, 2);
        let quad = |x: &[f64]| -> f64 { (0..2 * k).map(|a| (0..2 * k).map(|b| x[a] * p[a * 2 * k + b] * x[b]).sum::<f64>()).sum() };
        let line: Vec<f64> = (0..2 * k).map(|i| (i % k) as f64).collect();
        assert!(quad(&line).abs() < 1e-12);
        let bump: Vec<f64> = (0..2 * k).map(|i| if i % k == 2 { 1.0 } else { 0.0 }).collect();
        assert!(quad(&bump) > 5.0);
    }

    #[test]
    fn names_follow_the_spectrum() {
        let taus = grid(0.3, 1000.0);
        let k = taus.len();
        // a narrow peak at the same τ after loading and unloading, signed with the change
        let mut a = vec![0.0; 2 * k];
        a[8] = 0.2;
        a[k + 8] = 0.2;
        a[9] = 0.05;
        a[k + 9] = 0.05;
        assert_eq!(name(&taus, &a), Shape::SecondTimeConstant);
        // a broad band
        let b: Vec<f64> = (0..2 * k).map(|i| if (i % k) >= 3 { 0.03 } else { 0.0 }).collect();
        assert_eq!(name(&taus, &b), Shape::Creep);
        // overshoot up after both: opposite signs per unit signed change
        let mut c = a.clone();
        for v in &mut c[k..] {
            *v = -*v;
        }
        assert_eq!(name(&taus, &c), Shape::ChangeDriven);
    }
}
