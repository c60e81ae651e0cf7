//! `handling_spikes`: short transients while weights are placed by hand.
//!
//! Signature: a short excursion (≤ `max_spike_s`) of the raw samples from the step's own
//! first-order curve, within the handling window of a logged step. The running-median detector of
//! part 1 misses a spike that rides the step's edge in the step's direction (the median follows
//! the edge); this one compares the samples with the step's first-order curve, its onset fitted
//! robustly (Huber's loss, so the spike carries little weight), removes what varies slowly (a
//! running median of the residual over ±0.5 s) and scans the rest with box filters of 0.03–0.25 s.
//! Term: none — the windows are reported and excluded from every fit; placing weights by hand is
//! not sensor physics.

use super::super::preprocess::{median, SpikeWindow};

pub const EXPLANATION: &str = "short transients while weights are placed by hand: an artifact of the procedure, reported and excluded from every fit, not modelled as physics";

/// The box sums' robust spread, over this factor (its sampling error over a step's window), is
/// their scale when that exceeds σ·√w (coloured noise).
pub const COLOURED: f64 = 1.15;

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

fn huber(r: f64, k: f64) -> (f64, f64) {
    // (ρ, weight)
    let a = r.abs();
    if a <= k {
        (0.5 * r * r, 1.0)
    } else {
        (k * (a - 0.5 * k), k / a)
    }
}

/// Columns of the local model at time t: level, the step's first-order rise, and what a second
/// relaxation, creep or drift add near the edge (a rise at 4τ, and a ramp and its square after the
/// onset, over the window's length `span`). The load may arrive over a touch of `d` seconds from
/// the onset (a hand lowering a weight): the rises are then the responses to that ramp.
///
/// With a touch, two more columns: the first-order response to a brief extra press of the hand, a
/// smooth bump of force over the whole touch and over its first half. A press lasts as long as the
/// touch; a handling spike is shorter than the shortest touch's half, so it stays in the residual.
fn columns(t: f64, t0: f64, tau: f64, d: f64, span: f64, press: bool) -> [f64; NCOL] {
    if t > t0 {
        let r = (t - t0) / span;
        let (b1, b2) = if press && d >= MIN_PRESS_TOUCH_S { (bump_response(t - t0, tau, d), bump_response(t - t0, tau, 0.5 * d)) } else { (0.0, 0.0) };
        [1.0, ramp_rise(t - t0, tau, d), ramp_rise(t - t0, 4.0 * tau, d), r, r * r, b1, b2]
    } else {
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }
}

/// The touches long enough to carry a press column (s): a press over half of a shorter touch would
/// be as brief as a handling spike.
const MIN_PRESS_TOUCH_S: f64 = 0.5;
/// A hand's extra press is a fraction of the weight: a fitted press larger than this share of the
/// step is not taken as one (the step is scanned without the press columns).
const MAX_PRESS_SHARE: f64 = 0.12;

/// The first-order response (time constant τ) at x ≥ 0 to a unit sin² bump of force over [0, w].
fn bump_response(x: f64, tau: f64, w: f64) -> f64 {
    let at = |x: f64| {
        let om = 2.0 * std::f64::consts::PI / w;
        let q = om * tau;
        let e = (-x / tau).exp();
        0.5 * (1.0 - e) - 0.5 * ((om * x).cos() + q * (om * x).sin() - e) / (1.0 + q * q)
    };
    if x <= w {
        at(x)
    } else {
        at(w) * (-(x - w) / tau).exp()
    }
}

/// The first-order response (time constant τ) at x ≥ 0 after the start of a unit ramp of length d
/// (a step when d = 0).
fn ramp_rise(x: f64, tau: f64, d: f64) -> f64 {
    if d <= 0.0 {
        1.0 - (-x / tau).exp()
    } else if x < d {
        (x - tau * (1.0 - (-x / tau).exp())) / d
    } else {
        1.0 - tau / d * ((-(x - d) / tau).exp() - (-x / tau).exp())
    }
}

/// The touches tried (s): the load at once, or lowered by hand over these.
const TOUCHES_S: [f64; 4] = [0.0, 0.25, 0.5, 1.0];

const NCOL: usize = 7;

