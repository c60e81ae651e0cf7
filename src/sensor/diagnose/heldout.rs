//! Cross-validation: a model fitted on everything (RMSE, BIC) and on folds (held-out RMSE per
//! unit). Folds leave out one trial (its own offset, gains and rest relaxation validated inside it),
//! one step of a single recording, or the later blocks of a hold (forward in time).

use super::*;

#[derive(Debug, Clone, Serialize)]
#[cfg_attr(test, derive(Default))]
pub struct Score {
    pub rmse: f64,
    pub heldout_rmse: f64,
    pub bic: f64,
    pub params: usize,
    /// Samples scored.
    pub n: usize,
    /// Held-out squared error per unit (trial × step segment, or step segment), for paired tests.
    #[serde(skip)]
    pub units: Vec<f64>,
    /// The (trial, segment) of each unit, in the order of `units`.
    #[serde(skip)]
    pub unit_keys: Vec<(usize, usize)>,
    /// Samples held out per unit, in the order of `units`.
    #[serde(skip)]
    pub unit_n: Vec<usize>,
    /// Blocks per hold when the units are blocks of holds (one recording whose load levels are
    /// not each held in two steps), else 0.
    #[serde(skip)]
    pub blocks: usize,
    /// Held-out squared error per block of [`WITHIN_BLOCK_S`] inside each unit of a held-out trial
    /// ((trial, segment, block), blocks counted from the unit's start), sorted by that key (looked
    /// up by binary search), for a test within the trials (`gate::within_trials_z`); empty for one
    /// recording.
    #[serde(skip)]
    pub within: Vec<((usize, usize, u64), f64)>,
}

/// How long before a held-out trial's first onset its samples are scored (segment 0); the samples
/// before that give the trial its own offset.
const SCORED_BEFORE_ONSET_S: f64 = 0.2;

/// The length of the blocks a held-out trial's units are cut into for a test within the trials: a
/// few first-order time constants and four correlation times of family A's AR(1) noise (ρ 0.98 at
/// 100 Hz), so that the noise of neighbouring blocks is nearly independent.
pub const WITHIN_BLOCK_S: f64 = 2.0;

impl Score {
    /// The share by which this model's held-out RMSE is lower than `before`'s.
    pub(super) fn gain_over(&self, before: &Score) -> f64 {
        (before.heldout_rmse - self.heldout_rmse) / before.heldout_rmse.max(1e-300)
    }
}

