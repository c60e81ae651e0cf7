//! The first-order rise 1 − e^(−(t − t0)/τ) as a filtered sample sees it (the average over its
//! span), with its derivatives in the onset and in ln τ (the Gauss–Newton columns of the refit).

/// Time constants after which a first-order rise is taken as settled (e^(−40) ≈ 4e-18).
pub(super) const SETTLED: f64 = 40.0;

/// The first-order rise 1 − e^(−(t − t0)/τ) (0 before t0), averaged over [t − h, t + h] (a filtered
/// sample's span; h = 0: the value at t).
pub(super) fn block_rise(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
    if t - h - t0 > SETTLED * tau {
        return 1.0;
    }
    if h <= 0.0 {
        return if t >= t0 { 1.0 - (-(t - t0) / tau).exp() } else { 0.0 };
    }
    if t - h >= t0 {
        let x = h / tau;
        1.0 - (-(t - t0) / tau).exp() * x.sinh() / x
    } else if t + h <= t0 {
        0.0
    } else {
        let a = t + h - t0;
        (a - tau * (1.0 - (-a / tau).exp())) / (2.0 * h)
    }
}

/// ∂/∂t0 of [`block_rise`].
pub(super) fn rise_dt0(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
    if t - h - t0 > SETTLED * tau {
        return 0.0;
    }
    if h <= 0.0 {
        return if t >= t0 { -(-(t - t0) / tau).exp() / tau } else { 0.0 };
    }
    if t - h >= t0 {
        let x = h / tau;
        -(-(t - t0) / tau).exp() * x.sinh() / x / tau
    } else if t + h <= t0 {
        0.0
    } else {
        -(1.0 - (-(t + h - t0) / tau).exp()) / (2.0 * h)
    }
}

/// ∂/∂ln τ of [`block_rise`].
pub(super) fn rise_dln_tau(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
    if t - h - t0 > SETTLED * tau {
        return 0.0;
    }
    if h <= 0.0 {
        let x = (t - t0) / tau;
        return if t >= t0 { -x * (-x).exp() } else { 0.0 };
    }
    if t - h >= t0 {
        // 1 − e^(−u/τ)·S(x), S(x) = sinh x / x, x = h/τ
        let (u, x) = (t - t0, h / tau);
        let s = x.sinh() / x;
        let ds = (x * x.cosh() - x.sinh()) / (x * x);
        -(-u / tau).exp() * (u / tau * s - x * ds)
    } else if t + h <= t0 {
        0.0
    } else {
        let a = t + h - t0;
        let e = (-a / tau).exp();
        (a * e - tau * (1.0 - e)) / (2.0 * h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Gauss–Newton columns are the derivatives of the model they correct: the filtered
    /// sample's average, before, across and after a step's onset.
    #[test]
    fn rise_derivatives_match_the_filtered_rise() {
        let (t0, tau) = (10.0, 0.8);
        for h in [0.0, 0.045] {
            for t in [9.9, 9.97, 10.001, 10.02, 10.04, 10.3, 12.0] {
                let e = 1e-6;
                let dt0 = (block_rise(t, t0 + e, tau, h) - block_rise(t, t0 - e, tau, h)) / (2.0 * e);
                assert!((rise_dt0(t, t0, tau, h) - dt0).abs() < 1e-5, "h {h} t {t}: {} vs {dt0}", rise_dt0(t, t0, tau, h));
                let dl = (block_rise(t, t0, tau * e.exp(), h) - block_rise(t, t0, tau * (-e).exp(), h)) / (2.0 * e);
                assert!((rise_dln_tau(t, t0, tau, h) - dl).abs() < 1e-5, "h {h} t {t}: {} vs {dl}", rise_dln_tau(t, t0, tau, h));
            }
        }
        // the derivatives are not zero where the rise moves (the test can fail)
        assert!(rise_dt0(10.3, t0, tau, 0.045) < -0.5 && rise_dln_tau(10.3, t0, tau, 0.045) < -0.1);
    }
}
