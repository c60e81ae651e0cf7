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

use super::super::preprocess::{median, SpikeWindow, Step};

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
    /// The read-out's map between the step's two levels, when the recording names its read-out:
    /// u = 1 + Rm·G of a divider (u = G for a resistance) before and after the step, from the
    /// settled levels (`read_out_course`). The level at a share s of the way in conductance is then
    /// a share u_b·s / (u_a + (u_b − u_a)·s) of the way in the read-out. None: straight.
    pub through: Option<[f64; 2]>,
    /// The time constant of the level the step leaves, when known (the fit of the step before it;
    /// for a recording's first step, of the last step that ends at its load): during a touch the
    /// time constant may glide with the load from it to the step's own.
    pub tau_before_s: Option<f64>,
}

/// The share of the way in the read-out at a share `s` of the way in the sensor's conductance,
/// between u = `u[0]` and `u[1]` (see `EdgeStep::through`).
fn through_divider(u: [f64; 2], s: f64) -> f64 {
    s * u[1] / (u[0] + (u[1] - u[0]) * s)
}

/// Where the read-out's map bends a step (see `EdgeStep::through`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Bend {
    None,
    /// The read-out relaxes at first order toward the divider's level as the conductance ramps in:
    /// the touch's course is bent.
    Input([f64; 2]),
    /// The conductance relaxes at first order and the divider bends what it relaxes.
    Output([f64; 2]),
}

/// The shape of a step's rise. `Straight`: the read-out relaxes at first order, with one time
/// constant, toward a level that moves linearly with the load. `Course`: what the recording says of
/// itself, with no free parameter: the divider's bend, a time constant that glides with the load
/// during the touch from the left level's (`tau_from`) to the step's own, and a touch at constant
/// speed or `smooth` (an S-curve, 3s² − 2s³: the hand slows at both ends).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    Straight,
    Course { bend: Bend, tau_from: Option<f64>, smooth: bool },
}