/// Robust (Huber) fit of the local model over onsets near `t0_s` and time constants around
/// `tau_s`; returns the residuals.
fn robust_residual(t: &[f64], v: &[f64], st: &EdgeStep, sigma: f64) -> Vec<f64> {
    let n = t.len();
    let k = 1.345 * sigma;
    let span = (t[n - 1] - t[0]).max(1e-9);
    let mut pre: Vec<f64> = (0..n).filter(|&j| t[j] < st.t0_s - 0.2).map(|j| v[j]).collect();
    let mut late: Vec<f64> = (0..n).filter(|&j| t[j] > st.t0_s + 3.0 * st.tau_s).map(|j| v[j]).collect();
    let a0 = if pre.is_empty() { v[0] } else { median(&mut pre) };
    let l0 = if late.is_empty() { v[n - 1] } else { median(&mut late) };
    let start = {
        let mut x = [0.0; NCOL];
        x[0] = a0;
        x[1] = l0 - a0;
        x
    };
    let mut cols = vec![[0.0f64; NCOL]; n];
    let model = |c: &[f64; NCOL], x: &[f64; NCOL]| c.iter().zip(x).map(|(a, b)| a * b).sum::<f64>();
    let fit = |t0: f64, tau: f64, d: f64, press: bool, cols: &mut Vec<[f64; NCOL]>| -> (f64, [f64; NCOL]) {
        for j in 0..n {
            cols[j] = columns(t[j], t0, tau, d, span, press);
        }
        let mut x = start;
        // Huber's loss: convex, so no fit may buy a wrong onset by calling the edge an outlier
        // (a redescending loss can), while a spike still weighs little
        for _ in 0..5 {
            let mut m = nalgebra::SMatrix::<f64, NCOL, NCOL>::zeros();
            let mut r = nalgebra::SVector::<f64, NCOL>::zeros();
            for j in 0..n {
                let w = huber(v[j] - model(&cols[j], &x), k).1;
                for a in 0..NCOL {
                    if cols[j][a] == 0.0 {
                        continue;
                    }
                    r[a] += w * cols[j][a] * v[j];
                    for b in 0..NCOL {
                        m[(a, b)] += w * cols[j][a] * cols[j][b];
                    }
                }
            }
            for a in 0..NCOL {
                m[(a, a)] += 1e-12 * (1.0 + m[(a, a)]);
            }
            match m.cholesky() {
                Some(ch) => {
                    let sol = ch.solve(&r);
                    x.iter_mut().zip(sol.iter()).for_each(|(a, b)| *a = *b);
                }
                None => break,
            }
        }
        let obj = (0..n).map(|j| huber(v[j] - model(&cols[j], &x), k).0).sum();
        (obj, x)
    };
    let mut best = (f64::INFINITY, st.t0_s, st.tau_s, start);
    let mut touch = 0.0;
    // coarse onsets and touches at the part-1 τ (a touch starts about half of it earlier), then
    // τ, then fine onsets. The touch is chosen by its ramp alone (a press column could take up a
    // spike and call it a touch); a touch that long gets the press columns from then on
    for d in TOUCHES_S {
        for g in 0..=30 {
            let t0 = st.t0_s - 0.3 - 0.5 * d + 0.02 * g as f64;
            let (o, x) = fit(t0, st.tau_s, d, false, &mut cols);
            if o < best.0 {
                best = (o, t0, st.tau_s, x);
                touch = d;
            }
        }
    }
    let mut press = touch >= MIN_PRESS_TOUCH_S;
    if press {
        let (o, x) = fit(best.1, best.2, touch, true, &mut cols);
        best = (o, best.1, best.2, x);
    }
    for f in [0.5, 0.7, 1.4, 2.0] {
        let (o, x) = fit(best.1, f * st.tau_s, touch, press, &mut cols);
        if o < best.0 {
            best = (o, best.1, f * st.tau_s, x);
        }
    }
    // finer: τ within ±10 %, onsets within ±0.02 s, τ within ±3 % (a large step's residual is
    // ΔV·e⁻¹·Δτ/τ at t = τ, far above the noise for a coarse τ)
    for (span, n_tau, dt0, n_t0) in [(0.10, 10, 0.0, 0), (0.0, 0, 0.0025, 16), (0.03, 12, 0.0, 0), (0.0, 0, 0.001, 10)] {
        let (t_c, tau_c) = (best.1, best.2);
        for g in 0..=n_tau {
            let tau = tau_c * (1.0 - span + 2.0 * span * g as f64 / n_tau.max(1) as f64);
            let (o, x) = fit(t_c, tau, touch, press, &mut cols);
            if o < best.0 {
                best = (o, t_c, tau, x);
            }
        }
        for g in 0..=n_t0 {
            let t0 = t_c - 0.5 * dt0 * n_t0 as f64 + dt0 * g as f64;
            let (o, x) = fit(t0, best.2, touch, press, &mut cols);
            if o < best.0 {
                best = (o, t0, best.2, x);
            }
        }
    }
    let (_, t0, tau, mut x) = best;
    // a press larger than a hand's is not one: the step is scanned with the ramp alone
    let bump = (0..n).map(|j| {
        let c = columns(t[j], t0, tau, touch, span, press);
        (c[5] * x[5] + c[6] * x[6]).abs()
    });
    if press && bump.fold(0.0, f64::max) > MAX_PRESS_SHARE * x[1].abs() {
        press = false;
        x = fit(t0, tau, touch, false, &mut cols).1;
    }
    (0..n).map(|j| v[j] - model(&columns(t[j], t0, tau, touch, span, press), &x)).collect()
}

