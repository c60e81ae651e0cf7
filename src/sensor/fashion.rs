//! "Fashion" curves (the paper's Figure 6): how the step gain k and the time constant τ follow the
//! load. k comes from a physical form — the sensor's conductance as a power law of the load,
//! G = g1 · (L + L_pre)^n, seen through the divider — and τ from a straight line in the load.

use serde::Serialize;

/// How to turn the response into the sensor's conductance and back.
#[derive(Debug, Clone, Copy, Serialize)]
pub enum Readout {
    /// Divider voltage, sensor between supply and node.
    DividerHigh { vcc_v: f64, r_m_ohm: f64 },
    /// Divider voltage, sensor between node and ground.
    DividerLow { vcc_v: f64, r_m_ohm: f64 },
    /// Resistance in ohm.
    Ohm,
}

impl Readout {
    pub fn conductance(self, v: f64) -> Option<f64> {
        let g = match self {
            Readout::DividerHigh { vcc_v, r_m_ohm } => v / (r_m_ohm * (vcc_v - v)),
            Readout::DividerLow { vcc_v, r_m_ohm } => (vcc_v - v) / (r_m_ohm * v),
            Readout::Ohm => 1.0 / v,
        };
        (g.is_finite() && g > 0.0).then_some(g)
    }
    /// The divider's u = 1 + Rm·G at response `v` (G for a resistance): a step's share of the way
    /// in the read-out follows its share in conductance through it (`handling_spikes::EdgeStep`).
    /// Unlike `conductance`, a level at or just past the unloaded end (G ≤ 0 through noise or an
    /// offset) is kept.
    pub fn divider_u(self, v: f64) -> Option<f64> {
        let u = match self {
            Readout::DividerHigh { vcc_v, .. } => vcc_v / (vcc_v - v),
            Readout::DividerLow { vcc_v, .. } => vcc_v / v,
            Readout::Ohm => 1.0 / v,
        };
        (u.is_finite() && u > 0.0).then_some(u)
    }
    /// dV/du at response `v` (u as in [`Readout::divider_u`]): how a change of the sensor's
    /// conductance shows in the response at that level (a divider compresses it toward either end).
    pub fn slope_du(self, v: f64) -> f64 {
        match self {
            Readout::DividerHigh { vcc_v, .. } => (vcc_v - v).powi(2) / vcc_v,
            Readout::DividerLow { vcc_v, .. } => -v * v / vcc_v,
            Readout::Ohm => -v * v,
        }
    }
    /// The response at u (the inverse of [`Readout::divider_u`]); None outside the read-out's span.
    pub fn response_of_u(self, u: f64) -> Option<f64> {
        let v = match self {
            Readout::DividerHigh { vcc_v, .. } => vcc_v * (1.0 - 1.0 / u),
            Readout::DividerLow { vcc_v, .. } => vcc_v / u,
            Readout::Ohm => 1.0 / u,
        };
        (u > 0.0 && v.is_finite()).then_some(v)
    }
    pub fn response(self, g: f64) -> f64 {
        match self {
            Readout::DividerHigh { vcc_v, r_m_ohm } => vcc_v * r_m_ohm * g / (r_m_ohm * g + 1.0),
            Readout::DividerLow { vcc_v, r_m_ohm } => vcc_v / (r_m_ohm * g + 1.0),
            Readout::Ohm => 1.0 / g,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Fashion {
    pub readout: Readout,
    /// G = g1 · (L + preload)^n, L in the protocol's unit (grams).
    pub g1: f64,
    pub n: f64,
    pub preload: f64,
    /// RMS of log G residuals of the plateau levels.
    pub k_log_rms: f64,
    /// τ = tau0 + tau1 · L.
    pub tau0_s: f64,
    pub tau1_s_per_unit: f64,
    pub tau_rms_s: f64,
    /// (load, plateau response, fitted response) for each level.
    pub levels: Vec<(f64, f64, f64)>,
    /// (load, fitted τ of the step to that load, law's τ).
    pub taus: Vec<(f64, f64, f64)>,
}

impl Fashion {
    pub fn level(&self, load: f64) -> f64 {
        self.readout.response(self.g1 * (load + self.preload).max(0.0).powf(self.n))
    }
    pub fn tau(&self, load: f64) -> f64 {
        (self.tau0_s + self.tau1_s_per_unit * load).max(1e-3)
    }
    /// The step gain for a change of load.
    pub fn k(&self, from: f64, to: f64) -> f64 {
        self.level(to) - self.level(from)
    }
    /// Predicted step response at time t after a load change (first order).
    pub fn predict(&self, from: f64, to: f64, t: f64) -> f64 {
        self.level(from) + self.k(from, to) * (1.0 - (-t.max(0.0) / self.tau(to)).exp())
    }
}

/// Fits both curves from plateau levels (load, response) and step time constants (load, τ).
pub fn fit(readout: Readout, levels: &[(f64, f64)], taus: &[(f64, f64)]) -> Option<Fashion> {
    let pts: Vec<(f64, f64)> = levels.iter().filter_map(|&(l, v)| readout.conductance(v).map(|g| (l, g.ln()))).collect();
    if pts.len() < 3 || taus.len() < 2 {
        return None;
    }
    // log G = log g1 + n log(L + p): linear in (log g1, n) for each preload p; scan p
    let lmax = pts.iter().map(|p| p.0).fold(0.0, f64::max);
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for i in 0..=400 {
        let p = if i == 0 { 0.0 } else { lmax * 1e-4 * 1.03f64.powi(i) };
        if pts.iter().any(|q| q.0 + p <= 0.0) {
            continue;
        }
        let xs: Vec<f64> = pts.iter().map(|q| (q.0 + p).ln()).collect();
        let ys: Vec<f64> = pts.iter().map(|q| q.1).collect();
        let (slope, icpt, rms) = line(&xs, &ys);
        if best.is_none_or(|b| rms < b.3) {
            best = Some((icpt.exp(), slope, p, rms));
        }
    }
    let (g1, n, preload, k_log_rms) = best?;
    let (t1, t0, tau_rms) = line(&taus.iter().map(|t| t.0).collect::<Vec<_>>(), &taus.iter().map(|t| t.1).collect::<Vec<_>>());
    let mut f = Fashion { readout, g1, n, preload, k_log_rms, tau0_s: t0, tau1_s_per_unit: t1, tau_rms_s: tau_rms, levels: vec![], taus: vec![] };
    f.levels = levels.iter().map(|&(l, v)| (l, v, f.level(l))).collect();
    f.taus = taus.iter().map(|&(l, t)| (l, t, f.tau(l))).collect();
    Some(f)
}

/// Least-squares line: (slope, intercept, rms residual).
pub fn line(x: &[f64], y: &[f64]) -> (f64, f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let icpt = my - slope * mx;
    let rms = (x.iter().zip(y).map(|(a, b)| (b - icpt - slope * a).powi(2)).sum::<f64>() / n).sqrt();
    (slope, icpt, rms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn divider_u_inverts_the_response() {
        for r in [Readout::DividerHigh { vcc_v: 3.3, r_m_ohm: 1000.0 }, Readout::DividerLow { vcc_v: 5.0, r_m_ohm: 10_000.0 }] {
            let rm = match r {
                Readout::DividerHigh { r_m_ohm, .. } | Readout::DividerLow { r_m_ohm, .. } => r_m_ohm,
                Readout::Ohm => unreachable!(),
            };
            for g in [1e-6, 1e-4, 3e-3] {
                let u = r.divider_u(r.response(g)).unwrap();
                assert!((u - (1.0 + rm * g)).abs() < 1e-9 * u, "{r:?} {g}: {u}");
            }
        }
        assert!((Readout::Ohm.divider_u(Readout::Ohm.response(2e-4)).unwrap() - 2e-4).abs() < 1e-15);
        // the unloaded end is kept, a response past the supply is not
        assert!(Readout::DividerHigh { vcc_v: 3.3, r_m_ohm: 1000.0 }.divider_u(-0.001).is_some());
        assert!(Readout::DividerHigh { vcc_v: 3.3, r_m_ohm: 1000.0 }.divider_u(3.4).is_none());
    }

    #[test]
    fn recovers_a_power_law_through_the_divider() {
        let r = Readout::DividerHigh { vcc_v: 3.3, r_m_ohm: 1000.0 };
        let truth = |l: f64| r.response(2e-6 * (l + 20.0).powf(0.9));
        let levels: Vec<(f64, f64)> = [0.0, 200.0, 400.0, 600.0, 800.0, 1000.0].iter().map(|&l| (l, truth(l))).collect();
        let taus = vec![(200.0, 0.6), (400.0, 0.95), (600.0, 1.3), (800.0, 1.65), (1000.0, 2.0)];
        let f = fit(r, &levels, &taus).unwrap();
        assert!((f.n - 0.9).abs() < 0.02, "n {}", f.n);
        for &(l, v) in &levels {
            assert!((f.level(l) - v).abs() < 2e-3, "{l}: {} vs {v}", f.level(l));
        }
        assert!((f.tau(500.0) - 1.125).abs() < 1e-9);
        assert!(f.k(200.0, 400.0) > f.k(800.0, 1000.0));
    }
}
