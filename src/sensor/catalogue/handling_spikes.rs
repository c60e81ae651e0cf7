//! `handling_spikes`: short transients while weights are placed by hand.
//!
//! Signature: a short excursion (≤ `max_spike_s`) of the raw samples from the step's own
//! first-order curve, within the handling window of a logged step. The running-median detector of
//! part 1 misses a spike that rides the step's edge in the step's direction (the median follows
//! the edge); this one compares the samples with the step's first-order curve, its onset fitted
//! robustly (Tukey's biweight, so the spike carries no weight), removes what varies slowly (a
//! running median of the residual over ±0.5 s) and scans the rest with box filters of 0.03–0.25 s.
//! Term: none — the windows are reported and excluded from every fit; placing weights by hand is
//! not sensor physics.

use super::super::preprocess::{median, SpikeWindow};

pub const EXPLANATION: &str = "short transients while weights are placed by hand: an artifact of the procedure, reported and excluded from every fit, not modelled as physics";

/// A box-filtered residual must stand this many of its own standard deviations off zero.
pub const MIN_Z: f64 = 6.0;

/// One logged step as the detector sees it: its fitted onset and time constant, and the span it
/// may look in (its handling window, cut at the neighbouring steps).
#[derive(Debug, Clone)]
pub struct EdgeStep {
    pub t0_s: f64,
    pub tau_s: f64,
    pub from_s: f64,
    pub to_s: f64,
}

fn tukey(r: f64, c: f64) -> (f64, f64) {
    // (ρ, weight)
    if r.abs() >= c {
        (c * c / 6.0, 0.0)
    } else {
        let q = 1.0 - (r / c).powi(2);
        (c * c / 6.0 * (1.0 - q * q * q), q * q)
    }
}

/// Robust fit of v = a + b·u(t), u = 1 − e^(−(t − t0)/τ) after t0 (0 before), over onsets near
/// `t0_s`; returns the residuals at the samples given.
fn robust_residual(t: &[f64], v: &[f64], st: &EdgeStep, sigma: f64) -> Vec<f64> {
    let n = t.len();
    let dt = if n > 1 { (t[n - 1] - t[0]) / (n - 1) as f64 } else { 0.01 };
    let c = 4.685 * sigma;
    let mut pre: Vec<f64> = (0..n).filter(|&j| t[j] < st.t0_s - 0.2).map(|j| v[j]).collect();
    let mut late: Vec<f64> = (0..n).filter(|&j| t[j] > st.t0_s + 3.0 * st.tau_s).map(|j| v[j]).collect();
    let a0 = if pre.is_empty() { v[0] } else { median(&mut pre) };
    let l0 = if late.is_empty() { v[n - 1] } else { median(&mut late) };
    let mut best: (f64, f64, f64, f64) = (f64::INFINITY, st.t0_s, a0, l0 - a0);
    let steps = (0.6 / (0.5 * dt)).round().max(1.0) as usize;
    let mut u = vec![0.0; n];
    for g in 0..=steps {
        let t0 = st.t0_s - 0.3 + 0.6 * g as f64 / steps as f64;
        for j in 0..n {
            u[j] = if t[j] > t0 { 1.0 - (-(t[j] - t0) / st.tau_s).exp() } else { 0.0 };
        }
        let (mut a, mut b) = (a0, l0 - a0);
        let mut obj = 0.0;
        for _ in 0..5 {
            let (mut sw, mut su, mut suu, mut sv, mut suv) = (0.0, 0.0, 0.0, 0.0, 0.0);
            obj = 0.0;
            for j in 0..n {
                let (rho, w) = tukey(v[j] - a - b * u[j], c);
                obj += rho;
                sw += w;
                su += w * u[j];
                suu += w * u[j] * u[j];
                sv += w * v[j];
                suv += w * u[j] * v[j];
            }
            let det = sw * suu - su * su;
            if det.abs() < 1e-12 * (1.0 + sw * suu) {
                break;
            }
            b = (sw * suv - su * sv) / det;
            a = (sv - b * su) / sw;
        }
        let obj_end: f64 = (0..n).map(|j| tukey(v[j] - a - b * u[j], c).0).sum();
        let _ = obj;
        if obj_end < best.0 {
            best = (obj_end, t0, a, b);
        }
    }
    let (_, t0, a, b) = best;
    (0..n).map(|j| v[j] - a - b * if t[j] > t0 { 1.0 - (-(t[j] - t0) / st.tau_s).exp() } else { 0.0 }).collect()
}

