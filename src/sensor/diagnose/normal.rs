//! Least squares from per-unit normal equations: every held-out fold is a sum of the units it
//! trains on, and the relaxation spectrum's penalty is chosen by leaving one training unit out at
//! a time (inner cross-validation). The units are trials, steps, or forward blocks of holds.

use super::*;

/// Least squares of the configuration on the given (trial, sample) rows.
pub(super) fn solve(d: &Design, trials: &[Trial], rows: &[(usize, usize)], cfg: &Config, hat: &Hat) -> Option<Vec<f64>> {
    solve_with(d, trials, rows, cfg, hat, None).map(|(x, _)| x)
}

/// A shape or term column holding less than this share of its energy on all the data is not
/// determined by a fold's training rows: it is left at zero there (the held-out step's own τ,
/// onset shift or term columns, whatever the penalty would leave otherwise).
pub(super) const MIN_FOLD_SUPPORT: f64 = 1e-3;

/// The normal equations of a set of rows: AᵀA (upper triangle), Aᵀy and yᵀy.
#[derive(Clone)]
pub(super) struct Normal {
    pub(super) ata: DMatrix<f64>,
    pub(super) aty: DVector<f64>,
    pub(super) yy: f64,
}

impl Normal {
    pub(super) fn zeros(p: usize) -> Self {
        Normal { ata: DMatrix::zeros(p, p), aty: DVector::zeros(p), yy: 0.0 }
    }
    pub(super) fn add(&mut self, o: &Normal) {
        self.ata += &o.ata;
        self.aty += &o.aty;
        self.yy += o.yy;
    }
    pub(super) fn sub(&self, o: &Normal) -> Normal {
        Normal { ata: &self.ata - &o.ata, aty: &self.aty - &o.aty, yy: self.yy - o.yy }
    }
    /// The squared error of coefficients x on these rows (no clip).
    pub(super) fn sse(&self, x: &[f64]) -> f64 {
        let p = x.len();
        let mut q = 0.0;
        for a in 0..p {
            q += self.ata[(a, a)] * x[a] * x[a];
            for b in a + 1..p {
                q += 2.0 * self.ata[(a, b)] * x[a] * x[b];
            }
        }
        self.yy - 2.0 * x.iter().zip(self.aty.iter()).map(|(u, v)| u * v).sum::<f64>() + q
    }
}

/// Adds the usable rows to the normal equations.
pub(super) fn accumulate(d: &Design, trials: &[Trial], rows: &[(usize, usize)], cfg: &Config, hat: &Hat, n: &mut Normal) {
    let p = d.ncols(cfg);
    let mut r = Vec::new();
    let mut nz: Vec<usize> = Vec::with_capacity(p);
    for &(i, j) in rows {
        let tr = &trials[i];
        if !usable(i, tr, j, cfg) {
            continue;
        }
        d.row(i, tr, tr.t[j], cfg, hat, &mut r);
        // rows are sparse (a step's shape columns are zero before it): the upper triangle over the
        // row's nonzero columns
        nz.clear();
        nz.extend((0..p).filter(|&a| r[a] != 0.0));
        let y = tr.v[j] - tr.prior(tr.t[j]) - clip_offset(i, tr, tr.t[j], cfg);
        n.yy += y * y;
        for (ai, &a) in nz.iter().enumerate() {
            n.aty[a] += r[a] * y;
            for &b in &nz[ai..] {
                n.ata[(a, b)] += r[a] * r[b];
            }
        }
    }
}

/// Fewest blocks each hold is cut into when one recording's load levels are not each held in at
/// least two steps (a single step up and down): leaving a step out would leave its level without
/// data.
pub(super) const HOLD_BLOCKS: usize = 10;

/// Most blocks per hold.
pub(super) const MAX_HOLD_BLOCKS: usize = 30;

/// Shortest block, in seconds, when long holds are cut into more than [`HOLD_BLOCKS`]: far longer
/// than a sensor's noise stays correlated (a second or so), so the blocks are about independent
/// units of the paired test. With ten blocks a hold of ten minutes is nine units, and an effect
/// the read-out shows in one hold only (a creep at the divider's top is compressed, its recovery
/// at zero load is not) could never reach the test's z however large its gain.
pub(super) const HOLD_BLOCK_S: f64 = 15.0;

