//! Fitting the first-order step model V = V0 + k(1 − e^(−(t − t0)/τ)).
//!
//! Separate pieces, in the argmin manner: [`StepData`] is the problem (data of one step over one or
//! more trials), [`varpro`] is the solver (variable projection: k, V0 and the per-trial amplitudes
//! are linear given τ; τ by a log-spaced scan, golden-section and Newton refinement), [`Termination`]
//! says why it stopped, and [`StepFit`] is the report the tables, plots and diagnosis read.

use super::preprocess::{median, Ramp, Series, Step};
use nalgebra::DMatrix;
use serde::Serialize;

/// One trial's samples around one step.
#[derive(Debug, Clone)]
pub struct Trial {
    pub recording: String,
    pub t: Vec<f64>,
    pub v: Vec<f64>,
    /// Logged time of the step.
    pub t_log: f64,
    /// Detected onset: the first sample clearly off the pre-step level.
    pub t_on: f64,
    /// Index of the first post-onset sample used in the fit.
    pub post: usize,
    /// Samples before this index are the pre-step level; those between it and `post` straddle the
    /// onset (a filtered sample there mixes both) and are left out.
    pub pre_end: usize,
    /// The post-onset sample spacing when it is uniform (to 1e-9 relative), for a faster decay.
    pub uniform_dt: Option<f64>,
    /// End of the hold.
    pub t_end: f64,
}

/// The data of one step pooled over trials.
#[derive(Debug, Clone)]
pub struct StepData {
    pub step: Step,
    pub trials: Vec<Trial>,
}

/// Cuts one trial's window for a step out of a preprocessed series.
pub fn trial_window(series: &Series, step: &Step, recording: &str, ramp: Option<Ramp>) -> Option<Trial> {
    if let Some(r) = ramp.filter(|r| r.duration_s > 0.0) {
        return ramp_window(series, step, recording, r);
    }
    let hold_prev = 6.0f64;
    let search = 2.0f64.min(0.4 * (step.t_end - step.t_log));
    let base_len = 2.0f64;
    let t0 = step.t_log - search - base_len.min(hold_prev);
    // the next weight may land before it is logged: stop the window a search span before the next log
    let t_stop = step.t_end - search;
    let idx: Vec<usize> = (0..series.t.len()).filter(|&i| series.ok[i] && series.t[i] >= t0 && series.t[i] <= t_stop).collect();
    if idx.len() < 12 {
        return None;
    }
    let t: Vec<f64> = idx.iter().map(|&i| series.t[i]).collect();
    let v: Vec<f64> = idx.iter().map(|&i| series.v[i]).collect();
    let mut base: Vec<f64> = t.iter().zip(&v).filter(|(tt, _)| **tt < step.t_log - search).map(|(_, vv)| *vv).collect();
    if base.len() < 3 {
        base = v[..3.min(v.len())].to_vec();
    }
    let b0 = median(&mut base);
    let mut tail: Vec<f64> = t.iter().zip(&v).filter(|(tt, _)| **tt > t_stop - 1.0).map(|(_, vv)| *vv).collect();
    let v_end = median(&mut tail);
    let thr = (6.0 * series.sigma).max(0.05 * (v_end - b0).abs());
    let mut on = None;
    for i in 0..t.len().saturating_sub(3) {
        if t[i] < step.t_log - search {
            continue;
        }
        if t[i] > step.t_log + search {
            break;
        }
        if (0..3).all(|k| (v[i + k] - b0).abs() > thr && (v[i + k] - b0).signum() == (v_end - b0).signum()) {
            on = Some(i);
            break;
        }
    }
    let on = on.unwrap_or_else(|| t.iter().position(|&x| x >= step.t_log).unwrap_or(0));
    let (pre_end, post) = (on.saturating_sub(2), on + 1);
    if pre_end < 2 || t.len() < post + 8 {
        return None;
    }
    let uniform_dt = uniform(&t[post..]);
    Some(Trial { recording: recording.to_string(), t_on: t[post], t, v, t_log: step.t_log, post, pre_end, uniform_dt, t_end: step.t_end })
}

/// A trial's window for a step whose load ramps in over `r` (an actuator's travel): the pre-step
/// level from the 2 s before the ramp starts, the samples on the ramp left out, the fit from the
/// ramp's end (where the response is a first-order decay toward the new level again, its
/// amplitude set by the ramp) to the next ramp's start.
fn ramp_window(series: &Series, step: &Step, recording: &str, r: Ramp) -> Option<Trial> {
    let end = step.t_log + r.end_after_log_s;
    let start = end - r.duration_s;
    let gap = 0.2f64;
    let t_stop = step.t_end + r.end_after_log_s - r.duration_s - gap;
    let idx: Vec<usize> = (0..series.t.len()).filter(|&i| series.ok[i] && series.t[i] >= start - gap - 2.0 && series.t[i] <= t_stop).collect();
    let t: Vec<f64> = idx.iter().map(|&i| series.t[i]).collect();
    let v: Vec<f64> = idx.iter().map(|&i| series.v[i]).collect();
    let pre_end = t.iter().position(|&x| x >= start - gap).unwrap_or(t.len());
    let post = t.iter().position(|&x| x >= end)?;
    if pre_end < 3 || t.len() < post + 8 {
        return None;
    }
    let uniform_dt = uniform(&t[post..]);
    Some(Trial { recording: recording.to_string(), t_on: t[post], t, v, t_log: step.t_log, post, pre_end, uniform_dt, t_end: step.t_end })
}

