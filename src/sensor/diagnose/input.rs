//! The load as it is applied (issue 15, item 1). A hand's weight lands at once, around an onset
//! fitted near the logged change; an actuator travels for seconds. For an actuator's recordings
//! the first-order steps are driven by a ramp ending near the logged change: its duration, end
//! and shape (constant speed or an S-curve) are chosen once per data set by the baseline's own
//! cross-validation, and each step's duration and the read-out's curvature along its ramp are
//! fitted on that step's samples around the ramp.

use super::*;
use crate::sensor::preprocess::{Ramp, Series};

/// How a step's load is applied: over a ramp of `ramp_s` (0: at once), an S-curve or at a
/// constant speed, read through a read-out whose curvature along the step is `curve`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct LoadIn {
    pub ramp_s: f64,
    pub smooth: bool,
    /// The read-out's bend along the ramp: the response's input is w = s + curve·s·(1 − s) of the
    /// load's course s (a divider's voltage rises faster at the start of a loading ramp).
    pub curve: f64,
}

/// Degree + 1 of the ramp's polynomials (an S-curve's square is of degree 6).
const DEG: usize = 7;

/// The normalised course of the response's input over the ramp, as coefficients in x = (t −
/// start)/ramp (ascending): the load's course s (x, or 3x² − 2x³) through the read-out's bend,
/// s + c·s·(1 − s). |c| ≤ 1 keeps it monotone.
fn course(smooth: bool, c: f64) -> [f64; DEG] {
    let mut s = [0.0; DEG];
    if smooth {
        s[2] = 3.0;
        s[3] = -2.0;
    } else {
        s[1] = 1.0;
    }
    let mut w = s.map(|x| (1.0 + c) * x);
    for i in 0..DEG {
        for j in 0..DEG - i {
            w[i + j] -= c * s[i] * s[j];
        }
    }
    w
}

fn horner(p: &[f64; DEG], x: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, &c| acc * x + c)
}

/// The first-order lag (τ) of an input that follows the polynomial `w` in x over a ramp of `d`
/// ending at `end`, from 0 before it: on the ramp P(x) − P(0)·e^(−(t − start)/τ) with P =
/// Σ (−τ/d)^k w⁽ᵏ⁾ (exact for a polynomial: τP′ + P = w); after it, a first-order approach to w(1).
/// For τ over [`SLOW_LAG`] × d that difference of large terms (P(0) grows as (τ/d)⁶) loses its
/// digits, and the ramp's part is the integral (d/τ)∫₀ˣ w(s)·e^(−(x − s)d/τ) ds instead, by
/// 8-point Gauss–Legendre (exact for w, and the exponential varies slowly over the ramp).
#[derive(Clone)]
struct Lag {
    p: [f64; DEG],
    /// The response at the ramp's end, and the input's end value w(1).
    on_end: f64,
    w1: f64,
    /// For a slow lag: the input and τ/d, integrated on the ramp.
    slow: Option<([f64; DEG], f64)>,
}

/// τ/d above which the ramp's lag is integrated (its polynomial form cancels).
const SLOW_LAG: f64 = 2.0;

/// Gauss–Legendre nodes and weights on [−1, 1] (8 points, by symmetry).
const GL_X: [f64; 4] = [0.183_434_642_495_649_8, 0.525_532_409_916_329, 0.796_666_477_413_626_7, 0.960_289_856_497_536_3];
const GL_W: [f64; 4] = [0.362_683_783_378_362, 0.313_706_645_877_887_3, 0.222_381_034_453_374_5, 0.101_228_536_290_376_3];

/// (1/a)∫₀ˣ w(s)·e^(−(x − s)/a) ds by 8-point Gauss–Legendre.
fn lag_integral(w: &[f64; DEG], a: f64, x: f64) -> f64 {
    let h = 0.5 * x;
    let f = |s: f64| horner(w, s) * (-(x - s) / a).exp();
    let sum: f64 = GL_X.iter().zip(&GL_W).map(|(&u, &g)| g * (f(h * (1.0 - u)) + f(h * (1.0 + u)))).sum();
    sum * h / a
}