/// The blocks per hold when the held-out units are blocks of holds, else 0: [`HOLD_BLOCKS`], or
/// as many blocks of at least [`HOLD_BLOCK_S`] as the shortest hold has room for (at most
/// [`MAX_HOLD_BLOCKS`]).
pub(super) fn hold_blocks(trials: &[Trial]) -> usize {
    let [tr] = trials else { return 0 };
    let held = |l: f64| tr.segs.iter().filter(|s| s.load == l).count();
    if !tr.segs.iter().any(|s| held(s.load) < 2) {
        return 0;
    }
    let end = tr.t.last().copied().unwrap_or(0.0);
    let shortest = (0..tr.segs.len()).map(|s| tr.segs.get(s + 1).map(|g| g.t0).unwrap_or(end) - tr.segs[s].t0).fold(f64::INFINITY, f64::min);
    let by_time = if shortest.is_finite() { (shortest / HOLD_BLOCK_S).floor() as usize } else { 0 };
    by_time.clamp(HOLD_BLOCKS, MAX_HOLD_BLOCKS)
}

/// The block unit of a sample of a single recording: (0, 0) before the first onset, else
/// (0, 1 + s·blocks + b) for block b of hold s.
pub(super) fn unit_key(tr: &Trial, t: f64, blocks: usize) -> (usize, usize) {
    let s = tr.segs.iter().filter(|g| g.t0 <= t).count();
    if s == 0 {
        return (0, 0);
    }
    let a = tr.segs[s - 1].t0;
    let b = tr.segs.get(s).map(|g| g.t0).unwrap_or_else(|| tr.t.last().copied().unwrap_or(a) + 1e-9);
    let k = (((t - a) / (b - a).max(1e-12)) * blocks as f64).floor().clamp(0.0, blocks as f64 - 1.0) as usize;
    (0, 1 + (s - 1) * blocks + k)
}

/// The normal equations per unit (trial, segment counted from 1 at the first onset; rows before
/// the first step are segment 0), the units the held-out folds leave out.
pub(super) fn unit_normals(d: &Design, trials: &[Trial], rows: &[(usize, usize)], cfg: &Config, hat: &Hat) -> std::collections::BTreeMap<(usize, usize), Normal> {
    let mut by: std::collections::BTreeMap<(usize, usize), Vec<(usize, usize)>> = Default::default();
    let blocks = hold_blocks(trials);
    for &(i, j) in rows {
        let tr = &trials[i];
        let key = if blocks > 0 { unit_key(tr, tr.t[j], blocks) } else { (i, tr.segs.iter().filter(|s| s.t0 <= tr.t[j]).count()) };
        by.entry(key).or_default().push((i, j));
    }
    let p = d.ncols(cfg);
    by.into_iter()
        .map(|(k, rs)| {
            let mut n = Normal::zeros(p);
            accumulate(d, trials, &rs, cfg, hat, &mut n);
            (k, n)
        })
        .collect()
}

/// [`solve`], also returning the normal matrix's diagonal (each column's energy on `rows`); with
/// `support` (that diagonal on all the data), columns under MIN_FOLD_SUPPORT of it are left at 0.
/// A relaxation spectrum without its penalty gets it by inner cross-validation on these rows.
pub(super) fn solve_with(d: &Design, trials: &[Trial], rows: &[(usize, usize)], cfg: &Config, hat: &Hat, support: Option<&[f64]>) -> Option<(Vec<f64>, Vec<f64>)> {
    if cfg.relax.as_ref().is_some_and(|r| r.lambda.is_none()) {
        let units = unit_normals(d, trials, rows, cfg, hat);
        let parts: Vec<&Normal> = units.values().collect();
        let lambda = choose_lambda(d, cfg, &parts, support);
        return solve_normal(d, cfg, &sum_normals(d, cfg, &parts), support, lambda);
    }
    let mut n = Normal::zeros(d.ncols(cfg));
    accumulate(d, trials, rows, cfg, hat, &mut n);
    solve_normal(d, cfg, &n, support, cfg.relax.as_ref().and_then(|r| r.lambda).unwrap_or(0.0))
}

pub(super) fn sum_normals(d: &Design, cfg: &Config, parts: &[&Normal]) -> Normal {
    let mut n = Normal::zeros(d.ncols(cfg));
    for p in parts {
        n.add(p);
    }
    n
}

