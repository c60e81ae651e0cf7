//! The catalogue's terms as candidates of the model: each effect added to a configuration with its
//! shape parameters chosen on the training fit (τ2 and drive of a second relaxation, a warm-up's τ,
//! a clip), or removed with them.

use super::*;

/// The second time constant's candidates, in multiples of the steps' median τ (a geometric grid).
pub(super) const TAU2_STEP: f64 = 1.371;
pub(super) const TAU2_GRID: [f64; 9] = [2.0, 2.742, 3.759, 5.154, 7.067, 9.689, 13.28, 18.21, 24.97];

/// How far beyond [`TAU2_GRID`] a second relaxation's τ2 is tried: up to this many median spacings
/// of the steps (a hold). A relaxation slower than the steps' own τ need not be near it: one of
/// 100 s under 40 g steps (part-1 τ about 0.45 s, so the grid's top about 11 s; tuning seed
/// 28 320) gained 17 % held out there, and a drift (23 %) took its place and was renamed creep.
pub(super) const TAU2_HOLDS: f64 = 3.0;

/// The second relaxation's τ2 candidates (s): [`TAU2_GRID`] times `tau2_scale`, then on in steps of
/// [`TAU2_STEP`]² (so that the refinement, one [`TAU2_STEP`] either side, still covers every τ2
/// between them) to the first at or past [`TAU2_HOLDS`] median spacings of the steps.
pub(super) fn tau2_grid(tau2_scale: f64, trials: &[Trial]) -> Vec<f64> {
    let mut grid: Vec<f64> = TAU2_GRID.iter().map(|m| m * tau2_scale).collect();
    let mut spacing = step_spacings_s(trials);
    if spacing.is_empty() {
        return grid;
    }
    let top = TAU2_HOLDS * crate::sensor::preprocess::median(&mut spacing);
    while let Some(&last) = grid.last().filter(|&&l| l < top && l.is_finite() && l > 0.0) {
        grid.push(last * TAU2_STEP * TAU2_STEP);
    }
    grid
}

/// τ2 of the second relaxation refined by golden-section search in log τ2 within one grid step
/// either side of the chosen value (within the grid's ends, [`tau2_grid`]), on the training BIC (the number of parameters is the same
/// throughout, so this is the training RSS). Returns the refined configuration and its score.
pub(super) fn refine_tau2(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Config, Score, Vec<f64>)> {
    let at = |ln_tau2: f64| {
        let mut c = cfg.clone();
        c.tau2 = ln_tau2.exp();
        train_bic(d, trials, &c, hat).map(|(b, _)| b).unwrap_or(f64::INFINITY)
    };
    // 10 steps shrink the bracket to 0.8 % of a grid step (0.3 % in τ2); never past the grid's
    // ends (refined again after every refit, τ2 would otherwise walk a step further each time)
    let (lo, hi) = tau2_ends(tau2_scale(trials), trials, cfg.drive);
    let (lo, hi) = (lo.ln().min(cfg.tau2.ln()), hi.ln().max(cfg.tau2.ln()));
    let br = crate::sensor::golden::golden(at, (cfg.tau2.ln() - TAU2_STEP.ln()).max(lo), (cfg.tau2.ln() + TAU2_STEP.ln()).min(hi), 10, 0.0);
    let (best, f_best) = br.best();
    let base = at(cfg.tau2.ln());
    if f_best >= base {
        return None;
    }
    let mut c = cfg.clone();
    c.tau2 = best.exp();
    let (s, x) = score(d, trials, &c, hat)?;
    Some((c, s, x))
}

/// What the forward step needs to propose a term: the design, the trials, the levels, the clip
/// and the median first-order τ (the second relaxation's grid is relative to it).
pub(super) struct Ctx<'a> {
    pub(super) d: &'a Design,
    pub(super) trials: &'a [Trial],
    pub(super) hat: &'a Hat,
    pub(super) clip: Option<f64>,
    pub(super) clip_steps: &'a ClipSteps,
    /// What a second relaxation's τ2 grid is relative to (`model::tau2_scale`).
    pub(super) tau2_scale: f64,
}