impl Lag {
    fn new(w: &[f64; DEG], tau: f64, d: f64) -> Lag {
        let a = tau / d;
        let (mut p, mut dk, mut f) = ([0.0; DEG], *w, 1.0);
        for _ in 0..DEG {
            for i in 0..DEG {
                p[i] += f * dk[i];
            }
            dk = std::array::from_fn(|i| if i + 1 < DEG { (i + 1) as f64 * dk[i + 1] } else { 0.0 });
            f *= -a;
        }
        let slow = (a > SLOW_LAG).then_some((*w, a));
        let on_end = if slow.is_some() { lag_integral(w, a, 1.0) } else { horner(&p, 1.0) - p[0] * catalogue::decay(1.0 / a) };
        Lag { on_end, w1: horner(w, 1.0), p, slow }
    }
    /// The response given x = (t − start)/d and the decay e^(−(t − start)/τ) on the ramp or
    /// e^(−(t − end)/τ) after it.
    fn at(&self, x: f64, decay: f64) -> f64 {
        if x <= 0.0 {
            0.0
        } else if x <= 1.0 {
            match &self.slow {
                Some((w, a)) => lag_integral(w, *a, x),
                None => horner(&self.p, x) - self.p[0] * decay,
            }
        } else {
            self.w1 + (self.on_end - self.w1) * decay
        }
    }
}

/// [`Lag::at`]'s arguments at time t.
fn lag_args(t: f64, end: f64, tau: f64, d: f64) -> (f64, f64) {
    let start = end - d;
    let x = (t - start) / d;
    if x <= 0.0 {
        (x, 1.0)
    } else if x <= 1.0 {
        (x, catalogue::decay((t - start) / tau))
    } else {
        (x, catalogue::decay((t - end) / tau))
    }
}