/// The relaxation penalties tried by inner cross-validation (relative to the spectrum's mean
/// column energy).
pub(super) const LAMBDAS: [f64; 15] = [1e-5, 3.16e-5, 1e-4, 3.16e-4, 1e-3, 3.16e-3, 1e-2, 3.16e-2, 1e-1, 3.16e-1, 1.0, 3.16, 10.0, 31.6, 100.0];

/// The relaxation penalty with the least leave-one-unit-out error over `parts` (each part's
/// error from the fit to all the others).
pub(super) fn choose_lambda(d: &Design, cfg: &Config, parts: &[&Normal], support: Option<&[f64]>) -> f64 {
    lambda_cv(d, cfg, parts, support).0
}

/// [`choose_lambda`] with its cross-validated error.
pub(super) fn lambda_cv(d: &Design, cfg: &Config, parts: &[&Normal], support: Option<&[f64]>) -> (f64, f64) {
    if parts.len() < 3 {
        return (LAMBDAS[LAMBDAS.len() / 2], f64::INFINITY);
    }
    let total = sum_normals(d, cfg, parts);
    // a column the inner folds' data hardly hold (the left-out step's own shape) is left at zero
    let own: Vec<f64> = (0..total.aty.len()).map(|a| total.ata[(a, a)]).collect();
    let support = Some(support.unwrap_or(&own));
    let rest: Vec<Normal> = parts.iter().map(|m| total.sub(m)).collect();
    let cv_at = |lambda: f64| -> f64 {
        let mut cv = 0.0;
        for (m, r) in parts.iter().zip(&rest) {
            match solve_normal(d, cfg, r, support, lambda) {
                Some((x, _)) => cv += m.sse(&x),
                None => return f64::INFINITY,
            }
        }
        cv
    };
    // the decades first, then the half decades either side of the best of them
    let mut best = (f64::INFINITY, LAMBDAS[LAMBDAS.len() / 2]);
    let mut best_i = LAMBDAS.len() / 2;
    for i in (0..LAMBDAS.len()).step_by(2) {
        let cv = cv_at(LAMBDAS[i]);
        if cv < best.0 {
            (best, best_i) = ((cv, LAMBDAS[i]), i);
        }
    }
    for i in [best_i.wrapping_sub(1), best_i + 1].into_iter().filter(|&i| i < LAMBDAS.len()) {
        let cv = cv_at(LAMBDAS[i]);
        if cv < best.0 {
            best = (cv, LAMBDAS[i]);
        }
    }
    (best.1, best.0)
}