/// The model `cur` with effect `e` added, its shape parameters chosen on the training fit (not on
/// held-out data): the second relaxation's τ2 and drive on their grid, a clip at the recording's
/// level, a rest relaxation's τ; a second relaxation already in the model has its form (in the
/// response or in the conductance) and τ2 chosen again jointly with the new term's shape, or, when
/// its form cannot change, its τ2 refitted after it (`refit_tau2`).
pub(super) fn candidate(e: Effect, cur: &Config, ctx: &Ctx) -> Option<Config> {
    let (d, trials, hat, clip, clip_steps, tau2_scale) = (ctx.d, ctx.trials, ctx.hat, ctx.clip, ctx.clip_steps, ctx.tau2_scale);
    let cands: Vec<Config> = match e {
        Effect::RestRelaxation => nuisance::rest_candidates(d, trials, cur),
        // with the change, its size, or the change of the conductance seen through the read-out
        // (when every trial says how its response maps to the conductance)
        Effect::SecondTimeConstant => {
            let drives: Vec<Drive> = [Drive::Change, Drive::Size, Drive::Through].into_iter().filter(|&drive| drive != Drive::Through || through_known(trials)).collect();
            let mut c = cur.clone();
            c.effects.push(e);
            on_tau2_grid(&c, &drives, &tau2_grid(tau2_scale, trials))
        }
        Effect::BaselineDrift => {
            // linear, or a warm-up on a log grid of τ up to the longest trial (a longer one is a
            // line over the recording)
            let longest = trials.iter().map(Trial::span_s).fold(0.0, f64::max);
            std::iter::once(None)
                .chain(catalogue::baseline_drift::WARMUP_TAUS_S.iter().filter(|&&tau| tau <= longest).map(|&tau| Some(tau)))
                .map(|tau| {
                    let mut c = cur.clone();
                    c.effects.push(e);
                    c.drift_tau = tau;
                    c
                })
                .collect()
        }
        Effect::Saturation => {
            let mut c = cur.clone();
            c.effects.push(e);
            c.clip = clip;
            c.tau_fixed = clip.map(|level| clip_fixes(trials, level, clip_steps)).unwrap_or_default();
            c.restart = clip_steps.from.clone();
            c.clip_rail = clip_steps.rail;
            if let (Some(level), true) = (clip, clip_steps.rail) {
                let windows = rail_spans(trials, level, clip_steps, &c.tau_fixed);
                settle_rail_spans(d, trials, &mut c, hat, &windows);
            }
            vec![c]
        }
        Effect::Hysteresis => {
            // in the response, or in the sensor's conductance seen through the read-out (when every
            // trial says how its response maps to the conductance, as for the conductance's creep)
            let through = through_known(trials);
            [false, true]
                .into_iter()
                .filter(|&th| !th || through)
                .map(|th| {
                    let mut c = cur.clone();
                    c.effects.push(e);
                    c.hyst_through = th;
                    c
                })
                .collect()
        }
        _ => {
            let mut c = cur.clone();
            c.effects.push(e);
            vec![c]
        }
    };
    if e == Effect::SecondTimeConstant || !cur.effects.contains(&Effect::SecondTimeConstant) {
        return pick_on_training(e, cands, ctx).map(|(c, _)| c);
    }
    // a second relaxation already in the model: its form (in the response or in the conductance)
    // and τ2 on its grid are chosen again jointly with the new term's shape. A term left out
    // biases the form and τ2, and those chosen without the term bias the term's shape: family A's
    // second τ of the response (8 s) with a linear drift (tuning seeds) took the conductance's form
    // and τ2 12–17 s in the first round. With the drift's shape chosen beside that form and τ2, then
    // the form, then τ2 by a local search (stop 50), the drift took a warm-up of 20–80 s that
    // predicted held-out data worse (−3.9 %, z −4.6) or barely better (+4 %, z 1.2); with the form
    // chosen jointly and τ2 locally after, +8.6 % at z 2.3: the drift was never named (stop 50's
    // pairs: 0/8). A relaxation whose form cannot change (driven by the size of the change, or
    // without a read-out: only τ2 was biased, and a local search suffices) keeps stop 50's local
    // search: on the whole grid, a spurious second τ of the size of the change moved with a
    // hysteresis into a drift's place (family A's creep + drift pair, one case of eight).
    if cur.drive == Drive::Size || !through_known(trials) {
        let (c, b0) = pick_on_training(e, cands, ctx)?;
        return Some(refit_tau2(ctx, c, b0));
    }
    let grid = tau2_grid(tau2_scale, trials);
    let joint = cands.iter().flat_map(|c| on_tau2_grid(c, &[Drive::Change, Drive::Through], &grid)).collect();
    pick_on_training(e, joint, ctx).map(|(c, _)| c)
}

/// The configuration `c` with its second relaxation in each of `drives` and at each τ2 of `grid`
/// ([`tau2_grid`]) that the drive reaches ([`reach`]).
fn on_tau2_grid(c: &Config, drives: &[Drive], grid: &[f64]) -> Vec<Config> {
    drives.iter().flat_map(|&drive| reach(drive, grid).iter().map(move |&tau2| Config { drive, tau2, ..c.clone() })).collect()
}

/// The part of the τ2 grid a drive reaches. A relaxation of the change (or of the conductance's
/// change) acts alike after loading and unloading, and goes on past the steps' scale. One driven
/// by the size of the change, with its own share after loading and after unloading, stays on the
/// grid relative to the steps' τ ([`TAU2_GRID`]): slower, with a share after unloading alone, it is
/// a fading memory of the highest load (on a staircase, the peak's gap decays exactly so), which
/// the hysteresis names. (Reaching three holds, it took the name of family A's row 25 hysteresis,
/// fading in 240 s, on 2 of 8 tuning cases, seeds 36 980 and 37 010, which were then named creep.)
fn reach(drive: Drive, grid: &[f64]) -> &[f64] {
    if drive == Drive::Size {
        &grid[..TAU2_GRID.len().min(grid.len())]
    } else {
        grid
    }
}