/// The spacing of a time vector when it is uniform.
pub fn uniform(t: &[f64]) -> Option<f64> {
    if t.len() < 2 {
        return None;
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    t.windows(2).all(|w| ((w[1] - w[0]) - dt).abs() <= 1e-9 * dt.abs()).then_some(dt)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// Newton steps on log τ converged.
    Converged,
    /// The best τ lies at an end of the searched range.
    AtBound,
    /// Too few samples for the parameters.
    TooFewSamples,
}

/// Per-trial parameters of a fit.
#[derive(Debug, Clone, Serialize)]
pub struct TrialParams {
    pub recording: String,
    pub t_log: f64,
    pub t_on: f64,
    /// Estimated true step time (where the exponential starts).
    pub t0: f64,
    pub v0: f64,
}

/// The report of one step fit.
#[derive(Debug, Clone, Serialize)]
pub struct StepFit {
    pub k: f64,
    pub tau_s: f64,
    pub se_k: f64,
    pub se_tau_s: f64,
    pub rms: f64,
    pub n: usize,
    pub trials: Vec<TrialParams>,
    pub termination: Termination,
    pub evaluations: usize,
}

impl StepFit {
    /// The fitted curve for trial `i` at time t.
    pub fn model(&self, i: usize, t: f64) -> f64 {
        let tp = &self.trials[i];
        if t < tp.t0 {
            tp.v0
        } else {
            tp.v0 + self.k * (1.0 - (-(t - tp.t0) / self.tau_s).exp())
        }
    }
}

/// A jump's time constant, in sample intervals: settled at the next sample.
pub const JUMP_TAU_SHARE: f64 = 0.05;

/// A trial window's mean sample interval (None with fewer than two samples).
pub fn sample_interval(tr: &Trial) -> Option<f64> {
    let n = tr.t.len();
    (n >= 2).then(|| (tr.t[n - 1] - tr.t[0]) / (n - 1) as f64)
}

/// The farthest a fitted curve's onset may lie before the detected one (at least 5 samples).
pub const ONSET_LEAD_S: f64 = 2.0;

/// When a trial's step is a jump within one sample (the load landing at once, anything slower
/// after it), the time of the jump: midway between the two consecutive samples within three
/// intervals of the detected onset that differ most. A jump: those two samples differ by at least
/// half the step's change (by five times the noise of such a difference, landing within half the
/// change of the new level), or the fitted τ is under one sample interval, or the fitted curve
/// would have begun more than [`ONSET_LEAD_S`] (5 samples) before the detected onset (a slow τ,
/// determined to better than ±50 %, fitted to the creep after a jump puts it minutes back).
pub fn jump_time(tr: &Trial, tp: &TrialParams, f: &StepFit) -> Option<f64> {
    let n = tr.t.len();
    if n < 3 || f.k == 0.0 {
        return None;
    }
    let dt = sample_interval(tr)?;
    let near: Vec<usize> = (0..n).filter(|&j| (tr.t[j] - tr.t_on).abs() <= 3.0 * dt + 1e-9).collect();
    let (a, b) = near.windows(2).filter(|w| w[1] == w[0] + 1).map(|w| (w[0], w[1])).max_by(|x, y| (tr.v[x.1] - tr.v[x.0]).abs().total_cmp(&(tr.v[y.1] - tr.v[y.0]).abs()))?;
    // the leap must stand out of the noise of a difference of two samples (5σ), or a small
    // step's noise would pass for half of it
    let noise = super::preprocess::noise_sigma(&tr.v) * std::f64::consts::SQRT_2;
    // and land near the new level (within half the change): a leap far past it is the start of a
    // relaxation back (a change-driven overshoot), not the step
    let lands = (tr.v[b] - tp.v0 - f.k).abs() < 0.5 * f.k.abs();
    let leap = if (tr.v[b] - tr.v[a]).abs() > 5.0 * noise && lands { (tr.v[b] - tr.v[a]) / f.k } else { 0.0 };
    // (the onset a slow τ implies counts only when that τ is determined: a small step in the
    // noise fits any τ)
    let determined = f.se_tau_s < 0.5 * f.tau_s;
    let jump = leap >= 0.5 || f.tau_s < dt || (determined && tp.t0 < tr.t_on - ONSET_LEAD_S.max(5.0 * dt));
    jump.then(|| 0.5 * (tr.t[a] + tr.t[b]))
}

/// exp(−(t_j − t_on)/τ) for the post-onset samples of a trial, by recurrence where the sample
/// spacing repeats (one exp per distinct spacing instead of one per sample).
fn decay(tr: &Trial, tau: f64, out: &mut Vec<f64>) {
    out.clear();
    out.reserve(tr.t.len() - tr.post);
    if let Some(dt) = tr.uniform_dt {
        let r = (-dt / tau).exp();
        let mut e = (-(tr.t[tr.post] - tr.t_on) / tau).exp();
        for _ in tr.post..tr.t.len() {
            out.push(e);
            e *= r;
        }
        return;
    }
    let mut e = (-(tr.t[tr.post] - tr.t_on) / tau).exp();
    let mut last_dt = f64::NAN;
    let mut f = 0.0;
    out.push(e);
    for j in tr.post + 1..tr.t.len() {
        let dt = tr.t[j] - tr.t[j - 1];
        if last_dt.is_nan() || (dt - last_dt).abs() > 1e-9 * dt.abs() {
            f = (-dt / tau).exp();
            last_dt = dt;
        }
        e *= f;
        out.push(e);
    }
}

/// Linear solve for given τ: returns (θ = [V0_i…, b_i…, k], RSS). The normal equations are
/// assembled from per-trial sums (the design matrix has a fixed sparsity).
fn solve_linear(d: &StepData, tau: f64) -> Option<(Vec<f64>, f64)> {
    let (theta, es, _) = solve_theta(d, tau)?;
    let w = d.trials.len();
    // the residual sum from the residuals themselves: yᵀy − θᵀAᵀy cancels badly when τ ≫ the
    // window and the amplitude columns become nearly collinear
    let mut rss = 0.0;
    for (i, tr) in d.trials.iter().enumerate() {
        for j in 0..tr.pre_end {
            rss += (tr.v[j] - theta[i]).powi(2);
        }
        for (q, j) in (tr.post..tr.t.len()).enumerate() {
            rss += (tr.v[j] - theta[i] - theta[2 * w] - theta[w + i] * es[i][q]).powi(2);
        }
    }
    Some((theta, rss))
}

/// The linear parameters θ for a given τ, with the decays and the Cholesky factor of AᵀA.
fn solve_theta(d: &StepData, tau: f64) -> Option<(Vec<f64>, Vec<Vec<f64>>, Arrow)> {
    let w = d.trials.len();
    let mut ar = Arrow { b: Vec::with_capacity(w), c: Vec::with_capacity(w), d: 0.0 };
    let mut rhs = Vec::with_capacity(w);
    let mut rk = 0.0;
    let mut es: Vec<Vec<f64>> = vec![Vec::new(); w];
    for (i, tr) in d.trials.iter().enumerate() {
        let sy_all: f64 = tr.v[..tr.pre_end].iter().sum();
        decay(tr, tau, &mut es[i]);
        let e = &es[i];
        let (mut se, mut see, mut sey, mut sy_post) = (0.0, 0.0, 0.0, 0.0);
        for (&y, &ej) in tr.v[tr.post..].iter().zip(e.iter()) {
            se += ej;
            see += ej * ej;
            sey += ej * y;
            sy_post += y;
        }
        let n_post = (tr.t.len() - tr.post) as f64;
        ar.b.push([tr.pre_end as f64 + n_post, se, see]);
        ar.c.push([n_post, se]);
        ar.d += n_post;
        rhs.push([sy_all + sy_post, sey]);
        rk += sy_post;
    }
    let (x, k) = ar.solve(&rhs, rk)?;
    let mut theta = vec![0.0; 2 * w + 1];
    for (i, xi) in x.iter().enumerate() {
        theta[i] = xi[0];
        theta[w + i] = xi[1];
    }
    theta[2 * w] = k;
    Some((theta, es, ar))
}

/// The normal matrix of the step model: per trial a 2×2 block for (V0_i, b_i), coupled only to
/// the shared k. Solved by eliminating the blocks (O(trials), no dense factorisation).
struct Arrow {
    /// [b11, b12, b22] of each trial's block.
    b: Vec<[f64; 3]>,
    /// Coupling of (V0_i, b_i) to k.
    c: Vec<[f64; 2]>,
    d: f64,
}

impl Arrow {
    fn inv(b: &[f64; 3], r: [f64; 2]) -> Option<[f64; 2]> {
        let det = b[0] * b[2] - b[1] * b[1];
        if det.abs() <= 1e-300 || !det.is_finite() {
            return None;
        }
        Some([(b[2] * r[0] - b[1] * r[1]) / det, (b[0] * r[1] - b[1] * r[0]) / det])
    }
    fn solve(&self, rhs: &[[f64; 2]], rk: f64) -> Option<(Vec<[f64; 2]>, f64)> {
        let (mut num, mut den) = (rk, self.d);
        let mut bir = Vec::with_capacity(rhs.len());
        let mut bic = Vec::with_capacity(rhs.len());
        for i in 0..rhs.len() {
            let (a, c) = (Self::inv(&self.b[i], rhs[i])?, Self::inv(&self.b[i], self.c[i])?);
            num -= self.c[i][0] * a[0] + self.c[i][1] * a[1];
            den -= self.c[i][0] * c[0] + self.c[i][1] * c[1];
            bir.push(a);
            bic.push(c);
        }
        if den.abs() <= 1e-300 * self.d.abs().max(1.0) {
            return None;
        }
        let k = num / den;
        Some(((0..rhs.len()).map(|i| [bir[i][0] - bic[i][0] * k, bir[i][1] - bic[i][1] * k]).collect(), k))
    }
    /// zᵀ M⁻¹ z.
    fn quad(&self, z: &[[f64; 2]], zk: f64) -> Option<f64> {
        let (x, k) = self.solve(z, zk)?;
        Some(z.iter().zip(&x).map(|(a, b)| a[0] * b[0] + a[1] * b[1]).sum::<f64>() + zk * k)
    }
}

/// RSS and its first and (Gauss-Newton) second derivative in s = ln τ. By the variable-projection
/// envelope theorem f′ = −2 rᵀg with g = ∂(Aθ)/∂s, and f″ ≈ 2‖P⊥g‖² = 2(gᵀg − (Aᵀg)ᵀ(AᵀA)⁻¹Aᵀg).
fn vp_derivs(d: &StepData, tau: f64) -> Option<(f64, f64, f64)> {
    let (theta, es, arrow) = solve_theta(d, tau)?;
    let w = d.trials.len();
    let mut atg = vec![[0.0f64; 2]; w];
    let mut atg_k = 0.0;
    let (mut rg, mut gg, mut rss) = (0.0, 0.0, 0.0);
    for (i, tr) in d.trials.iter().enumerate() {
        for j in 0..tr.pre_end {
            rss += (tr.v[j] - theta[i]).powi(2);
        }
        let (mut sg, mut sge) = (0.0, 0.0);
        for (q, j) in (tr.post..tr.t.len()).enumerate() {
            let e = es[i][q];
            let g = theta[w + i] * e * (tr.t[j] - tr.t_on) / tau;
            let r = tr.v[j] - theta[i] - theta[2 * w] - theta[w + i] * e;
            rss += r * r;
            rg += r * g;
            gg += g * g;
            sg += g;
            sge += g * e;
        }
        atg[i] = [sg, sge];
        atg_k += sg;
    }
    let proj = arrow.quad(&atg, atg_k)?;
    Some((rss, -2.0 * rg, 2.0 * (gg - proj).max(0.0)))
}

/// A starting τ from the data: the median over trials of the time to 63 % of the step.
fn tau_guess(d: &StepData) -> Option<f64> {
    let mut g = Vec::new();
    for tr in &d.trials {
        let n = tr.t.len();
        let v0 = tr.v[..tr.pre_end].iter().sum::<f64>() / tr.pre_end as f64;
        let tail = 10.min(n - tr.post);
        let v1 = tr.v[n - tail..].iter().sum::<f64>() / tail as f64;
        let target = v0 + 0.632 * (v1 - v0);
        if let Some(j) = (tr.post..n).find(|&j| (tr.v[j] - target) * (v1 - v0).signum() >= 0.0) {
            g.push((tr.t[j] - tr.t_on).max(0.5 * (tr.t[tr.post + 1] - tr.t[tr.post])));
        }
    }
    if g.is_empty() {
        return None;
    }
    Some(median(&mut g))
}

/// Variable projection over τ.
pub fn varpro(d: &StepData) -> Option<StepFit> {
    let w = d.trials.len();
    let n: usize = d.trials.iter().map(|t| t.pre_end + t.t.len() - t.post).sum();
    if w == 0 || n < 2 * w + 4 {
        return None;
    }
    let span = d.trials.iter().map(|t| t.t[t.t.len() - 1] - t.t_on).fold(0.0, f64::max);
    let dt = d.trials.iter().map(|t| (t.t[t.t.len() - 1] - t.t[0]) / (t.t.len() - 1) as f64).fold(f64::INFINITY, f64::min);
    let (lo, hi) = ((0.5 * dt).max(1e-3).ln(), (5.0 * span).max(1.0).ln());
    // fast path: safeguarded Newton on ln τ from the 63 % time, with exact gradient and the
    // Gauss-Newton curvature; falls back to the scan below when it does not converge
    if let Some(t0) = tau_guess(d) {
        let mut sl = t0.ln().clamp(lo, hi);
        let mut evals = 0;
        let mut ok = false;
        if let Some((mut f0, mut g0, mut h0)) = vp_derivs(d, sl.exp()) {
            evals += 1;
            for _ in 0..30 {
                if h0 <= 0.0 {
                    break;
                }
                let mut step = -(g0 / h0).clamp(-1.0, 1.0);
                let mut accepted = false;
                for _ in 0..8 {
                    let cand = (sl + step).clamp(lo, hi);
                    if let Some((f1, g1, h1)) = vp_derivs(d, cand.exp()) {
                        evals += 1;
                        if f1 <= f0 {
                            sl = cand;
                            (f0, g0, h0) = (f1, g1, h1);
                            accepted = true;
                            break;
                        }
                    }
                    step *= 0.5;
                }
                if !accepted || step.abs() < 1e-6 {
                    ok = accepted || step.abs() < 1e-6;
                    break;
                }
            }
            let _ = f0;
        }
        if ok && sl > lo && sl < hi {
            return finish(d, sl.exp(), Termination::Converged, evals);
        }
    }
    let mut evals = 0;
    let mut f = |lt: f64| -> f64 {
        evals += 1;
        solve_linear(d, lt.exp()).map(|(_, rss)| rss).unwrap_or(f64::INFINITY)
    };
    let m = 24;
    let grid: Vec<f64> = (0..m).map(|i| lo + (hi - lo) * i as f64 / (m - 1) as f64).collect();
    let vals: Vec<f64> = grid.iter().map(|&g| f(g)).collect();
    let best = (0..m).min_by(|&a, &b| vals[a].partial_cmp(&vals[b]).unwrap_or(std::cmp::Ordering::Equal))?;
    let mut termination = Termination::Converged;
    if best == 0 || best == m - 1 {
        termination = Termination::AtBound;
    }
    // golden section in the bracket around the best grid point
    let br = super::golden::golden(&mut f, grid[best.saturating_sub(1)], grid[(best + 1).min(m - 1)], 40, 1e-3);
    let (a, b) = (br.a, br.b);
    // Newton on log τ with central differences
    let mut lt = 0.5 * (a + b);
    for _ in 0..6 {
        let h = 1e-4;
        let (f0, fp, fm) = (f(lt), f(lt + h), f(lt - h));
        let d1 = (fp - fm) / (2.0 * h);
        let d2 = (fp - 2.0 * f0 + fm) / (h * h);
        if d2 <= 0.0 {
            break;
        }
        let step = (d1 / d2).clamp(-0.05, 0.05);
        if f(lt - step) < f0 {
            lt -= step;
        }
        if step.abs() < 1e-7 {
            break;
        }
    }
    finish(d, lt.exp(), termination, evals)
}

/// The report at the chosen τ: linear parameters, standard errors, per-trial onsets.
fn finish(d: &StepData, tau: f64, termination: Termination, evals: usize) -> Option<StepFit> {
    let w = d.trials.len();
    let n: usize = d.trials.iter().map(|t| t.pre_end + t.t.len() - t.post).sum();
    let (theta, es, _) = solve_theta(d, tau)?;
    let k = theta[2 * w];
    let mut rss = 0.0;
    // standard errors from the full Jacobian [V0_i, b_i, k, τ]; a row has at most four
    // non-zeros (V0_i, b_i, k, τ), so JᵀJ is assembled from 4×4 blocks
    let p = 2 * w + 2;
    let mut jtj = DMatrix::<f64>::zeros(p, p);
    for (i, tr) in d.trials.iter().enumerate() {
        jtj[(i, i)] += tr.pre_end as f64;
        for j in 0..tr.pre_end {
            rss += (tr.v[j] - theta[i]).powi(2);
        }
        let e = &es[i];
        let cols = [i, w + i, 2 * w, 2 * w + 1];
        let mut acc = [[0.0f64; 4]; 4];
        for (q, j) in (tr.post..tr.t.len()).enumerate() {
            rss += (tr.v[j] - theta[i] - theta[2 * w] - theta[w + i] * e[q]).powi(2);
            let sdt = tr.t[j] - tr.t_on;
            let row = [1.0, e[q], 1.0, theta[w + i] * e[q] * sdt / (tau * tau)];
            for a in 0..4 {
                for bb in 0..4 {
                    acc[a][bb] += row[a] * row[bb];
                }
            }
        }
        for a in 0..4 {
            for bb in 0..4 {
                jtj[(cols[a], cols[bb])] += acc[a][bb];
            }
        }
    }
    let s2 = rss / (n as f64 - p as f64).max(1.0);
    let (se_k, se_tau) = match jtj.try_inverse() {
        Some(inv) => ((inv[(2 * w, 2 * w)] * s2).max(0.0).sqrt(), (inv[(2 * w + 1, 2 * w + 1)] * s2).max(0.0).sqrt()),
        None => (f64::NAN, f64::NAN),
    };
    let trials = d
        .trials
        .iter()
        .enumerate()
        .map(|(i, tr)| {
            let ratio = -theta[w + i] / k;
            let t0 = if ratio > 0.0 { tr.t_on + tau * ratio.ln() } else { tr.t_on };
            TrialParams { recording: tr.recording.clone(), t_log: tr.t_log, t_on: tr.t_on, t0: t0.min(tr.t_on), v0: theta[i] }
        })
        .collect();
    Some(StepFit { k, tau_s: tau, se_k, se_tau_s: se_tau, rms: (rss / n as f64).sqrt(), n, trials, termination, evaluations: evals })
}

/// The paper's Eq. 4: pooled RMS over trials, each from its logged step time for the same number
/// of samples (the shortest trial's), against a model curve per trial.
pub fn eq4(d: &StepData, model: impl Fn(usize, f64) -> f64) -> f64 {
    let starts: Vec<usize> = d.trials.iter().map(|tr| tr.t.iter().position(|&x| x >= tr.t_log).unwrap_or(0)).collect();
    let j = d.trials.iter().zip(&starts).map(|(tr, s)| tr.t.len() - s).min().unwrap_or(0);
    if j == 0 {
        return f64::NAN;
    }
    let mut s = 0.0;
    for (i, tr) in d.trials.iter().enumerate() {
        for q in 0..j {
            let idx = starts[i] + q;
            s += (tr.v[idx] - model(i, tr.t[idx])).powi(2);
        }
    }
    (s / (j * d.trials.len()) as f64).sqrt()
}

/// The paper's method, faithfully: per trial k by Eq. 2 and τ by Eq. 3 (with the factor c chosen
/// per trial to match the curve, as the paper adjusted it by hand), then an exhaustive search of
/// the k–τ rectangle spanned by the per-trial values for the lowest pooled Eq. 4 error.
#[derive(Debug, Clone, Serialize)]
pub struct PaperFit {
    /// Gain per unit load (V per kg when the protocol is in grams or newtons).
    pub k: f64,
    pub tau_s: f64,
    pub eq4: f64,
    pub weight: f64,
    pub per_trial: Vec<(f64, f64, f64)>,
    pub grid: usize,
    /// Trials whose Eq. 3 optimum lies on an edge of the c grid (a warning: τ is a bound there).
    pub edge_notes: Vec<String>,
}

/// Per trial (k, τ, c) and (V_initial, start_s).
type PerTrial = (Vec<(f64, f64, f64)>, Vec<(f64, f64)>);

/// Points of the per-trial c grid of Eq. 3 (log-spaced).
pub const C_GRID: usize = 400;

/// The c grid of Eq. 3 (τ = c · 0.637 · T) for a trial of duration `t_total` sampled every `dt`:
/// log-spaced from the τ of one sample interval to c = 1, so the data, not the grid, set the
/// smallest τ (a linear grid from c = 1/200 made τ ≥ 0.005 · 0.637 · T: 1.25 s on a 394 s hold).
fn c_grid(t_total: f64, dt: f64) -> Vec<f64> {
    let hi = 1.0f64;
    let lo = (dt / (0.637 * t_total)).clamp(1e-9, hi);
    if lo >= hi {
        return vec![hi];
    }
    (0..C_GRID).map(|i| lo * (hi / lo).powf(i as f64 / (C_GRID - 1) as f64)).collect()
}

/// Per-trial k (Eq. 2) and τ (Eq. 3, c chosen per trial), with each trial's V_initial and start,
/// and a note for each trial whose best c lies on an edge of its grid.
fn paper_per_trial(d: &StepData, weight: f64) -> Option<(PerTrial, Vec<String>)> {
    let mut per = Vec::new();
    let mut vinit = Vec::new();
    let mut notes = Vec::new();
    for tr in &d.trials {
        let s = tr.t.iter().position(|&x| x >= tr.t_log)?;
        let (vi, vf) = (tr.v[s], tr.v[tr.v.len() - 1]);
        let k = (vf - vi) / weight;
        let t_total = tr.t[tr.t.len() - 1] - tr.t[s];
        let dt = if tr.t.len() - s > 1 { t_total / (tr.t.len() - s - 1) as f64 } else { t_total };
        let grid = c_grid(t_total, dt);
        let mut best = (f64::INFINITY, 0usize);
        for (ci, &c) in grid.iter().enumerate() {
            let tau = c * 0.637 * t_total;
            let e: f64 = (s..tr.t.len()).map(|q| (tr.v[q] - vi - k * weight * (1.0 - (-(tr.t[q] - tr.t[s]) / tau).exp())).powi(2)).sum();
            if e < best.0 {
                best = (e, ci);
            }
        }
        let c = grid[best.1];
        if grid.len() > 1 && best.1 == 0 {
            notes.push(format!(
                "{}: Eq. 3's best τ is the grid's smallest, one sample interval ({:.4} s): the rise is faster than the sampling resolves",
                tr.recording,
                c * 0.637 * t_total
            ));
        } else if grid.len() > 1 && best.1 == grid.len() - 1 {
            notes.push(format!("{}: Eq. 3's best τ is the grid's largest, c = 1 ({:.3} s): the response has not settled within the hold", tr.recording, c * 0.637 * t_total));
        }
        per.push((k, c * 0.637 * t_total, c));
        vinit.push((vi, tr.t[s]));
    }
    Some(((per, vinit), notes))
}

fn rect(per: &[(f64, f64, f64)]) -> (f64, f64, f64, f64) {
    let (kmin, kmax) = per.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p.0), a.1.max(p.0)));
    let (tmin, tmax) = per.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| (a.0.min(p.1), a.1.max(p.1)));
    (kmin, kmax, tmin, tmax)
}