/// Spike windows at the steps' edges (raw samples, their noise `sigma`).
pub fn detect(t: &[f64], v: &[f64], steps: &[EdgeStep], sigma: f64, max_spike_s: f64) -> Vec<SpikeWindow> {
    let mut out = Vec::new();
    if t.len() < 8 || sigma <= 0.0 {
        return out;
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let mut widths: Vec<usize> = [0.03, 0.05, 0.09, 0.15, 0.25].iter().map(|w| ((w / dt).round() as usize).max(1)).collect();
    widths.dedup();
    let half = ((0.5 / dt).round() as usize).max(2);
    for st in steps {
        let idx: Vec<usize> = (0..t.len()).filter(|&j| t[j] >= st.from_s && t[j] <= st.to_s).collect();
        if idx.len() < 4 * half {
            continue;
        }
        let (tt, vv): (Vec<f64>, Vec<f64>) = idx.iter().map(|&j| (t[j], v[j])).unzip();
        let r = robust_residual(&tt, &vv, st, sigma);
        let n = r.len();
        // what varies slowly is the model's, not a spike
        let mut buf = Vec::with_capacity(2 * half + 1);
        let rr: Vec<f64> = (0..n)
            .map(|j| {
                buf.clear();
                buf.extend_from_slice(&r[j.saturating_sub(half)..(j + half + 1).min(n)]);
                r[j] - median(&mut buf)
            })
            .collect();
        let mut prefix = vec![0.0; n + 1];
        for j in 0..n {
            prefix[j + 1] = prefix[j] + rr[j];
        }
        let mut hit = vec![false; n];
        for &w in &widths {
            if w > n {
                continue;
            }
            let scale = sigma * (w as f64).sqrt();
            for j in 0..=n - w {
                if ((prefix[j + w] - prefix[j]) / scale).abs() >= MIN_Z {
                    hit[j..j + w].iter_mut().for_each(|h| *h = true);
                }
            }
        }
        let gap = ((0.1 / dt).round() as usize).max(1);
        let pad = ((0.05 / dt).round() as usize).max(1);
        let mut j = 0;
        while j < n {
            if !hit[j] {
                j += 1;
                continue;
            }
            let start = j;
            let mut end = j;
            let mut k = j;
            while k < n && k <= end + gap {
                if hit[k] {
                    end = k;
                }
                k += 1;
            }
            if tt[end] - tt[start] <= max_spike_s {
                let peak = (start..=end).map(|q| rr[q]).fold(0.0f64, |p, x| if x.abs() > p.abs() { x } else { p });
                out.push(SpikeWindow { start_s: tt[start.saturating_sub(pad)], end_s: tt[(end + pad).min(n - 1)], peak });
            }
            j = end + 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(spike: f64, sign: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|&x| if x < 10.0 { 0.5 } else { 0.5 - 0.3 * (1.0 - (-(x - 10.0) / 0.6f64).exp()) }).collect();
        for (i, x) in v.iter_mut().enumerate() {
            // deterministic noise, σ ≈ 0.003
            *x += 0.0104 * (((i * 7919) % 1000) as f64 / 1000.0 - 0.5);
            let s = t[i] - 10.0 + 0.075;
            if (0.0..0.15).contains(&s) {
                *x += sign * spike * (std::f64::consts::PI * s / 0.15).sin();
            }
        }
        (t, v)
    }

    #[test]
    fn finds_a_spike_riding_the_edge_in_the_steps_direction() {
        // a falling step with a falling spike: the running median of part 1 follows it
        let (t, v) = series(0.049, -1.0);
        let st = EdgeStep { t0_s: 10.02, tau_s: 0.6, from_s: 7.0, to_s: 13.0 };
        let w = detect(&t, &v, &[st], 0.003, 1.0);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].start_s <= 9.95 && w[0].end_s >= 10.05 && w[0].peak < 0.0, "{w:?}");
        let (_, mask) = super::super::super::preprocess::spikes(&t, &v, &Default::default());
        assert!(mask.iter().all(|m| *m), "part 1's detector was expected to miss it");
    }

    #[test]
    fn nothing_on_a_clean_step_or_a_slow_transient() {
        let (t, mut v) = series(0.0, 1.0);
        let st = EdgeStep { t0_s: 10.0, tau_s: 0.6, from_s: 7.0, to_s: 13.0 };
        assert!(detect(&t, &v, &[st.clone()], 0.003, 1.0).is_empty());
        // a slower second relaxation the first-order curve does not have
        for (i, x) in v.iter_mut().enumerate() {
            if t[i] > 10.0 {
                *x += 0.03 * ((-(t[i] - 10.0) / 8.0).exp() - (-(t[i] - 10.0) / 0.6).exp());
            }
        }
        assert!(detect(&t, &v, &[st], 0.003, 1.0).is_empty());
    }
}