/// Solves normal equations (upper triangle given), with the relaxation spectrum's smoothness
/// penalty at `lambda`.
pub(super) fn solve_normal(d: &Design, cfg: &Config, n: &Normal, support: Option<&[f64]>, lambda: f64) -> Option<(Vec<f64>, Vec<f64>)> {
    let p = d.ncols(cfg);
    let mut ata = n.ata.clone();
    let mut aty = n.aty.clone();
    for a in 0..p {
        for b in 0..a {
            ata[(a, b)] = ata[(b, a)];
        }
    }
    let diag: Vec<f64> = (0..p).map(|a| ata[(a, a)]).collect();
    if let Some(full) = support {
        // levels are kept: a level seen only in another step's transient is still better
        // estimated from it than set to zero (a top load held once, on long holds)
        for a in (d.n_levels()..p).filter(|&a| diag[a] < MIN_FOLD_SUPPORT * full[a]) {
            for b in 0..p {
                ata[(a, b)] = 0.0;
                ata[(b, a)] = 0.0;
            }
            aty[a] = 0.0;
        }
    }
    // a column without data, or, with a clip, a level with none to speak of (reached only through
    // transients settled to 1e-9 of its step: a load whose every sample sits at the clip), which is
    // left out of the solve and set to the clip below
    let level_scale = (d.n_trials..d.n_levels()).map(|a| ata[(a, a)]).fold(0.0, f64::max);
    let empty: Vec<bool> = (0..p).map(|a| ata[(a, a)] == 0.0 || (cfg.clip.is_some() && a >= d.n_trials && a < d.n_levels() && ata[(a, a)] < 1e-9 * level_scale)).collect();
    for a in (0..p).filter(|&a| empty[a]) {
        for b in 0..p {
            ata[(a, b)] = 0.0;
            ata[(b, a)] = 0.0;
        }
        aty[a] = 0.0;
    }
    if let (Some(rx), true) = (&cfg.relax, cfg.effects.contains(&Effect::Relaxation)) {
        let (k, m) = (rx.taus.len(), rx.sets() * rx.taus.len());
        let c0 = term_col(d, cfg, Effect::Relaxation);
        let scale = mean_diagonal(&ata, c0..c0 + m);
        let pen = catalogue::relaxation::smoothness(k, rx.sets());
        for a in 0..m {
            for b in 0..m {
                ata[(c0 + a, c0 + b)] += lambda * scale * pen[a * m + b];
            }
        }
        // a faint ridge keeps the spectrum determined where the data and the smoothness leave it
        // free (a kernel set with no change of its kind)
        faint_ridge(&mut ata, c0..c0 + m, scale);
    }
    // the per-trial gains and the shared levels trade one common factor: a faint ridge on the gains
    // leaves it with the levels (the gains' mean near zero); the rests' columns follow the gains'
    let ng = d.n_gains(cfg);
    if ng > 0 {
        let cols = d.gain_col(cfg)..d.gain_col(cfg) + ng;
        let scale = mean_diagonal(&ata, cols.clone());
        faint_ridge(&mut ata, cols, scale);
    }
    // tiny ridge keeps columns without data (a load absent from a fold) solvable at zero
    for a in 0..p {
        ata[(a, a)] += 1e-12 * (1.0 + ata[(a, a)]);
    }
    let mut x: Vec<f64> = ata.cholesky()?.solve(&aty).iter().copied().collect();
    // with a clip, a load whose samples all sit at the clip has a level no sample constrains: it
    // lies somewhere above the clip, and the prediction there is the clip either way
    if let (Some(c), false) = (cfg.clip, d.prior) {
        let n = d.n_trials;
        let offset = x[..n].iter().sum::<f64>() / n as f64;
        for col in n..d.n_levels() {
            if empty[col] {
                x[col] = c - offset;
            }
        }
    }
    Some((x, diag))
}

/// The mean of `ata`'s diagonal over the columns `cols` (not empty).
fn mean_diagonal(ata: &DMatrix<f64>, cols: std::ops::Range<usize>) -> f64 {
    let n = cols.len() as f64;
    cols.map(|a| ata[(a, a)]).sum::<f64>() / n
}

/// A faint ridge on the columns `cols`, 10⁻⁶ of `scale` (their mean diagonal before any penalty):
/// it settles what the data leave free there and nothing else.
fn faint_ridge(ata: &mut DMatrix<f64>, cols: std::ops::Range<usize>, scale: f64) {
    for a in cols {
        ata[(a, a)] += 1e-6 * scale.max(1e-300);
    }
}