/// The first and last τ2 (s) of the grid ([`tau2_grid`]) that `drive` reaches ([`reach`]).
fn tau2_ends(tau2_scale: f64, trials: &[Trial], drive: Drive) -> (f64, f64) {
    let grid = tau2_grid(tau2_scale, trials);
    let g = reach(drive, &grid);
    (g[0], g[g.len() - 1])
}

/// A second relaxation already in the model `c` (training BIC `b0`) whose form cannot change, its
/// τ2 refitted with a term just added (a term left out biases it — drift lengthens τ2) by a local
/// search in steps of the grid's ratio, within the grid's range.
fn refit_tau2(ctx: &Ctx, mut c: Config, mut b0: f64) -> Config {
    let (d, trials, hat) = (ctx.d, ctx.trials, ctx.hat);
    let (lo, hi) = tau2_ends(ctx.tau2_scale, trials, c.drive);
    loop {
        let mut moved = false;
        for f in [1.0 / TAU2_STEP, TAU2_STEP] {
            let mut cand = c.clone();
            cand.tau2 *= f;
            if cand.tau2 < lo * 0.99 || cand.tau2 > hi * 1.01 {
                continue;
            }
            if let Some((b, _)) = train_bic(d, trials, &cand, hat) {
                if b < b0 {
                    (c, b0, moved) = (cand, b, true);
                    break;
                }
            }
        }
        if !moved {
            break;
        }
    }
    c
}

/// Of the candidates `cands` of effect `e`, the one with the lowest training BIC, and that BIC
/// (shape parameters are chosen on the training fit, not on held-out data).
///
/// A second relaxation whose best τ2 is the last of its grid ([`tau2_grid`], past the steps' own
/// scale) is one the data do not bound: a trend slower than the recording shows, which a drift or
/// creep describes as well (a 0.3σ linear drift in 20 s holds took a second τ at 106 s, 27.2 %
/// better held out against the drift's 27.0 %). So is one past the steps' scale that creep fits as
/// well ([`creep_fits_as_well`]). Then τ2 is chosen on the grid relative to the steps' τ
/// ([`TAU2_GRID`]) alone, as before the grid went on.
fn pick_on_training(e: Effect, cands: Vec<Config>, ctx: &Ctx) -> Option<(Config, f64)> {
    let grid = tau2_grid(ctx.tau2_scale, ctx.trials);
    let (top, base_top) = (grid[grid.len() - 1], TAU2_GRID[TAU2_GRID.len() - 1] * ctx.tau2_scale);
    let at_top = |c: &Config| grid.len() > TAU2_GRID.len() && c.effects.contains(&Effect::SecondTimeConstant) && c.tau2 >= top * (1.0 - 1e-9);
    let bounded = |c: &Config| !c.effects.contains(&Effect::SecondTimeConstant) || c.tau2 <= base_top * (1.0 + 1e-9);
    let scored = scored_on_training(e, cands, ctx);
    let pick = scored.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    // (only where τ2 is chosen here: a term added beside a second relaxation whose τ2 is kept)
    let chosen_here = scored.iter().any(|(c, _)| c.tau2 != pick.0.tau2);
    if !chosen_here || (!at_top(&pick.0) && (bounded(&pick.0) || !creep_fits_as_well(&pick.0, pick.1, ctx))) {
        return Some(pick.clone());
    }
    let on_steps_grid = scored.iter().filter(|(c, _)| bounded(c)).min_by(|a, b| a.1.total_cmp(&b.1));
    on_steps_grid.or(Some(pick)).cloned()
}

/// Whether a creep in the second relaxation's place (superposed over the load history, or the
/// conductance's seen through the read-out, taken exactly) fits the training data at least as well
/// as the model `c` (training BIC `b`) does with its second relaxation: a relaxation slower than the
/// steps' scale that creep describes as well is creep's, and the second relaxation keeps to the
/// grid relative to the steps' τ. (With the grid going on to three holds, a conductance's creep of
/// 1.2 % per decade in 20 s holds was taken as a second relaxation and a hysteresis; the creep
/// seen through the read-out, tried in the slow terms' place after, then gained 0.3 % at z 0.8,
/// and the creep went unnamed: `through::tests`.)
fn creep_fits_as_well(c: &Config, b: f64, ctx: &Ctx) -> bool {
    let Some(idx) = c.effects.iter().position(|e| *e == Effect::SecondTimeConstant).filter(|_| !c.effects.contains(&Effect::Creep)) else { return false };
    let mut wo = without(c, idx);
    wo.effects.push(Effect::Creep);
    carried_creep_forms(&wo, ctx).iter().filter_map(|f| train_bic(ctx.d, ctx.trials, f, ctx.hat)).any(|(bf, _)| bf <= b)
}