fn at(lo: f64, hi: f64, i: usize, n: usize) -> f64 {
    if n > 1 {
        lo + (hi - lo) * i as f64 / (n - 1) as f64
    } else {
        lo
    }
}

/// The paper's method: per-trial values, then the exhaustive k–τ search of their rectangle.
/// Eq. 4 for every k at one τ follows from three sums, so the search costs one pass over the
/// samples per τ (the result is the same as evaluating Eq. 4 at every grid point; see
/// [`paper_as_described`], which the tests compare against).
pub fn paper(d: &StepData, weight: f64, grid: usize) -> Option<PaperFit> {
    let ((per, vinit), edge_notes) = paper_per_trial(d, weight)?;
    let (kmin, kmax, tmin, tmax) = rect(&per);
    let starts: Vec<usize> = d.trials.iter().map(|tr| tr.t.iter().position(|&x| x >= tr.t_log).unwrap_or(0)).collect();
    let j = d.trials.iter().zip(&starts).map(|(tr, s)| tr.t.len() - s).min().unwrap_or(0);
    let nn = (j * d.trials.len()) as f64;
    let mut best = (f64::INFINITY, per[0].0, per[0].1);
    for b in 0..grid {
        let tau = at(tmin, tmax, b, grid);
        let (mut sdd, mut sdu, mut suu) = (0.0, 0.0, 0.0);
        for (i, tr) in d.trials.iter().enumerate() {
            for q in 0..j {
                let idx = starts[i] + q;
                let dv = tr.v[idx] - vinit[i].0;
                let u = weight * (1.0 - (-(tr.t[idx] - vinit[i].1).max(0.0) / tau).exp());
                sdd += dv * dv;
                sdu += dv * u;
                suu += u * u;
            }
        }
        for a in 0..grid {
            let k = at(kmin, kmax, a, grid);
            let e = ((sdd - 2.0 * k * sdu + k * k * suu).max(0.0) / nn).sqrt();
            if e < best.0 {
                best = (e, k, tau);
            }
        }
    }
    Some(PaperFit { k: best.1, tau_s: best.2, eq4: best.0, weight, per_trial: per, grid, edge_notes })
}