/// The rise of a step of shape `course` (not `Straight`) at the times `x` after its onset (s,
/// ascending), time constant τ after a touch of d seconds: the first-order response integrated
/// exactly over sub-steps of at most 5 ms (the input linear and τ constant within each), then
/// relaxing at τ.
fn course_rises(x: &[f64], tau: f64, d: f64, bend: Bend, tau_from: Option<f64>, smooth: bool) -> Vec<f64> {
    // the load's share of the way at a share s of the touch
    let load = |s: f64| if smooth { s * s * (3.0 - 2.0 * s) } else { s };
    let input = |s: f64| match bend {
        Bend::Input(u) => through_divider(u, load(s)),
        _ => load(s),
    };
    let tau_at = |s: f64| tau_from.map_or(tau, |ta| ta + (tau - ta) * load(s)).max(1e-6);
    // the response at the end of the touch, and on a grid within it
    let m = if d > 0.0 { ((d / 0.005).ceil() as usize).max(20) } else { 0 };
    let h = if m > 0 { d / m as f64 } else { 0.0 };
    let mut grid = Vec::with_capacity(m + 1);
    let mut y = 0.0;
    grid.push(0.0);
    for i in 0..m {
        let (s0, s1) = (i as f64 / m as f64, (i + 1) as f64 / m as f64);
        let (u0, u1) = (input(s0), input(s1));
        let tk = tau_at(0.5 * (s0 + s1));
        let e = (-h / tk).exp();
        y = u1 + (y - u0) * e - (u1 - u0) * tk / h * (1.0 - e);
        grid.push(y);
    }
    let at_end = y;
    let out = |r: f64| match bend {
        Bend::Output(u) => through_divider(u, r),
        _ => r,
    };
    x.iter()
        .map(|&xj| {
            let r = if xj <= 0.0 {
                0.0
            } else if xj < d {
                let q = xj / h;
                let i = (q.floor() as usize).min(m - 1);
                grid[i] + (grid[i + 1] - grid[i]) * (q - i as f64)
            } else {
                1.0 + (at_end - 1.0) * (-(xj - d) / tau).exp()
            };
            out(r)
        })
        .collect()
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
/// `rise`: the step's own rise at t (of its shape; `ramp_rise` when straight).
fn columns(t: f64, t0: f64, tau: f64, d: f64, span: f64, press: bool, rise: f64) -> [f64; NCOL] {
    if t > t0 {
        let r = (t - t0) / span;
        let (b1, b2) = if press && d >= MIN_PRESS_TOUCH_S { (bump_response(t - t0, tau, d), bump_response(t - t0, tau, 0.5 * d)) } else { (0.0, 0.0) };
        [1.0, rise, ramp_rise(t - t0, 4.0 * tau, d), r, r * r, b1, b2]
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

/// Bends smaller than this are straight (the level's departure from the chord at mid-way is a
/// quarter of this share of the step).
const MIN_BEND: f64 = 0.02;

/// One step's samples and what its local fits share: Huber's knee, the window's span, the start.
struct Local<'a> {
    t: &'a [f64],
    v: &'a [f64],
    k: f64,
    span: f64,
    start: [f64; NCOL],
}

/// A local fit: its Huber objective, onset, τ, touch, press columns and coefficients.
#[derive(Clone, Copy)]
struct LocalFit {
    obj: f64,
    t0: f64,
    tau: f64,
    touch: f64,
    press: bool,
    x: [f64; NCOL],
}

fn model(c: &[f64; NCOL], x: &[f64; NCOL]) -> f64 {
    c.iter().zip(x).map(|(a, b)| a * b).sum::<f64>()
}

impl Local<'_> {
    /// The step's own rise at every sample (onset t0, τ, touch d, its shape).
    fn rises(&self, t0: f64, tau: f64, d: f64, shape: Shape) -> Vec<f64> {
        match shape {
            Shape::Straight => self.t.iter().map(|&tj| if tj > t0 { ramp_rise(tj - t0, tau, d) } else { 0.0 }).collect(),
            Shape::Course { bend, tau_from, smooth } => course_rises(&self.t.iter().map(|&tj| tj - t0).collect::<Vec<_>>(), tau, d, bend, tau_from, smooth),
        }
    }

    /// The local model's columns at every sample.
    fn columns(&self, t0: f64, tau: f64, d: f64, press: bool, shape: Shape) -> Vec<[f64; NCOL]> {
        let rises = self.rises(t0, tau, d, shape);
        self.t.iter().zip(rises).map(|(&tj, r)| columns(tj, t0, tau, d, self.span, press, r)).collect()
    }

    /// The Huber fit (iteratively reweighted) at one onset, τ, touch and shape.
    fn fit(&self, t0: f64, tau: f64, d: f64, press: bool, shape: Shape) -> (f64, [f64; NCOL]) {
        let (v, n) = (self.v, self.t.len());
        let cols = self.columns(t0, tau, d, press, shape);
        let mut x = self.start;
        // Huber's loss: convex, so no fit may buy a wrong onset by calling the edge an outlier
        // (a redescending loss can), while a spike still weighs little
        for _ in 0..5 {
            let mut m = nalgebra::SMatrix::<f64, NCOL, NCOL>::zeros();
            let mut r = nalgebra::SVector::<f64, NCOL>::zeros();
            for j in 0..n {
                let w = huber(v[j] - model(&cols[j], &x), self.k).1;
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
        let obj = (0..n).map(|j| huber(v[j] - model(&cols[j], &x), self.k).0).sum();
        (obj, x)
    }

    /// Coarse onsets and touches at the part-1 τ (a touch starts about half of it earlier), then
    /// τ, then fine onsets, for one shape. The touch is chosen by its ramp alone (a press column
    /// could take up a spike and call it a touch); a touch that long gets the press columns from
    /// then on, unless the press it fits is larger than a hand's.
    fn search(&self, st: &EdgeStep, shape: Shape) -> LocalFit {
        let mut best = LocalFit { obj: f64::INFINITY, t0: st.t0_s, tau: st.tau_s, touch: 0.0, press: false, x: self.start };
        for d in TOUCHES_S {
            for g in 0..=30 {
                let t0 = st.t0_s - 0.3 - 0.5 * d + 0.02 * g as f64;
                let (obj, x) = self.fit(t0, st.tau_s, d, false, shape);
                if obj < best.obj {
                    best = LocalFit { obj, t0, touch: d, x, ..best };
                }
            }
        }
        best.press = best.touch >= MIN_PRESS_TOUCH_S;
        if best.press {
            let (obj, x) = self.fit(best.t0, best.tau, best.touch, true, shape);
            best = LocalFit { obj, x, ..best };
        }
        let try_at = |best: &mut LocalFit, t0: f64, tau: f64| {
            let (obj, x) = self.fit(t0, tau, best.touch, best.press, shape);
            if obj < best.obj {
                *best = LocalFit { obj, t0, tau, x, ..*best };
            }
        };
        for f in [0.5, 0.7, 1.4, 2.0] {
            let t0 = best.t0;
            try_at(&mut best, t0, f * st.tau_s);
        }
        // finer: τ within ±10 %, onsets within ±0.02 s, τ within ±3 % (a large step's residual is
        // ΔV·e⁻¹·Δτ/τ at t = τ, far above the noise for a coarse τ)
        for (span, n_tau, dt0, n_t0) in [(0.10, 10, 0.0, 0), (0.0, 0, 0.0025, 16), (0.03, 12, 0.0, 0), (0.0, 0, 0.001, 10)] {
            let (t_c, tau_c) = (best.t0, best.tau);
            for g in 0..=n_tau {
                try_at(&mut best, t_c, tau_c * (1.0 - span + 2.0 * span * g as f64 / n_tau.max(1) as f64));
            }
            for g in 0..=n_t0 {
                let tau = best.tau;
                try_at(&mut best, t_c - 0.5 * dt0 * n_t0 as f64 + dt0 * g as f64, tau);
            }
        }
        // a press larger than a hand's is not one: the step is scanned with the ramp alone
        if best.press {
            let bump = self.columns(best.t0, best.tau, best.touch, best.press, shape).into_iter().map(|c| (c[5] * best.x[5] + c[6] * best.x[6]).abs());
            if bump.fold(0.0, f64::max) > MAX_PRESS_SHARE * best.x[1].abs() {
                let (obj, x) = self.fit(best.t0, best.tau, best.touch, false, shape);
                best = LocalFit { obj, press: false, x, ..best };
            }
        }
        best
    }
}

impl<'a> Local<'a> {
    /// One step's samples, their noise and the start of its fits: the level before the onset and
    /// the step to the level after 3τ (medians).
    fn new(t: &'a [f64], v: &'a [f64], st: &EdgeStep, sigma: f64) -> Self {
        let n = t.len();
        let mut pre: Vec<f64> = (0..n).filter(|&j| t[j] < st.t0_s - 0.2).map(|j| v[j]).collect();
        let mut late: Vec<f64> = (0..n).filter(|&j| t[j] > st.t0_s + 3.0 * st.tau_s).map(|j| v[j]).collect();
        let a0 = if pre.is_empty() { v[0] } else { median(&mut pre) };
        let l0 = if late.is_empty() { v[n - 1] } else { median(&mut late) };
        let mut start = [0.0; NCOL];
        start[0] = a0;
        start[1] = l0 - a0;
        Local { t, v, k: 1.345 * sigma, span: (t[n - 1] - t[0]).max(1e-9), start }
    }
}

/// Robust (Huber) fit of the local model of one shape over onsets near `t0_s` and time constants
/// around `tau_s`; returns its objective and the residuals.
fn robust_residual(local: &Local, st: &EdgeStep, shape: Shape) -> (f64, Vec<f64>) {
    let best = local.search(st, shape);
    let cols = local.columns(best.t0, best.tau, best.touch, best.press, shape);
    (best.obj, local.v.iter().zip(&cols).map(|(vj, c)| vj - model(c, &best.x)).collect())
}

/// The other shapes a step may take, from what the recording says of it (its read-out's bend, the
/// time constant of the level it leaves): tried only where the straight one leaves a spike or a
/// misfit.
fn courses(st: &EdgeStep) -> Vec<Shape> {
    let bends: Vec<Bend> = match st.through {
        Some(u) if (through_divider(u, 0.5) - 0.5).abs() >= MIN_BEND / 4.0 => vec![Bend::None, Bend::Input(u), Bend::Output(u)],
        _ => vec![Bend::None],
    };
    let glides: Vec<Option<f64>> = match st.tau_before_s {
        Some(ta) if ta.is_finite() && ta > 0.0 && ((ta - st.tau_s) / st.tau_s).abs() >= MIN_GLIDE => vec![None, Some(ta)],
        _ => vec![None],
    };
    let mut out = Vec::new();
    for smooth in [false, true] {
        for &bend in &bends {
            for &tau_from in &glides {
                // the straight shape at constant speed is `Straight`
                if smooth || bend != Bend::None || tau_from.is_some() {
                    out.push(Shape::Course { bend, tau_from, smooth });
                }
            }
        }
    }
    out
}

/// A glide of the time constant smaller than this share is none.
const MIN_GLIDE: f64 = 0.1;

/// The level a hold settles to: the median of the samples in [from, to] (at least 5).
fn settled(t: &[f64], v: &[f64], from: f64, to: f64) -> Option<f64> {
    let mut w: Vec<f64> = t.iter().zip(v).filter(|(&tj, _)| tj >= from && tj <= to).map(|(_, &x)| x).collect();
    (w.len() >= 5).then(|| median(&mut w))
}

/// Each step's `through` (u before and after it): the level before the step (the median of 3.0–
/// 1.2 s before its logged change, before any touch) and the level its hold settles to (the
/// median of its last 2 s, or of its last third when shorter), each through the read-out's
/// inverse `to_u`. None where a level cannot be read or lies outside the read-out's range.
pub fn read_out_course(t: &[f64], v: &[f64], steps: &[Step], to_u: impl Fn(f64) -> Option<f64>) -> Vec<Option<[f64; 2]>> {
    steps
        .iter()
        .map(|s| {
            let before = settled(t, v, s.t_log - 3.0, s.t_log - 1.2)?;
            let after = settled(t, v, s.t_end - (2.0f64).min((s.t_end - s.t_log) / 3.0), s.t_end)?;
            let (ua, ub) = (to_u(before)?, to_u(after)?);
            (ua.is_finite() && ub.is_finite() && ua > 0.0 && ub > 0.0).then_some([ua, ub])
        })
        .collect()
}

/// One recording as the edge detector sees it: its samples, noise and steps.
pub struct EdgeSeries<'a> {
    pub t: &'a [f64],
    pub v: &'a [f64],
    pub steps: Vec<EdgeStep>,
    pub sigma: f64,
}

/// One step's high-passed residual from its robust first-order fit, and the running median's
/// half width (samples).
struct EdgeResidual {
    t: Vec<f64>,
    rr: Vec<f64>,
    half: usize,
}

impl EdgeResidual {
    /// The windows the scan finds, less those centred within `half` of the ends: there the running
    /// median of [`high_pass`] is one-sided and leaves the residual's slow part in (a handling spike
    /// is near the logged change, not at the edge of the window searched around it, which reaches
    /// 3 s before and after).
    fn spikes(&self, sigma: f64, max_spike_s: f64) -> Vec<SpikeWindow> {
        let n = self.t.len();
        if n == 0 {
            return vec![];
        }
        let (lo, hi) = (self.t[self.half.min(n - 1)], self.t[n.saturating_sub(1 + self.half)]);
        scan(&self.t, &self.rr, sigma, max_spike_s).into_iter().filter(|w| (lo..=hi).contains(&(0.5 * (w.start_s + w.end_s)))).collect()
    }
}

/// Spike windows at the steps' edges of one recording (raw samples, their noise `sigma`).
pub fn detect(t: &[f64], v: &[f64], steps: &[EdgeStep], sigma: f64, max_spike_s: f64) -> Vec<SpikeWindow> {
    detect_all(&[EdgeSeries { t, v, steps: steps.to_vec(), sigma }], max_spike_s).pop().unwrap_or_default()
}

/// Spike windows at the steps' edges of every recording of a data set.
pub fn detect_all(series: &[EdgeSeries], max_spike_s: f64) -> Vec<Vec<SpikeWindow>> {
    series.iter().map(|s| edge_residuals(s).into_iter().flat_map(|e| e.spikes(s.sigma, max_spike_s)).collect()).collect()
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
        let local = Local::new(&tt, &vv, st, sigma);
        let (obj, r) = robust_residual(&local, st, Shape::Straight);
        let mut rr = high_pass(&r, half);
        // where the straight model leaves a spike or a misfit, the step's other shapes are tried:
        // the one that fits best
        // (a long misfit too: it merges with a spike beside it into one window too long to be one)
        if !scan(&tt, &rr, sigma, f64::INFINITY).is_empty() {
            let other = courses(st).into_iter().map(|sh| robust_residual(&local, st, sh)).filter(|(o, _)| o.is_finite()).min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, r2)) = other.filter(|(o, _)| *o < obj) {
                rr = high_pass(&r2, half);
            }
        }
        out.push(EdgeResidual { t: tt, rr, half });
    }
    out
}