/// The model `c` (creep in it) with its creep in the forms that carry over between steps: superposed
/// over the load history, and, when every trial's read-out is known, the conductance's creep
/// superposed and seen through the read-out, taken exactly.
pub(super) fn carried_creep_forms(c: &Config, ctx: &Ctx) -> Vec<Config> {
    let sup = Config { creep: CreepForm::Superposed, ..c.clone() };
    let through = through_known(ctx.trials).then(|| Config { creep: CreepForm::Through { at: None }, ..c.clone() }).and_then(|c| {
        let b = train_bic(ctx.d, ctx.trials, &c, ctx.hat)?.0;
        Some(through_exactly(ctx.d, ctx.trials, ctx.hat, (c, b)).0)
    });
    std::iter::once(sup).chain(through).collect()
}

/// The candidates `cands` of effect `e` with their training BIC (a second relaxation driven by the
/// size of the change only with one sign after loading and unloading alike).
fn scored_on_training(e: Effect, cands: Vec<Config>, ctx: &Ctx) -> Vec<(Config, f64)> {
    let (d, trials, hat) = (ctx.d, ctx.trials, ctx.hat);
    let mut out = Vec::new();
    for c in cands {
        if let Some((b, xc)) = train_bic(d, trials, &c, hat) {
            // a response to the size of the change has one sign after loading and
            // unloading alike; opposite signs are the change's own (signed) relaxation
            if e == Effect::SecondTimeConstant && c.drive == Drive::Size {
                let k = term_col(d, &c, e);
                if xc[k] * xc[k + 1] <= 0.0 {
                    continue;
                }
            }
            out.push((c, b));
        }
    }
    out
}

/// Whether every trial says how its response maps to the sensor's conductance (a read-out): the
/// terms' conductance forms are offered only then.
pub(super) fn through_known(trials: &[Trial]) -> bool {
    !trials.is_empty() && trials.iter().all(|tr| tr.readout.is_some())
}

/// The longest fading memory a hysteresis is given, in trials' lengths.
const MEMORY_PER_TRIAL: f64 = 4.0;