/// The paper's search exactly as described: Eq. 4 evaluated at every (k, τ) of the grid. The
/// benchmark's reference for the paper's cost.
pub fn paper_as_described(d: &StepData, weight: f64, grid: usize) -> Option<PaperFit> {
    let ((per, vinit), edge_notes) = paper_per_trial(d, weight)?;
    let (kmin, kmax, tmin, tmax) = rect(&per);
    let mut best = (f64::INFINITY, per[0].0, per[0].1);
    for a in 0..grid {
        let k = at(kmin, kmax, a, grid);
        for b in 0..grid {
            let tau = at(tmin, tmax, b, grid);
            let e = eq4(d, |i, t| vinit[i].0 + k * weight * (1.0 - (-(t - vinit[i].1).max(0.0) / tau).exp()));
            if e < best.0 {
                best = (e, k, tau);
            }
        }
    }
    Some(PaperFit { k: best.1, tau_s: best.2, eq4: best.0, weight, per_trial: per, grid, edge_notes })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::preprocess::Phase;

    fn synth(k: f64, tau: f64, t0s: &[f64], noise: f64) -> StepData {
        let trials = t0s
            .iter()
            .enumerate()
            .map(|(i, &t0)| {
                let t: Vec<f64> = (0..2500).map(|j| j as f64 * 0.01).collect();
                let v: Vec<f64> = t
                    .iter()
                    .enumerate()
                    .map(|(j, &x)| {
                        let base = 0.2 + 0.01 * i as f64;
                        let m = if x < t0 { base } else { base + k * (1.0 - (-(x - t0) / tau).exp()) };
                        m + noise * ((((j * 7919 + i * 104729) % 2000) as f64 / 1000.0) - 1.0)
                    })
                    .collect();
                let post = t.iter().position(|&x| x >= t0 + 0.02).unwrap();
                let uniform_dt = uniform(&t[post..]);
                Trial { recording: format!("r{i}"), t_on: t[post], t, v, t_log: 5.0, post, pre_end: post - 3, uniform_dt, t_end: 25.0 }
            })
            .collect();
        StepData { step: Step { phase: Phase::Loading, index: 0, t_log: 5.0, t_end: 25.0, before: 0.0, after: 200.0 }, trials }
    }

    #[test]
    fn varpro_recovers_k_and_tau_with_unknown_onsets() {
        let d = synth(0.6, 0.8, &[5.13, 4.9, 5.31], 0.002);
        let f = varpro(&d).unwrap();
        assert!((f.k / 0.6 - 1.0).abs() < 0.005, "k {}", f.k);
        assert!((f.tau_s / 0.8 - 1.0).abs() < 0.005, "tau {}", f.tau_s);
        assert!((f.trials[0].t0 - 5.13).abs() < 0.01, "t0 {}", f.trials[0].t0);
        assert!(f.se_k > 0.0 && f.se_k < 0.01 && f.se_tau_s > 0.0);
        assert_eq!(f.termination, Termination::Converged);
    }

    #[test]
    fn fast_paper_search_finds_the_same_optimum_as_the_described_one() {
        let d = synth(0.6, 0.8, &[5.13, 4.9, 5.31], 0.003);
        let (a, b) = (paper(&d, 0.2, 40).unwrap(), paper_as_described(&d, 0.2, 40).unwrap());
        assert_eq!((a.k, a.tau_s), (b.k, b.tau_s));
        assert!((a.eq4 - b.eq4).abs() < 1e-12);
    }

    /// Issue 17, defect 5: with long holds the c grid from 1/200 gave τ ≥ 0.005 · 0.637 · T
    /// (1.25 s for a 394 s hold, whatever the truth), silently.
    #[test]
    fn papers_tau_is_not_floored_by_a_long_hold() {
        for &tau in &[0.15, 0.64, 2.03] {
            let trials = (0..3)
                .map(|i| {
                    let t: Vec<f64> = (0..40000).map(|j| j as f64 * 0.01).collect();
                    let v: Vec<f64> = t.iter().map(|&x| 0.2 + if x < 5.0 { 0.0 } else { 0.6 * (1.0 - (-(x - 5.0) / tau).exp()) }).collect();
                    let post = t.iter().position(|&x| x >= 5.02).unwrap();
                    let uniform_dt = uniform(&t[post..]);
                    Trial { recording: format!("r{i}"), t_on: t[post], t, v, t_log: 5.0, post, pre_end: post - 3, uniform_dt, t_end: 399.0 }
                })
                .collect();
            let d = StepData { step: Step { phase: Phase::Loading, index: 0, t_log: 5.0, t_end: 399.0, before: 0.0, after: 200.0 }, trials };
            let p = paper(&d, 0.2, 60).unwrap();
            assert!((p.tau_s / tau - 1.0).abs() < 0.05, "truth {tau} s, paper {} s", p.tau_s);
            assert!(p.edge_notes.is_empty(), "{:?}", p.edge_notes);
        }
    }

    #[test]
    fn a_rise_within_one_sample_is_flagged_on_the_grids_edge() {
        let trials = vec![{
            let t: Vec<f64> = (0..2000).map(|j| j as f64 * 0.1).collect();
            let v: Vec<f64> = t.iter().map(|&x| if x < 5.0 { 0.2 } else { 0.8 }).collect();
            let post = t.iter().position(|&x| x >= 5.0).unwrap();
            let uniform_dt = uniform(&t[post..]);
            Trial { recording: "r".into(), t_on: t[post], t, v, t_log: 5.0, post, pre_end: post - 3, uniform_dt, t_end: 199.0 }
        }];
        let d = StepData { step: Step { phase: Phase::Loading, index: 0, t_log: 5.0, t_end: 199.0, before: 0.0, after: 1000.0 }, trials };
        let p = paper(&d, 1.0, 40).unwrap();
        assert!(p.edge_notes.iter().any(|n| n.contains("smallest")), "{:?}", p.edge_notes);
    }

    #[test]
    fn lsq_eq4_error_is_not_above_the_papers() {
        let d = synth(0.6, 0.8, &[5.13, 4.9, 5.31], 0.003);
        let f = varpro(&d).unwrap();
        let p = paper(&d, 0.2, 60).unwrap();
        let e_lsq = eq4(&d, |i, t| f.model(i, t));
        assert!(e_lsq <= p.eq4, "lsq {e_lsq} paper {}", p.eq4);
        assert!((p.k * 0.2 / 0.6 - 1.0).abs() < 0.2);
    }
}