/// The lag of a ramp's course through the read-out's bend ([`course`]), remembered: the model's
/// rows ask for the same few (step, τ) over and over (a direct-mapped cache per thread; the same
/// numbers as computing it afresh).
fn course_lag(ramp: LoadIn, tau: f64) -> Lag {
    type Key = (bool, u64, u64, u64);
    thread_local! {
        static CACHE: std::cell::RefCell<Vec<Option<(Key, Lag)>>> = std::cell::RefCell::new(vec![None; 4096]);
    }
    let key: Key = (ramp.smooth, ramp.curve.to_bits(), tau.to_bits(), ramp.ramp_s.to_bits());
    let h = (key.1 ^ key.2.rotate_left(17) ^ key.3.rotate_left(31) ^ u64::from(key.0)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 52;
    CACHE.with(|c| {
        let mut c = c.borrow_mut();
        let slot = &mut c[h as usize];
        match slot {
            Some((k, lag)) if *k == key => lag.clone(),
            _ => {
                let lag = Lag::new(&course(ramp.smooth, ramp.curve), tau, ramp.ramp_s);
                *slot = Some((key, lag.clone()));
                lag
            }
        }
    })
}

/// The first-order response to the load as applied: a step at t0 ([`block_rise`]) or, with a
/// ramp of `ramp` s ending at t0 (an actuator's travel), the ramp's response averaged over the
/// filtered sample's span [t − h, t + h] by Simpson's rule (approximate where the span holds the
/// ramp's start or end, whose response bends there; h is a fraction of a second, the ramps seconds).
#[inline]
pub(super) fn rise(t: f64, t0: f64, tau: f64, h: f64, ramp: LoadIn) -> f64 {
    if ramp.ramp_s <= 0.0 {
        return block_rise(t, t0, tau, h);
    }
    // settled (as block_rise): the input's course ends at 1 whatever its shape
    if t - h - t0 > SETTLED * tau {
        return 1.0;
    }
    if t + h <= t0 - ramp.ramp_s {
        return 0.0;
    }
    if h <= 0.0 {
        return ramp_rise(t, t0, tau, ramp);
    }
    let lag = course_lag(ramp, tau);
    let at = |t: f64| {
        let (x, a) = lag_args(t, t0, tau, ramp.ramp_s);
        lag.at(x, a)
    };
    (at(t - h) + 4.0 * at(t) + at(t + h)) / 6.0
}

/// The first-order response at t to a load ramping from t0 − ramp to t0 (its course and the
/// read-out's bend as [`course`]), normalised to reach 1.
pub(super) fn ramp_rise(t: f64, end: f64, tau: f64, ramp: LoadIn) -> f64 {
    let (x, a) = lag_args(t, end, tau, ramp.ramp_s);
    course_lag(ramp, tau).at(x, a)
}

/// A relaxation kernel of time constant τ driven by the ramped load: ∫ w′(s)·e^(−(t − s)/τ) ds,
/// which is the input's course w less its lag, w(t) − [`ramp_rise`] (by parts).
/// `w`: the input's course at t ([`course_at`], the same for every τ).
pub(super) fn ramp_kernel(t: f64, end: f64, tau: f64, ramp: LoadIn, w: f64) -> f64 {
    if t > end && (t - end) / tau > SETTLED {
        return 0.0;
    }
    w - ramp_rise(t, end, tau, ramp)
}

/// The input's course at t over a ramp ending at `end`: 0 before it, 1 after it.
pub(super) fn course_at(t: f64, end: f64, ramp: LoadIn) -> f64 {
    let x = (t - (end - ramp.ramp_s)) / ramp.ramp_s;
    if x <= 0.0 {
        0.0
    } else if x >= 1.0 {
        1.0
    } else {
        horner(&course(ramp.smooth, ramp.curve), x)
    }
}

/// ∂/∂ln τ of a ramped [`rise`] (central difference).
pub(super) fn ramp_dln_tau(t: f64, t0: f64, tau: f64, h: f64, ramp: LoadIn) -> f64 {
    if t - h - t0 > SETTLED * tau * 0.9 || t + h <= t0 - ramp.ramp_s {
        return 0.0;
    }
    let e = 1e-4f64;
    (rise(t, t0, tau * e.exp(), h, ramp) - rise(t, t0, tau * (-e).exp(), h, ramp)) / (2.0 * e)
}

/// ∂/∂t0 of a ramped [`rise`] (central difference).
pub(super) fn ramp_dt0(t: f64, t0: f64, tau: f64, h: f64, ramp: LoadIn) -> f64 {
    if t - h - t0 > SETTLED * tau * 0.9 || t + h <= t0 - ramp.ramp_s {
        return 0.0;
    }
    let e = 1e-4;
    (rise(t, t0 + e, tau, h, ramp) - rise(t, t0 - e, tau, h, ramp)) / (2.0 * e)
}

/// The ramp durations tried for one step, as shares of the data set's.
const STEP_RAMP_SHARES: [f64; 12] = [0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.15, 1.3, 1.5, 1.75, 2.0];

/// One step's ramp: where it ends (the data set's `end`, moved by up to ±0.4 s: the log's own
/// timing), its duration (s), the share of the data set's `r` whose first-order response, from the
/// part-1 fit's level before it, change and τ (`fit`), best matches the samples from before the
/// longest such ramp to a few τ after its end (least squares; the ramp starts after the previous
/// ramp's end, 90 % of the time between them at most, and the samples stop where the next ramp
/// nominally starts), and the read-out's bend along it (linear given the rest, within ±1).
pub(super) fn step_ramp(series: &Series, end: f64, (v0, k, tau): (f64, f64, f64), r: Ramp, (prev_end_s, next_start_s): (f64, f64)) -> (f64, LoadIn) {
    let shared_s = r.duration_s;
    let longest_s = (STEP_RAMP_SHARES[STEP_RAMP_SHARES.len() - 1] * shared_s).min(0.9 * (end - prev_end_s) - END_SHIFTS_S[END_SHIFTS_S.len() - 1]);
    let until_s = (end + (3.0 * tau).clamp(0.5, 10.0)).min(next_start_s).max(end + 0.5);
    let idx: Vec<usize> = (0..series.t.len()).filter(|&j| series.ok[j] && series.t[j] >= end - longest_s - 0.5 && series.t[j] <= until_s).collect();
    let (straight, bend) = (course(r.smooth, 0.0), course(r.smooth, 1.0));
    let bend: [f64; DEG] = std::array::from_fn(|i| bend[i] - straight[i]);
    // the bend that fits best with the ramp (end, duration d), and the squared error with it
    let fit = |end: f64, d: f64| -> (f64, f64) {
        let (mut see, mut seb, mut sbb) = (0.0, 0.0, 0.0);
        let (ls, lb) = (Lag::new(&straight, tau, d), Lag::new(&bend, tau, d));
        for &j in &idx {
            let (x, p) = lag_args(series.t[j], end, tau, d);
            let (e, b) = (series.v[j] - v0 - k * ls.at(x, p), k * lb.at(x, p));
            see += e * e;
            seb += e * b;
            sbb += b * b;
        }
        let c = if sbb > 0.0 { (seb / sbb).clamp(-1.0, 1.0) } else { 0.0 };
        (see - 2.0 * c * seb + c * c * sbb, c)
    };
    let at = |d: f64, c: f64| LoadIn { ramp_s: d, smooth: r.smooth, curve: c };
    let grid: Vec<f64> = STEP_RAMP_SHARES.iter().map(|a| a * shared_s).filter(|&d| d <= longest_s).collect();
    // the first of the best, each point fitted once
    let first = |xs: &[f64], sse: &dyn Fn(f64) -> f64| -> Option<(usize, f64)> { xs.iter().map(|&x| sse(x)).enumerate().min_by(|a, b| a.1.total_cmp(&b.1)) };
    // too short a hold for any share of the data set's ramp: the shortest that fits, straight
    let Some((b, _)) = first(&grid, &|d| fit(end, d).0) else { return (end, at(longest_s.max(STEP_RAMP_SHARES[0] * shared_s).min(shared_s), 0.0)) };
    let d0 = grid[b];
    // the end at the best grid duration, then the duration refined between the grid's neighbours
    // by golden section (kept only when it fits better than the grid's best)
    let shifts: Vec<f64> = END_SHIFTS_S.iter().map(|s| end + s).collect();
    let end = first(&shifts, &|e| fit(e, d0).0).map(|(i, _)| shifts[i]).unwrap_or(end);
    let br = crate::sensor::golden::golden(|d| fit(end, d).0, grid[b.saturating_sub(1)], grid[(b + 1).min(grid.len() - 1)], 14, 0.0);
    let mid = 0.5 * (br.a + br.b);
    let (on_mid, on_grid) = (fit(end, mid), fit(end, d0));
    let (d, c) = if on_mid.0 <= on_grid.0 { (mid, on_mid.1) } else { (d0, on_grid.1) };
    (end, at(d, c))
}

/// How far a step's ramp may end from the data set's end (s): the log's timing of each step.
const END_SHIFTS_S: [f64; 9] = [-0.4, -0.3, -0.2, -0.1, 0.0, 0.1, 0.2, 0.3, 0.4];

#[cfg(test)]
mod tests {
    use super::*;

    /// A ramped load's response is the first-order lag of the ramp (an Euler integration of
    /// τ·y′ = w − y at 1 µs), at a constant speed and on an S-curve, straight and through a bent
    /// read-out, before, on and after the ramp; a ramp of zero is the step; and the shapes differ
    /// (the test can fail).
    #[test]
    fn a_ramped_rise_is_the_lag_of_the_ramp() {
        let (end, tau, d) = (10.0, 0.7, 3.0);
        // a slow lag (τ/d = 50 and 500) is integrated, not cancelled: checked at the ramp's end
        for (tau, d) in [(1.0, 0.02), (1.0, 0.002)] {
            let input = LoadIn { ramp_s: d, smooth: true, curve: 0.8 };
            let w = |x: f64| {
                let s = x * x * (3.0 - 2.0 * x);
                s + 0.8 * s * (1.0 - s)
            };
            let (mut y, mut x, h) = (0.0, 0.0, 1e-6);
            while x < 1.0 {
                y += h * (w(x + 0.5 * h) - y) * d / tau;
                x += h;
            }
            let got = ramp_rise(end, end, tau, input);
            assert!((got - y).abs() < 1e-6 * y.abs().max(1e-9) + 1e-12, "τ/d {}: {got} vs {y}", tau / d);
            assert!(got > 0.0 && got < d / tau, "τ/d {}: {got}", tau / d);
        }
        for (smooth, c) in [(false, 0.0), (true, 0.0), (false, 0.4), (true, -0.7)] {
            let input = LoadIn { ramp_s: d, smooth, curve: c };
            let w = |t: f64| {
                let x = ((t - (end - d)) / d).clamp(0.0, 1.0);
                let s = if smooth { x * x * (3.0 - 2.0 * x) } else { x };
                s + c * s * (1.0 - s)
            };
            let (mut y, mut t, h) = (0.0, end - d - 0.5, 1e-6);
            for probe in [6.9, 7.5, 8.8, 10.0, 10.4, 13.0] {
                while t < probe {
                    y += h * (w(t) - y) / tau;
                    t += h;
                }
                assert!((ramp_rise(t, end, tau, input) - y).abs() < 1e-5, "smooth {smooth} c {c} t {t}: {} vs {y}", ramp_rise(t, end, tau, input));
            }
        }
        assert_eq!(rise(11.0, end, tau, 0.0, LoadIn::default()), block_rise(11.0, end, tau, 0.0));
        let at = |smooth, curve| ramp_rise(8.0, end, tau, LoadIn { ramp_s: d, smooth, curve });
        assert!((at(false, 0.0) - at(true, 0.0)).abs() > 0.05 && (at(false, 0.0) - at(false, 0.5)).abs() > 0.05);
    }
}