/// The final refit of the first-order part's shape: every step's onset and every step key's time
/// constant, by Gauss–Newton on their linearised shifts (fitted with everything else) until the
/// shifts are below 0.1 ms and 0.01 % (at most 12 rounds). An onset stays within ±0.1 s of its
/// part-1 value and a time constant within a factor 2 (each round's change within ±30 %), so an
/// onset stays an onset; then the model is refitted at the shifted shape. Part 1 fitted each
/// step's onset and time constant with the first-order shape alone, which the terms change (a
/// second relaxation lengthens the apparent τ). Returns the trials with their shifted steps and
/// the fit.
pub(super) fn refit_onsets(d: &Design, fit: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Vec<Trial>, Vec<f64>)> {
    let all: Vec<(usize, usize)> = fit.iter().enumerate().flat_map(|(k, tr)| (0..tr.segs.len()).map(move |s| (k, s))).collect();
    let df = Design { refit_onset: all.clone(), exact_shape: true, ..d.clone() };
    let mut shifted = fit.to_vec();
    let off = df.n_levels() + df.n_keys;
    let free_tau = cfg.tau_free && !d.prior;
    for _ in 0..12 {
        let x = solve(&df, &shifted, &all_rows(&shifted), cfg, hat)?;
        let mut moved = 0f64;
        for (q, &(k, s)) in all.iter().enumerate() {
            let was = &fit[k].segs[s];
            let sg = &mut shifted[k].segs[s];
            // a step whose edge lost a handling spike keeps its own linearised onset column (in
            // `d`): with the edge's samples gone its onset is weakly determined, and iterating on
            // it raised the spike cells' error to the truth (1σ: 0.14 → 0.20 × the baseline's)
            if !d.refit_onset.contains(&(k, s)) && !is_jump(&fit[k], was) {
                let t0 = (sg.t0 + x[off + q]).clamp(was.t0 - 0.1, was.t0 + 0.1);
                moved = moved.max((t0 - sg.t0).abs() / 1e-4);
                sg.t0 = t0;
            }
            if free_tau && cfg.fixed(k, s).is_none() && !is_jump(&fit[k], was) {
                // the column's coefficient is −Δ ln τ
                let tau = (sg.tau * (-x[df.n_levels() + sg.key].clamp(-0.3, 0.3)).exp()).clamp(was.tau / 4.0, was.tau * 4.0);
                moved = moved.max((tau / sg.tau).ln().abs() / 1e-4);
                sg.tau = tau;
            }
        }
        if moved < 1.0 {
            break;
        }
    }
    // the same design at raw samples (half span 0), where predictions are made, has the same columns
    let x2 = solve(&Design { exact_shape: true, ..d.clone() }, &shifted, &all_rows(&shifted), cfg, hat)?;
    Some((shifted, x2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The normal equations are a sum over units: summed, they give the solution of all the rows;
    /// a fold (one trial left out) is a sum of fewer of them and gives another.
    #[test]
    fn folds_are_sums_of_unit_normal_equations() {
        let b = fixture::built(&fixture::recs(91_000, |_| {}));
        let rows = all_rows(&b.trials);
        let x = solve(&b.d, &b.trials, &rows, &b.base_cfg, &b.hat).unwrap();
        let units = unit_normals(&b.d, &b.trials, &rows, &b.base_cfg, &b.hat);
        let all: Vec<&Normal> = units.values().collect();
        let (x_sum, _) = solve_normal(&b.d, &b.base_cfg, &sum_normals(&b.d, &b.base_cfg, &all), None, 0.0).unwrap();
        let scale = x.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(x.iter().zip(&x_sum).all(|(a, b)| (a - b).abs() < 1e-6 * scale), "{x:?} vs {x_sum:?}");
        let fold: Vec<&Normal> = units.iter().filter(|(k, _)| k.0 != 0).map(|(_, n)| n).collect();
        let (x_fold, _) = solve_normal(&b.d, &b.base_cfg, &sum_normals(&b.d, &b.base_cfg, &fold), None, 0.0).unwrap();
        let n_levels = b.d.n_levels();
        assert!(x_fold[3..n_levels].iter().zip(&x[3..n_levels]).any(|(a, b)| (a - b).abs() > 1e-9), "a fold without a trial fits the same levels");
    }

    /// The per-trial gains and the shared levels trade one common factor, which the gains' faint
    /// ridge leaves with the levels: the gains' mean change of level stays near zero whether or not
    /// the trials' rest relaxations (whose columns follow the gains') are in the model. (The ridge
    /// was put on the last columns, the rests' and part of the gains', when both were there: it
    /// pinned the third trial's gain instead of the gains' mean, which was then 0.037.)
    #[test]
    fn the_gains_ridge_is_on_the_gains_columns() {
        let recs = fixture::recs(91_100, |s| s.nuisance.gain_jitter = 0.03);
        let b = fixture::built(&recs);
        let rows = all_rows(&b.trials);
        let gains = Config { gains: true, ..b.base_cfg.clone() };
        let both = Config { rest_tau: Some(100.0), ..gains.clone() };
        let mean_gain = |c: &Config| {
            let x = solve(&b.d, &b.trials, &rows, c, &b.hat).unwrap();
            let g0 = b.d.gain_col(c);
            (0..b.d.n_trials).map(|k| x[g0 + GAIN_COLS * k]).sum::<f64>() / b.d.n_trials as f64
        };
        let (alone, with_rests) = (mean_gain(&gains), mean_gain(&both));
        assert!(alone.abs() < 1e-3 && with_rests.abs() < 1e-3, "the gains' mean change of level: {alone} alone, {with_rests} with the rests");
    }
}