/// One recording as the edge detector sees it: its samples, noise and steps.
pub struct EdgeSeries<'a> {
    pub t: &'a [f64],
    pub v: &'a [f64],
    pub steps: Vec<EdgeStep>,
    pub sigma: f64,
}

/// One step's high-passed residual from its robust first-order fit.
struct EdgeResidual {
    t: Vec<f64>,
    rr: Vec<f64>,
}

/// Spike windows at the steps' edges of one recording (raw samples, their noise `sigma`).
pub fn detect(t: &[f64], v: &[f64], steps: &[EdgeStep], sigma: f64, max_spike_s: f64) -> Vec<SpikeWindow> {
    detect_all(&[EdgeSeries { t, v, steps: steps.to_vec(), sigma }], max_spike_s).pop().unwrap_or_default()
}

/// Spike windows at the steps' edges of every recording of a data set.
pub fn detect_all(series: &[EdgeSeries], max_spike_s: f64) -> Vec<Vec<SpikeWindow>> {
    series.iter().map(|s| edge_residuals(s).into_iter().flat_map(|e| scan(&e.t, &e.rr, s.sigma, max_spike_s)).collect()).collect()
}

/// The residuals of one recording's steps (robust first-order fit, the slow part removed).
fn edge_residuals(s: &EdgeSeries) -> Vec<EdgeResidual> {
    let (t, v, sigma) = (s.t, s.v, s.sigma);
    if t.len() < 8 || sigma <= 0.0 {
        return vec![];
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let half = ((0.5 / dt).round() as usize).max(2);
    let mut out = Vec::new();
    for st in &s.steps {
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
        out.push(EdgeResidual { t: tt, rr });
    }
    out
}

/// The windows where a step's residual stands off zero (box filters of 0.03–0.25 s).
fn scan(tt: &[f64], rr: &[f64], sigma: f64, max_spike_s: f64) -> Vec<SpikeWindow> {
    let mut out = Vec::new();
    let n = rr.len();
    if n < 2 {
        return out;
    }
    let dt = (tt[n - 1] - tt[0]) / (n - 1) as f64;
    let mut widths: Vec<usize> = [0.03, 0.05, 0.09, 0.15, 0.25].iter().map(|w| ((w / dt).round() as usize).max(1)).collect();
    widths.dedup();
    let mut prefix = vec![0.0; n + 1];
    for j in 0..n {
        prefix[j + 1] = prefix[j] + rr[j];
    }
    let mut hit = vec![false; n];
    for &w in &widths {
        if w > n {
            continue;
        }
        // noise with memory (a slow correlated part) makes box sums wider than σ·√w: their own
        // robust spread over the window is the scale when it is larger
        let sums: Vec<f64> = (0..=n - w).map(|j| prefix[j + w] - prefix[j]).collect();
        let spread = {
            let mut a: Vec<f64> = sums.iter().map(|x| x.abs()).collect();
            1.4826 * median(&mut a)
        };
        // (white noise gives spread ≈ σ·√w; the spread's own sampling error is allowed for, so a
        // spike is not missed for it)
        let white = sigma * (w as f64).sqrt();
        let scale = white.max(spread / COLOURED);
        for (j, sum) in sums.iter().enumerate() {
            if (sum / scale).abs() >= MIN_Z {
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
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(spike: f64, sign: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|&x| if x < 10.0 { 0.5 } else { 0.5 - 0.3 * (1.0 - (-(x - 10.0) / 0.6f64).exp()) }).collect();
        let noise = super::super::test_noise(v.len(), 0.003, 11);
        for (i, x) in v.iter_mut().enumerate() {
            *x += noise[i];
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
        assert!(detect(&t, &v, std::slice::from_ref(&st), 0.003, 1.0).is_empty());
        // a slower second relaxation the first-order curve does not have
        for (i, x) in v.iter_mut().enumerate() {
            if t[i] > 10.0 {
                *x += 0.03 * ((-(t[i] - 10.0) / 8.0).exp() - (-(t[i] - 10.0) / 0.6).exp());
            }
        }
        assert!(detect(&t, &v, &[st], 0.003, 1.0).is_empty());
    }
}