/// A hysteresis's peak memory in the final model: kept for good, or fading on a log grid of memory
/// times up to a few times the longest trial (`catalogue::hysteresis::MEMORY_S`; a longer one is
/// the permanent memory over the recording), chosen on the training fit (and refined between the
/// grid's neighbours by golden-section search in log memory) and taken only when it
/// predicts the held-out units better than the memory `cfg` has by a paired z of Z_SEPARATE (a
/// fading the data show; family A, 20 s holds, three trials: a 1 % hysteresis with a 60 s memory
/// (1.8σ) fits 61.5–62.8 s at z 3.1–3.6 and is taken; 0.3 % (0.55σ) fits 54–60 s at z 1.6–2.0
/// (taken in one case of two), and 1 % with 200 s fits 192–199 s at z 1.1–1.7 (kept for good); a
/// permanent 0.3 % would fade over 358–751 s at z 0.1–0.4). Not offered while the names are
/// chosen: there the fading form took a creep's place (family A, fading-memory row, tuning seed
/// 31 330: +12 % against creep's +1.6 %) and named no fading hysteresis the permanent form missed.
/// (Honest naming uses it once: a hysteresis set against a second relaxation on the virgin loading
/// branch, `alternatives::where_they_differ`.)
pub(super) fn refine_memory(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<Config> {
    let longest = trials.iter().map(Trial::span_s).fold(0.0, f64::max);
    let mut best: Option<(Config, f64)> = None;
    for m in std::iter::once(None).chain(catalogue::hysteresis::MEMORY_S.iter().filter(|&&m| m <= MEMORY_PER_TRIAL * longest).map(|&m| Some(m))) {
        let c = Config { hyst_memory_s: m, ..cfg.clone() };
        if let Some((b, _)) = train_bic(d, trials, &c, hat) {
            if best.as_ref().is_none_or(|p| b < p.1) {
                best = Some((c, b));
            }
        }
    }
    let (mut c, b) = best.filter(|(c, _)| c.hyst_memory_s != cfg.hyst_memory_s)?;
    // refined between the grid's neighbours (a factor of 2), in log memory, on the training fit
    if let Some(m) = c.hyst_memory_s {
        let at = |ln_m: f64| train_bic(d, trials, &Config { hyst_memory_s: Some(ln_m.exp()), ..cfg.clone() }, hat).map(|(b, _)| b).unwrap_or(f64::INFINITY);
        let (fine, f_fine) = crate::sensor::golden::golden(at, m.ln() - 2f64.ln(), m.ln() + 2f64.ln(), 10, 0.0).best();
        if f_fine < b {
            c.hyst_memory_s = Some(fine.exp());
        }
    }
    let (now, _) = score(d, trials, cfg, hat)?;
    let (then, _) = score(d, trials, &c, hat)?;
    (then.heldout_rmse < now.heldout_rmse && z_over(&now, &then) >= Z_SEPARATE).then_some(c)
}

/// The conductance's creep through the read-out taken exactly at its fitted size: the column's
/// size set to the fraction the training fit gives, refitted, until it holds (a few iterations;
/// each kept only while the training BIC falls).
pub(super) fn through_exactly(d: &Design, trials: &[Trial], hat: &Hat, (mut c, mut b0): (Config, f64)) -> (Config, f64) {
    let Some((_, mut x)) = train_bic(d, trials, &c, hat) else { return (c, b0) };
    for _ in 0..THROUGH_ITERATIONS {
        let k = term_col(d, &c, Effect::Creep);
        let Some(&at) = x.get(k).filter(|a| a.is_finite()) else { break };
        if c.creep.exact_at().is_some_and(|prev| (at - prev).abs() <= 0.01 * prev.abs()) {
            break;
        }
        let cand = Config { creep: CreepForm::Through { at: Some(at) }, ..c.clone() };
        match train_bic(d, trials, &cand, hat) {
            Some((b, xn)) if b < b0 => (c, b0, x) = (cand, b, xn),
            _ => break,
        }
    }
    (c, b0)
}

/// A rail's spans where the fitted model sits on it, per window (`windows`: trial, where to look
/// from, where the data first read the rail, to; a rise into the rail or a fall from it, from
/// `clip::rail_spans`): first from the data's reading, then, fitted without those samples, from
/// where the model reaches the rail (none where it stays under it: min(model, rail) is the model
/// there, and its samples are fitted), at most [`RAIL_ITERATIONS`] times (Gauss–Newton steps of
/// the clip, each a linear fit), until the spans no longer move. Of the spans fitted, those whose
/// fit leaves the least squared error of min(model, rail) over every sample are kept (the steps
/// may alternate when a level sits at the rail).
fn settle_rail_spans(d: &Design, trials: &[Trial], c: &mut Config, hat: &Hat, windows: &[(usize, f64, f64, f64)]) {
    let Some(rail) = c.clip else { return };
    c.rail_spans = windows.iter().map(|&(k, _, hit, end)| (k, hit, end)).collect();
    let rows = all_rows(trials);
    let mut buf = Vec::new();
    // the spans whose fit leaves the least squared error of min(model, rail) over every sample
    let mut best: Option<(f64, Vec<(usize, f64, f64)>)> = None;
    for _ in 0..RAIL_ITERATIONS {
        let Some(x) = solve(d, trials, &rows, c, hat) else { break };
        // each trial's prediction once: for the error and for where it reaches the rail
        let pred: Vec<Vec<f64>> = trials.iter().enumerate().map(|(i, tr)| tr.t.iter().map(|&t| predict(d, i, tr, t, &x, c, hat, &mut buf)).collect()).collect();
        let rss: f64 = trials.iter().zip(&pred).flat_map(|(tr, p)| tr.v.iter().zip(p).map(|(v, q)| (v - q).powi(2))).sum();
        if best.as_ref().is_none_or(|b| rss < b.0) {
            best = Some((rss, c.rail_spans.clone()));
        }
        let next: Vec<(usize, f64, f64)> = windows
            .iter()
            .filter_map(|&(k, from, _, end)| {
                let tr = &trials[k];
                let on = (0..tr.t.len()).find(|&j| tr.t[j] >= from && tr.t[j] < end && pred[k][j] >= rail)?;
                Some((k, tr.t[on], end))
            })
            .collect();
        if next == c.rail_spans {
            break;
        }
        c.rail_spans = next;
    }
    if let Some((_, spans)) = best {
        c.rail_spans = spans;
    }
}

/// Gauss–Newton steps of a rail's clip at most ([`settle_rail_spans`]).
const RAIL_ITERATIONS: usize = 4;

/// Iterations of [`through_exactly`] at most.
const THROUGH_ITERATIONS: usize = 4;

/// The model `cur` without its `idx`-th effect (a clip's fixed steps and a rest relaxation's τ
/// go with it).
pub(super) fn without(cur: &Config, idx: usize) -> Config {
    let mut c = cur.clone();
    let e = c.effects.remove(idx);
    if e == Effect::Saturation {
        c.clip = None;
        c.tau_fixed.clear();
        c.rail_spans.clear();
        c.restart.clear();
        c.clip_rail = false;
    }
    if e == Effect::RestRelaxation {
        c.rest_tau = None;
    }
    if e == Effect::BaselineDrift {
        c.drift_tau = None;
    }
    if e == Effect::Hysteresis {
        c.hyst_memory_s = None;
        c.hyst_through = false;
    }
    if e == Effect::Creep {
        c.creep = CreepForm::Restarting;
    }
    if e == Effect::SecondTimeConstant {
        c.drive = Drive::Change;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each effect added as a candidate, with its shape parameters, and removed again gives the
    /// model back: the effect and the shape that goes with it (a clip's steps, a warm-up's τ, a
    /// rest relaxation's τ); a second relaxation's τ2 is on its grid, relative to the steps' τ.
    #[test]
    fn a_candidate_and_its_removal_give_the_model_back() {
        let b = fixture::built(&fixture::recs(7000, |s| s.effects.saturation_v = 1.55));
        let steps = ClipSteps::of(&b.trials, clip_level(&b.trials), false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let base = &b.base_cfg;
        for e in [Effect::Creep, Effect::Hysteresis, Effect::SecondTimeConstant, Effect::BaselineDrift, Effect::Saturation, Effect::RestRelaxation] {
            let c = candidate(e, base, &ctx).unwrap_or_else(|| panic!("{e:?}: no candidate"));
            let idx = c.effects.iter().position(|x| *x == e).unwrap_or_else(|| panic!("{e:?} not added"));
            if e == Effect::Saturation {
                assert!(c.clip.is_some() && c.tau_fixed.len() == 3 && c.restart.len() == 3, "{c:?}");
            }
            if e == Effect::SecondTimeConstant {
                assert!(tau2_grid(ctx.tau2_scale, &b.trials).iter().any(|g| (g - c.tau2).abs() < 1e-9 * g), "τ2 {} off the grid", c.tau2);
            }
            let back = without(&c, idx);
            assert_eq!(
                (&back.effects, back.clip, &back.tau_fixed, &back.restart, back.rest_tau, back.drift_tau, back.hyst_memory_s, back.hyst_through, back.drive),
                (&base.effects, base.clip, &base.tau_fixed, &base.restart, base.rest_tau, base.drift_tau, base.hyst_memory_s, base.hyst_through, base.drive),
                "{e:?}"
            );
            assert_eq!((back.creep, back.clip_rail, back.rail_spans.len()), (CreepForm::Restarting, false, 0), "{e:?}");
        }
    }

    /// An amplifier's rail under a noise whose ADC margin (twice the raw noise, 30 mV) takes most
    /// of the rise into it (40 g steps, 15 mV of noise, the rail 45 mV under the top level, about as
    /// far above the level below): the clip's model sits on the rail through the top holds (their
    /// settled mean within a third of the noise of it) and predicts the held-out data within 5 % of
    /// the model without it (the corner it adds is a few samples under this noise). Fitted with the
    /// ADC's rule (only the samples under the rail by twice the raw noise), the top level came out
    /// near the one below it: 34 mV under the rail, and 174 % worse held out on the bench's first
    /// such case.
    #[test]
    fn a_rail_under_a_large_noise_is_fitted_on_it() {
        let noisy = |s: &mut crate::params::sensor::SensorParams| s.noise_v = 0.015;
        let forty = |p: &mut crate::params::sensor::ProtocolParams| p.weights_g = vec![40.0; 5];
        let s = fixture::sensor(noisy);
        let rail = s.v_eq((200.0 + 20.0) / 1000.0 * 9.80665) - 0.045;
        for seed in [95_000u64, 95_100, 95_200] {
            let recs = fixture::recs_with(
                seed,
                |s| {
                    noisy(s);
                    s.effects.saturation_v = rail;
                    s.effects.saturation_before_noise = true;
                },
                forty,
            );
            let b = fixture::built(&recs);
            let found = rail_level(&b.d, &b.trials, &b.hat).expect("a rail is proposed");
            let steps = ClipSteps::of(&b.trials, Some(found), true);
            let ctx = Ctx { clip: Some(found), ..fixture::ctx(&b, &steps, &b.hat) };
            let c = candidate(Effect::Saturation, &b.base_cfg, &ctx).expect("a clip");
            assert!(c.clip_rail);
            let (with, x) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
            let (without, _) = score(&b.d, &b.trials, &b.base_cfg, &b.hat).unwrap();
            let mut buf = Vec::new();
            let mut on = Vec::new();
            for (k, tr) in b.trials.iter().enumerate() {
                for (sg, end) in tr.segs.iter().zip(tr.segs.iter().skip(1).map(|n| n.t0)).filter(|(sg, _)| sg.load == 200.0) {
                    let mid = sg.t0 + 0.5 * (end - sg.t0);
                    on.extend((0..tr.t.len()).filter(|&j| tr.t[j] >= mid && tr.t[j] < end).map(|j| predict(&b.d, k, tr, tr.t[j], &x, &c, &b.hat, &mut buf)));
                }
            }
            let mean = on.iter().sum::<f64>() / on.len() as f64;
            assert!((mean - found).abs() < 0.005, "seed {seed}: the top holds predicted at {mean} V, the rail at {found} V");
            assert!(with.heldout_rmse < 1.05 * without.heldout_rmse, "seed {seed}: held out {} with the clip, {} without", with.heldout_rmse, without.heldout_rmse);
        }
    }

    /// The candidate of effect `e` on family A's simulator (seed, the sensor as `set` makes it) and,
    /// for the form the candidate chose and `other` (the same candidate in the other form), their
    /// held-out RMSE.
    fn chosen_form(seed: u64, e: Effect, set: impl Fn(&mut crate::params::sensor::SensorParams), other: impl Fn(&Config) -> Config) -> (Config, f64, f64) {
        let b = fixture::built(&fixture::recs(seed, set));
        let steps = ClipSteps::of(&b.trials, clip_level(&b.trials), false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let c = candidate(e, &b.base_cfg, &ctx).expect("a candidate");
        let (s, _) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
        let (o, _) = score(&b.d, &b.trials, &other(&c), &b.hat).unwrap();
        (c, s.heldout_rmse, o.heldout_rmse)
    }

    /// A hysteresis's form is chosen on the training fit: a hysteresis of the sensor's
    /// conductance (family B's form: on the unloading branch the conductance gains
    /// h · (F_max − F) / 1 N · g_ref) is fitted through the read-out, and one that keeps a share
    /// of the response's gap to the top level is fitted in the response; each form chosen also
    /// predicts the held-out data better than the other form.
    #[test]
    fn a_hysteresis_is_fitted_in_the_form_it_acts_in() {
        for (k, in_g) in [false, true].into_iter().enumerate() {
            let set = |s: &mut crate::params::sensor::SensorParams| {
                s.effects.hysteresis = 0.01;
                s.effects.hysteresis_in_conductance = in_g;
            };
            let (c, s, o) = chosen_form(77_000 + 10 * k as u64, Effect::Hysteresis, set, |c| Config { hyst_through: !c.hyst_through, ..c.clone() });
            assert_eq!(c.hyst_through, in_g, "in the conductance: {in_g}");
            assert!(s < o, "in the conductance: {in_g}: held out {s} in its form, {o} in the other");
        }
    }

    /// A second relaxation's form is chosen on the training fit: one of the sensor's conductance
    /// (family B's form: the conductance is the mix of a fast and a slow relaxation toward the
    /// target's conductance) is fitted through the read-out, and one of the response in the
    /// response; each form chosen also predicts the held-out data better than the other form.
    #[test]
    fn a_second_relaxation_is_fitted_in_the_form_it_acts_in() {
        for (k, in_g) in [false, true].into_iter().enumerate() {
            let set = |s: &mut crate::params::sensor::SensorParams| {
                s.effects.second_fraction = 0.1;
                s.effects.second_tau_s = 30.0;
                s.effects.second_in_conductance = in_g;
            };
            let flip = |c: &Config| Config { drive: if c.drive == Drive::Through { Drive::Change } else { Drive::Through }, ..c.clone() };
            let (c, s, o) = chosen_form(78_000 + 10 * k as u64, Effect::SecondTimeConstant, set, flip);
            assert_eq!(c.drive == Drive::Through, in_g, "in the conductance: {in_g}: {:?}, τ2 {}", c.drive, c.tau2);
            assert!(s < o, "in the conductance: {in_g}: held out {s} in its form, {o} in the other");
        }
    }

    /// The τ2 grid goes on past the steps' own scale in steps of the grid's ratio squared, to the
    /// first value at or past three median spacings of the steps; with no spacing (one step) it is
    /// the grid relative to the steps' τ alone.
    #[test]
    fn the_tau2_grid_reaches_three_holds() {
        let b = fixture::built(&fixture::recs_with(9300, |_| {}, |p| p.hold_s = 40.0));
        let mut sp = step_spacings_s(&b.trials);
        let top = TAU2_HOLDS * crate::sensor::preprocess::median(&mut sp);
        let g = tau2_grid(0.5, &b.trials);
        assert!(g.iter().zip(TAU2_GRID).all(|(a, m)| (a - 0.5 * m).abs() < 1e-12), "{g:?}");
        assert!(g.windows(2).skip(TAU2_GRID.len() - 1).all(|w| (w[1] / w[0] - TAU2_STEP * TAU2_STEP).abs() < 1e-9), "{g:?}");
        let n = g.len();
        assert!(g[n - 1] >= top && g[n - 2] < top, "top {top} s: {g:?}");
        let one = Trial { segs: b.trials[0].segs[..1].to_vec(), ..b.trials[0].clone() };
        assert_eq!(tau2_grid(0.5, &[one]).len(), TAU2_GRID.len());
    }

    /// A second relaxation far slower than the steps' own τ (family B's range is 15–120 s; here
    /// 100 s, a 10 % share of the conductance's changes, in 40 s holds) is fitted near its τ2, past
    /// the grid relative to the steps' τ (its top 31 s here), and predicts the held-out data better
    /// than at that top. With the grid ending there, τ2 stayed at the top (the test fails so).
    #[test]
    fn a_second_relaxation_slower_than_the_steps_grid_is_fitted_near_its_tau2() {
        let set = |s: &mut crate::params::sensor::SensorParams| {
            s.effects.second_fraction = 0.1;
            s.effects.second_tau_s = 100.0;
            s.effects.second_in_conductance = true;
        };
        let b = fixture::built(&fixture::recs_with(9310, set, |p| p.hold_s = 40.0));
        let steps = ClipSteps::of(&b.trials, clip_level(&b.trials), false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let c = candidate(Effect::SecondTimeConstant, &b.base_cfg, &ctx).expect("a second relaxation");
        let old_top = TAU2_GRID[TAU2_GRID.len() - 1] * ctx.tau2_scale;
        assert!(c.tau2 > 1.5 * old_top && (c.tau2 / 100.0).ln().abs() < (TAU2_STEP * TAU2_STEP).ln(), "τ2 {} s for 100 s (the steps' grid ends at {old_top} s)", c.tau2);
        let (s, _) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
        let (o, _) = score(&b.d, &b.trials, &Config { tau2: old_top, ..c.clone() }, &b.hat).unwrap();
        assert!(s.heldout_rmse < o.heldout_rmse, "held out {} at τ2 {} s, {} at {old_top} s", s.heldout_rmse, c.tau2, o.heldout_rmse);
    }

    /// A linear drift is a trend the second relaxation's grid cannot bound: on the whole grid its
    /// best τ2 is the last one, and the candidate takes τ2 on the grid relative to the steps' τ
    /// instead, as before the grid went on past it.
    #[test]
    fn a_trend_the_tau2_grid_cannot_bound_keeps_the_steps_grid() {
        let b = fixture::built(&fixture::recs(9320, |s| s.effects.drift_v_per_s = 1e-4));
        let steps = ClipSteps::of(&b.trials, clip_level(&b.trials), false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let grid = tau2_grid(ctx.tau2_scale, &b.trials);
        let mut with = b.base_cfg.clone();
        with.effects.push(Effect::SecondTimeConstant);
        let all = scored_on_training(Effect::SecondTimeConstant, on_tau2_grid(&with, &[Drive::Change], &grid), &ctx);
        let best = all.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        assert_eq!(best.0.tau2, grid[grid.len() - 1], "the drift's best τ2 on the whole grid {grid:?}");
        let c = candidate(Effect::SecondTimeConstant, &b.base_cfg, &ctx).expect("a second relaxation");
        let base_top = TAU2_GRID[TAU2_GRID.len() - 1] * ctx.tau2_scale;
        assert!(c.tau2 <= base_top * (1.0 + 1e-9), "τ2 {} s past the steps' grid (its top {base_top} s)", c.tau2);
    }

    /// A term offered beside a second relaxation in the wrong form has the relaxation's form and τ2
    /// chosen with its own shape: family A's second τ of the response (5 %, 8 s) with a linear
    /// drift (3e-5 V/s), the relaxation taken in the conductance's form (as the first round took it
    /// while the drift was out): the drift's candidate goes back to the response's form, τ2 within
    /// a grid step of 8 s, and predicts the held-out data better by more than the least gain a term
    /// needs at the gate's z. With the form kept while the drift's shape was chosen (stop 50), the
    /// drift took an 80 s warm-up, τ2 stayed at 12.4 s, and it lost 3.9 % held out in the pipeline.
    #[test]
    fn a_term_beside_a_second_relaxation_chooses_its_form_again() {
        let b = fixture::built(&fixture::recs(9001, |s| {
            s.effects.second_fraction = 0.05;
            s.effects.second_tau_s = 8.0;
            s.effects.drift_v_per_s = 3e-5;
        }));
        let steps = ClipSteps::of(&b.trials, clip_level(&b.trials), false);
        let ctx = fixture::ctx(&b, &steps, &b.hat);
        let second = candidate(Effect::SecondTimeConstant, &b.base_cfg, &ctx).expect("a second relaxation");
        let cur = Config { drive: Drive::Through, ..second };
        let c = candidate(Effect::BaselineDrift, &cur, &ctx).expect("a drift");
        assert_eq!(c.drive, Drive::Change, "τ2 {}, warm-up {:?}", c.tau2, c.drift_tau);
        assert!((c.tau2 / 8.0).ln().abs() < TAU2_STEP.ln(), "τ2 {} for 8 s", c.tau2);
        let (before, _) = score(&b.d, &b.trials, &cur, &b.hat).unwrap();
        let (after, _) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
        let z = z_over(&before, &after);
        assert!(after.gain_over(&before) > MIN_TERM_GAIN && z >= MIN_Z, "held out {} → {} (z {z})", before.heldout_rmse, after.heldout_rmse);
    }
}