/// BIC of the fit on everything (no folds): what shape parameters are chosen by.
pub(super) fn train_bic(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(f64, Vec<f64>)> {
    let rows = all_rows(trials);
    let x = solve(d, trials, &rows, cfg, hat)?;
    let mut buf = Vec::new();
    let rss: f64 = rows.iter().map(|&(i, j)| (trials[i].v[j] - predict(d, i, &trials[i], trials[i].t[j], &x, cfg, hat, &mut buf)).powi(2)).sum();
    let (n, p) = (rows.len() as f64, (d.ncols(cfg) + usize::from(cfg.clip.is_some())) as f64);
    Some((n * (rss / n).max(1e-300).ln() + p * n.ln(), x))
}

/// A held-out trial's own columns (its offset, and its gains and rest relaxation when the model has
/// them), fitted on the samples before its first step and its odd segments (for scoring the even
/// ones), and on those before and its even segments (for the odd ones), by least squares on the
/// residual of the fold's model without them. Returns (columns, values per parity).
///
/// A rest relaxation's amplitude is fitted (with the others) only on the samples before the trial's
/// first unloading, then held while the offset and gains are fitted on all of the parity: a trial's
/// rest state acts from its start, and the load's history (a peak's memory) acts only once the load
/// has come down, so a per-trial decay fitted there cannot stand in for a shared effect of the
/// unloading half (with its offset, it otherwise mimics a raised unloading branch).
pub(super) fn trial_terms_halves(d: &Design, k: usize, tr: &Trial, xk: &[f64], cfg: &Config, hat: &Hat) -> (Vec<usize>, [Vec<f64>; 2]) {
    let mut cols = vec![k];
    if d.n_gains(cfg) > 0 {
        cols.extend((0..GAIN_COLS).map(|c| d.gain_col(cfg) + GAIN_COLS * k + c));
    }
    let rest = d.n_rests(cfg) > 0;
    if rest {
        cols.push(d.rest_col(cfg) + k);
    }
    let m = cols.len();
    let mut x = xk.to_vec();
    cols.iter().for_each(|&c| x[c] = 0.0);
    // per parity: the normal equations over all its rows, and over those before the first unloading
    let zero = || (DMatrix::<f64>::zeros(m, m), DVector::<f64>::zeros(m));
    let mut all = [zero(), zero()];
    let mut rising = [zero(), zero()];
    let first_down = tr.segs.iter().position(|s| s.load < s.prev).unwrap_or(tr.segs.len());
    let mut buf = Vec::new();
    let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
    for j in 0..tr.t.len() {
        let seg = tr.segs.iter().filter(|s| s.t0 <= tr.t[j]).count();
        if (seg == 0 && tr.t[j] >= t_first - SCORED_BEFORE_ONSET_S) || at_jump(tr, tr.t[j]) || !usable(k, tr, j, cfg) {
            continue;
        }
        let e = tr.v[j] - predict(d, k, tr, tr.t[j], &x, cfg, hat, &mut buf);
        let c = DVector::from_iterator(m, cols.iter().map(|&q| buf[q]));
        let (cc, ce) = (&c * c.transpose(), &c * e);
        // fitted on this segment's parity, used for the other's; before the first step, for both
        for p in 0..2 {
            if seg == 0 || p != seg % 2 {
                all[p].0 += &cc;
                all[p].1 += &ce;
                if rest && seg <= first_down {
                    rising[p].0 += &cc;
                    rising[p].1 += &ce;
                }
            }
        }
    }
    let vals = [0, 1].map(|p| {
        if !rest {
            return solve_small(&all[p].0, &all[p].1);
        }
        // the gains from all of it without the rest (on the rising part alone the level grows with
        // time, as a decay falls: the two are confounded there); with them held, the offset and
        // the rest's amplitude from the rising part; then the offset and gains on all of it with
        // the amplitude held
        let (a, r) = (&all[p].0, &all[p].1);
        let others: Vec<usize> = (0..m - 1).collect();
        let g = solve_sub(a, r, &others, &[]);
        let held: Vec<(usize, f64)> = (1..m - 1).map(|q| (q, g[q])).collect();
        let amp = solve_sub(&rising[p].0, &rising[p].1, &[0, m - 1], &held)[1];
        let mut v = solve_sub(a, r, &others, &[(m - 1, amp)]);
        v.push(amp);
        v
    });
    (cols, vals)
}

/// The normal equations `a x = r` solved for the columns `free`, with the columns of `held` fixed
/// at their values (the other columns left out); the free columns' values in their order.
fn solve_sub(a: &DMatrix<f64>, r: &DVector<f64>, free: &[usize], held: &[(usize, f64)]) -> Vec<f64> {
    let n = free.len();
    let af = DMatrix::from_fn(n, n, |i, j| a[(free[i], free[j])]);
    let rf = DVector::from_fn(n, |i, _| r[free[i]] - held.iter().map(|&(q, v)| a[(free[i], q)] * v).sum::<f64>());
    solve_small(&af, &rf)
}

/// A small symmetric system solved by Cholesky with a relative ridge of 1e-9 (zeros when singular).
fn solve_small(a: &DMatrix<f64>, r: &DVector<f64>) -> Vec<f64> {
    let m = r.len();
    let mut ap = a.clone();
    let scale = 1e-9 * (0..m).map(|q| ap[(q, q)]).sum::<f64>().max(1e-300);
    for q in 0..m {
        ap[(q, q)] += scale;
    }
    ap.cholesky().map(|ch| ch.solve(r).iter().copied().collect()).unwrap_or_else(|| vec![0.0; m])
}

/// Fit on everything (rmse, BIC) and on folds (held-out RMSE).
pub(super) fn score(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Score, Vec<f64>)> {
    score_on(d, trials, trials, cfg, hat)
}

/// A fold's solver: the coefficients fitted to the units `keep` accepts (and the diagonal of the
/// solve), with the penalty's support when given.
type Fold<'a> = dyn Fn(&dyn Fn(&(usize, usize)) -> bool, Option<&[f64]>) -> Option<(Vec<f64>, Vec<f64>)> + 'a;

/// Held-out squared errors: their sum and count, and per unit.
#[derive(Default)]
struct Held {
    sse: f64,
    n: usize,
    units: std::collections::BTreeMap<(usize, usize), f64>,
    within: std::collections::BTreeMap<(usize, usize, u64), f64>,
}

impl Held {
    fn add(&mut self, unit: (usize, usize), e: f64) {
        self.sse += e * e;
        self.n += 1;
        *self.units.entry(unit).or_default() += e * e;
    }

    /// A held-out trial's sample at `t_s` in the unit that starts at `start_s`: its unit's error
    /// and its block's (blocks counted from the unit's start).
    fn add_at(&mut self, unit: (usize, usize), (start_s, t_s): (f64, f64), e: f64) {
        self.add(unit, e);
        let block = ((t_s - start_s).max(0.0) / WITHIN_BLOCK_S) as u64;
        *self.within.entry((unit.0, unit.1, block)).or_default() += e * e;
    }
}

/// The held-out unit of a sample of a multi-trial set: its trial and the segment it falls in
/// (segments count from 1 at the first onset).
fn seg_of(tr: &Trial, t: f64) -> usize {
    tr.segs.iter().filter(|s| s.t0 <= t).count()
}

/// Fitted to `fit` (the same trials, possibly as given with handling spikes), scored on `trials`.
pub(super) fn score_on(d: &Design, fit: &[Trial], trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Score, Vec<f64>)> {
    let rows = all_rows(trials);
    let fit_rows = all_rows(fit);
    // the normal equations per unit, once: every fold is a sum of them (and the relaxation
    // spectrum's penalty is chosen within each fold, by leaving out one of its units at a time)
    let units_n = unit_normals(d, fit, &fit_rows, cfg, hat);
    let blocks = hold_blocks(trials);
    let fold = |keep: &dyn Fn(&(usize, usize)) -> bool, support: Option<&[f64]>| -> Option<(Vec<f64>, Vec<f64>)> {
        let parts: Vec<&Normal> = units_n.iter().filter(|(k, _)| keep(k)).map(|(_, n)| n).collect();
        let lambda = match &cfg.relax {
            Some(r) => r.lambda.unwrap_or_else(|| choose_lambda(d, cfg, &parts, support)),
            None => 0.0,
        };
        let mut sol = solve_normal(d, cfg, &sum_normals(d, cfg, &parts), support, lambda)?;
        raise_to_rail(d, fit, cfg, hat, &mut sol.0, &|k| units_n.keys().filter(|u| u.0 == k).all(|u| keep(u)));
        Some(sol)
    };
    let (x, full_diag) = fold(&|_| true, None)?;
    let mut buf = Vec::new();
    let (mut rss, mut n) = (0.0, 0usize);
    for &(i, j) in &rows {
        let e = trials[i].v[j] - predict(d, i, &trials[i], trials[i].t[j], &x, cfg, hat, &mut buf);
        rss += e * e;
        n += 1;
    }
    let p = d.ncols(cfg) + usize::from(cfg.clip.is_some());
    let bic = n as f64 * (rss / n as f64).max(1e-300).ln() + p as f64 * (n as f64).ln();
    let held = if trials.len() >= 2 {
        leave_trials_out(d, trials, cfg, hat, &fold)
    } else if blocks > 0 {
        forecast_blocks(d, &trials[0], cfg, hat, &fold, &full_diag, blocks)
    } else {
        leave_steps_out(d, &trials[0], cfg, hat, &fold, &full_diag)
    };
    let counts = unit_counts(trials, blocks);
    if !determined(trials, &held, &counts) {
        return None;
    }
    let unit_keys: Vec<(usize, usize)> = held.units.keys().copied().collect();
    let unit_n = unit_keys.iter().map(|k| counts.get(k).copied().unwrap_or(1).max(1)).collect();
    Some((
        Score {
            rmse: (rss / n.max(1) as f64).sqrt(),
            heldout_rmse: (held.sse / held.n.max(1) as f64).sqrt(),
            bic,
            params: p,
            n,
            units: held.units.into_values().collect(),
            unit_keys,
            unit_n,
            blocks,
            within: held.within.into_iter().collect(),
        },
        x,
    ))
}

/// Several trials: each held out in turn, predicted by the others' fit with its own offset (from its
/// samples before the first step) and its own per-trial terms validated inside it (fitted, with the
/// offset, on every other step of it and scored on the steps between, both halves in turn).
fn leave_trials_out(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat, fold: &Fold) -> Held {
    let mut held = Held::default();
    let mut buf = Vec::new();
    for k in 0..trials.len() {
        let Some((mut xk, _)) = fold(&|u| u.0 != k, None) else { continue };
        // the held-out trial's own offset, from its samples before the first step
        let tr = &trials[k];
        let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
        xk[k] = 0.0;
        let pre: Vec<f64> = (0..tr.t.len()).filter(|&j| tr.t[j] < t_first - SCORED_BEFORE_ONSET_S).map(|j| tr.v[j] - predict(d, k, tr, tr.t[j], &xk, cfg, hat, &mut buf)).collect();
        xk[k] = if pre.is_empty() { 0.0 } else { pre.iter().sum::<f64>() / pre.len() as f64 };
        let own = (d.n_gains(cfg) + d.n_rests(cfg) > 0).then(|| trial_terms_halves(d, k, tr, &xk, cfg, hat));
        for j in 0..tr.t.len() {
            if tr.t[j] >= t_first - SCORED_BEFORE_ONSET_S && !at_jump(tr, tr.t[j]) {
                let seg = seg_of(tr, tr.t[j]);
                if let Some((cols, vals)) = &own {
                    for (c, v) in cols.iter().zip(&vals[seg % 2]) {
                        xk[*c] = *v;
                    }
                }
                let e = tr.v[j] - predict(d, k, tr, tr.t[j], &xk, cfg, hat, &mut buf);
                let start_s = if seg == 0 { t_first - SCORED_BEFORE_ONSET_S } else { tr.segs[seg - 1].t0 };
                held.add_at((k, seg), (start_s, tr.t[j]), e);
            }
        }
    }
    held
}

/// One recording whose levels are not held in two steps each: the validation split inside the
/// trial, forward in time — each block of a hold after its first is predicted from the blocks
/// before it in the same hold and every other hold (a forecast: a trend the model leaves out shows
/// in every block, not only at a hold's ends).
fn forecast_blocks(d: &Design, tr: &Trial, cfg: &Config, hat: &Hat, fold: &Fold, full_diag: &[f64], blocks: usize) -> Held {
    let mut held = Held::default();
    let mut buf = Vec::new();
    let keys: std::collections::BTreeSet<(usize, usize)> = tr.t.iter().map(|&t| unit_key(tr, t, blocks)).filter(|k| k.1 > 0 && (k.1 - 1) % blocks > 0).collect();
    for u in keys {
        let (hold, block) = ((u.1 - 1) / blocks, (u.1 - 1) % blocks);
        let later = |x: &(usize, usize)| x.1 > 0 && (x.1 - 1) / blocks == hold && (x.1 - 1) % blocks >= block;
        let Some((xk, _)) = fold(&|x| !later(x), Some(full_diag)) else { continue };
        for j in (0..tr.t.len()).filter(|&j| unit_key(tr, tr.t[j], blocks) == u && !at_jump(tr, tr.t[j])) {
            let e = tr.v[j] - predict(d, 0, tr, tr.t[j], &xk, cfg, hat, &mut buf);
            held.add(u, e);
        }
    }
    held
}

/// One recording: each step left out in turn.
fn leave_steps_out(d: &Design, tr: &Trial, cfg: &Config, hat: &Hat, fold: &Fold, full_diag: &[f64]) -> Held {
    let mut held = Held::default();
    let mut buf = Vec::new();
    for s in 0..tr.segs.len() {
        let (a, b) = (tr.segs[s].t0, tr.seg_end(s));
        // the step's rows are unit s + 1 (segments count from the first onset)
        let Some((mut xk, _)) = fold(&|u| *u != (0, s + 1), Some(full_diag)) else { continue };
        // the held-out step's own time-constant correction has (almost) no training data:
        // predict it with the step's fitted τ
        if cfg.tau_free && !d.prior {
            xk[d.n_levels() + tr.segs[s].key] = 0.0;
            // so has its onset shift, when its onset is refitted: its column is zero on every
            // training row, and the solver's value for it is whatever the penalty left
            if let Some(q) = d.refit_onset.iter().position(|&k| k == (0, s)) {
                xk[d.n_levels() + d.n_keys + q] = 0.0;
            }
        }
        for j in 0..tr.t.len() {
            if tr.t[j] >= a && tr.t[j] < b && !at_jump(tr, tr.t[j]) {
                let e = tr.v[j] - predict(d, 0, tr, tr.t[j], &xk, cfg, hat, &mut buf);
                held.add((0, s), e);
            }
        }
    }
    held
}

/// Samples per held-out unit (as the units are formed for the trials at hand).
fn unit_counts(trials: &[Trial], blocks: usize) -> std::collections::BTreeMap<(usize, usize), usize> {
    let mut counts: std::collections::BTreeMap<(usize, usize), usize> = Default::default();
    if trials.len() >= 2 {
        for (k, tr) in trials.iter().enumerate() {
            let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
            for &t in tr.t.iter().filter(|&&t| t >= t_first - SCORED_BEFORE_ONSET_S) {
                *counts.entry((k, seg_of(tr, t))).or_default() += 1;
            }
        }
    } else if blocks > 0 {
        let tr = &trials[0];
        for &t in &tr.t {
            let k = unit_key(tr, t, blocks);
            if k.1 > 0 && !(k.1 - 1).is_multiple_of(blocks) {
                *counts.entry(k).or_default() += 1;
            }
        }
    } else {
        let tr = &trials[0];
        for (s, sg) in tr.segs.iter().enumerate() {
            let b = tr.seg_end(s);
            counts.insert((0, s), tr.t.iter().filter(|&&t| t >= sg.t0 && t < b).count());
        }
    }
    counts
}

/// Whether the folds determined what every unit needs: a fold that predicts a unit worse than any
/// constant inside the signal's range has not (a level held once or briefly, shape corrections
/// running off), and the model cannot be scored held out on these data.
fn determined(trials: &[Trial], held: &Held, counts: &std::collections::BTreeMap<(usize, usize), usize>) -> bool {
    let (lo, hi) = trials.iter().flat_map(|tr| tr.v.iter().copied()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    let range = (hi - lo).max(0.0);
    !held.units.iter().any(|(k, &e)| {
        let rms = (e / counts.get(k).copied().unwrap_or(1).max(1) as f64).sqrt();
        !rms.is_finite() || rms > range
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leave one trial out: a unit per trial and segment, and a trial whose whole level is offset
    /// (another day's zero) is predicted with its own offset from its samples before the first
    /// step, so the offset costs the held-out score nothing.
    #[test]
    fn a_held_out_trial_brings_its_own_offset() {
        let mut recs = fixture::recs(91_000, |_| {});
        let b = fixture::built(&recs);
        let (s, _) = score(&b.d, &b.trials, &b.base_cfg, &b.hat).unwrap();
        assert_eq!(s.units.len(), 3 * 11, "{:?}", s.unit_keys);
        assert!(s.heldout_rmse < 3e-3 && s.heldout_rmse >= 0.8 * s.rmse, "{} / {}", s.heldout_rmse, s.rmse);
        recs[1].response.iter_mut().for_each(|v| *v += 0.05);
        let b2 = fixture::built(&recs);
        let (s2, x2) = score(&b2.d, &b2.trials, &b2.base_cfg, &b2.hat).unwrap();
        let (_, x) = score(&b.d, &b.trials, &b.base_cfg, &b.hat).unwrap();
        assert!(((x2[1] - x[1]) - 0.05).abs() < 2e-3, "the shift reached the trial's offset: {} -> {}", x[1], x2[1]);
        assert!(s2.heldout_rmse < 1.1 * s.heldout_rmse, "{} -> {}", s.heldout_rmse, s2.heldout_rmse);
        // the shift is there to be absorbed: the fit's own offsets took it (the trial's offset moved)
        assert!(s2.rmse < 1.1 * s.rmse);
    }
}