/// The residual less its running median over ±`half` samples: what varies slowly is the model's,
/// not a spike.
fn high_pass(r: &[f64], half: usize) -> Vec<f64> {
    let n = r.len();
    let mut buf = Vec::with_capacity(2 * half + 1);
    (0..n)
        .map(|j| {
            buf.clear();
            buf.extend_from_slice(&r[j.saturating_sub(half)..(j + half + 1).min(n)]);
            r[j] - median(&mut buf)
        })
        .collect()
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
        let st = EdgeStep { t0_s: 10.02, tau_s: 0.6, from_s: 7.0, to_s: 13.0, through: None, tau_before_s: None };
        let w = detect(&t, &v, &[st], 0.003, 1.0);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].start_s <= 9.95 && w[0].end_s >= 10.05 && w[0].peak < 0.0, "{w:?}");
        let (_, mask) = super::super::super::preprocess::spikes(&t, &v, &Default::default());
        assert!(mask.iter().all(|m| *m), "part 1's detector was expected to miss it");
    }

    #[test]
    fn a_course_with_nothing_to_bend_or_glide_is_the_straight_rise() {
        // off the integration grid too (the samples between its nodes are interpolated)
        let x: Vec<f64> = (0..550).map(|i| i as f64 * 0.0073 - 0.5).collect();
        for d in [0.0, 0.25, 0.37, 0.5, 1.0] {
            let c = course_rises(&x, 0.6, d, Bend::None, None, false);
            for (xj, cj) in x.iter().zip(&c) {
                let r = if *xj > 0.0 { ramp_rise(*xj, 0.6, d) } else { 0.0 };
                assert!((cj - r).abs() < 1e-4, "d {d} x {xj}: {cj} vs {r}");
            }
        }
        // a gliding τ: against a direct integration on a fine grid
        let (ta, tb, d) = (0.6, 0.25, 0.5);
        let c = course_rises(&[0.2, 0.5, 0.9], tb, d, Bend::None, Some(ta), false);
        let (mut y, dt) = (0.0, 1e-5);
        let mut want = Vec::new();
        for k in 0..90_000 {
            let x = k as f64 * dt;
            let s = (x / d).min(1.0);
            y += dt * (s - y) / (ta + (tb - ta) * s);
            if [20_000, 50_000, 89_999].contains(&k) {
                want.push(y);
            }
        }
        for (a, b) in c.iter().zip(&want) {
            assert!((a - b).abs() < 1e-3, "{c:?} vs {want:?}");
        }
        // an output bend is the divider's map of the straight rise; it keeps both ends
        let c = course_rises(&x, 0.6, 0.5, Bend::Output([2.5, 1.2]), None, true);
        assert!(c[0] == 0.0 && (c[c.len() - 1] - 1.0).abs() < 1e-2);
    }

    /// A removal to the lightest load as family A's simulator makes it: the load lowered by hand
    /// over 0.5 s (an S-curve), the read-out relaxing at first order toward a divider's level, its
    /// time constant following the load (0.6 s to 0.25 s). Returns the samples and each step's u.
    fn removal(spike: f64, at: f64) -> (Vec<f64>, Vec<f64>, [f64; 2]) {
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        let (vcc, fa, fb) = (3.3, 2.16, 0.196);
        let x_of = |f: f64| 0.6 * f;
        let veq = |f: f64| vcc * x_of(f) / (1.0 + x_of(f));
        let noise = super::super::test_noise(t.len(), 0.003, 5);
        let mut v = veq(fa);
        let mut out = Vec::new();
        for (i, &tk) in t.iter().enumerate() {
            let u = ((tk - 4.5) / 0.5).clamp(0.0, 1.0);
            let f = fa + (fb - fa) * u * u * (3.0 - 2.0 * u);
            let tau = 0.215 + 0.178 * f;
            v = veq(f) + (v - veq(f)) * (-0.01 / tau).exp();
            let s = tk - at;
            let sp = if (0.0..0.1).contains(&s) { -spike * (std::f64::consts::PI * s / 0.1).sin() } else { 0.0 };
            out.push(v + noise[i] + sp);
        }
        let u = |f: f64| 1.0 + x_of(f);
        (t, out, [u(fa), u(fb)])
    }

    #[test]
    fn a_removal_through_a_divider_with_a_gliding_tau_is_no_spike_but_a_spike_on_it_is() {
        let (t, v, u) = removal(0.0, 0.0);
        let straight = EdgeStep { t0_s: 4.6, tau_s: 0.25, from_s: 2.0, to_s: 8.0, through: None, tau_before_s: None };
        // the straight first-order model leaves the removal's course as a spike
        assert!(!detect(&t, &v, std::slice::from_ref(&straight), 0.003, 1.0).is_empty(), "the test's step must trouble the straight model");
        let known = EdgeStep { through: Some(u), tau_before_s: Some(0.6), ..straight.clone() };
        let w = detect(&t, &v, std::slice::from_ref(&known), 0.003, 1.0);
        assert!(w.is_empty(), "{w:?}");
        // a 0.1 s spike of 10 σ riding that removal is still found, during the touch and after it;
        // after it, the straight model's misfit merged with the spike into one window too long to be
        // a spike, and the spike was lost (before the step's courses were tried on any misfit)
        for at in [4.6, 4.95, 5.3, 5.6] {
            let (t, v, _) = removal(0.03, at);
            let w = detect(&t, &v, std::slice::from_ref(&known), 0.003, 1.0);
            assert!(w.iter().any(|w| w.start_s <= at + 0.07 && w.end_s >= at + 0.03), "spike at {at}: {w:?}");
        }
    }

    /// No window is reported centred in the first or last half-second of a step's window, where the
    /// running median is one-sided: an excursion there (AR noise's slow part in family A's nulls, 2.5 s before
    /// the logged change) is not taken for a spike, while the same excursion nearer the change is.
    #[test]
    fn the_windows_ends_are_not_scanned() {
        let bump = |at: f64| {
            let (t, mut v) = series(0.0, 1.0);
            for (x, &tk) in v.iter_mut().zip(&t) {
                let s = tk - at;
                if (0.0..0.12).contains(&s) {
                    *x -= 0.03 * (std::f64::consts::PI * s / 0.12).sin();
                }
            }
            (t, v)
        };
        let st = EdgeStep { t0_s: 10.0, tau_s: 0.6, from_s: 7.0, to_s: 13.0, through: None, tau_before_s: None };
        let (t, v) = bump(7.02);
        assert!(detect(&t, &v, std::slice::from_ref(&st), 0.003, 1.0).is_empty());
        // (the scan alone finds it there: the ends are what leaves it out)
        let res = edge_residuals(&EdgeSeries { t: &t, v: &v, steps: vec![st.clone()], sigma: 0.003 });
        assert!(!scan(&res[0].t, &res[0].rr, 0.003, 1.0).is_empty(), "the test's excursion must be one the scan finds");
        let (t, v) = bump(8.5);
        let w = detect(&t, &v, std::slice::from_ref(&st), 0.003, 1.0);
        assert!(w.len() == 1 && w[0].start_s <= 8.55 && w[0].end_s >= 8.57, "{w:?}");
        // the end of the window alike
        let (t, v) = bump(12.86);
        assert!(detect(&t, &v, &[st], 0.003, 1.0).is_empty());
    }

    #[test]
    fn nothing_on_a_clean_step_or_a_slow_transient() {
        let (t, mut v) = series(0.0, 1.0);
        let st = EdgeStep { t0_s: 10.0, tau_s: 0.6, from_s: 7.0, to_s: 13.0, through: None, tau_before_s: None };
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
