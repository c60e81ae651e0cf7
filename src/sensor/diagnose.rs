//! When simulation and recordings differ: locate the mismatch, name the physics left out, model
//! it, refit, and keep a term only when it predicts held-out data better.
//!
//! Model ("the simulation"): every trial is a superposition of first-order steps,
//!   V(t) = o_i + Σ_s [level(L_s) − level(L_{s−1})] · (1 − e^{−(t − t0_s)/τ_s}),
//! with levels shared across trials per load (loading and unloading alike), τ_s from the exact
//! per-step fit and t0 the onsets found in each trial. Catalogue terms add to it (all linear given
//! their shape parameter): creep, hysteresis, a second time constant, baseline drift, and
//! saturation (a clip); handling spikes are reported and excluded, never modelled. Selection is
//! forward: a term enters when it lowers the held-out error (leave one trial out; with one
//! recording, leave one step out) with a paired z of at least `MIN_Z` over trial × step units, and
//! BIC by at least `MIN_DBIC`.

mod alternatives;
mod input;
mod normal;
mod nuisance;
mod refit;
mod select;
mod spectrum;

use super::analyze::{self, Options, Prepared, Report};
use super::preprocess::Phase;
use super::recording::Recording;
use nalgebra::{DMatrix, DVector};
use input::*;
use normal::*;
pub use alternatives::{Alternative, Z_SEPARATE};
pub use nuisance::NuisanceTerm;
use serde::Serialize;
use select::Selected;
use spectrum::*;

/// A term must improve held-out prediction with a paired z of at least this over units.
pub const MIN_Z: f64 = 3.0;
pub const MIN_DBIC: f64 = -10.0;
/// The relaxation spectrum is preferred to an exact form (creep, one second time constant) that
/// also passes only when its held-out RMSE (both with their first-order shape refitted) is lower
/// by more than this share. Set on family A: a 5 % second relaxation (seed 70 000) came out 4.7 %
/// better held out with the spectrum, yet 2.8 × the floor's error to the truth; the exact form
/// reaches the floor. On the shared recording the spectrum is 38 % better.
pub const SPECTRUM_MARGIN: f64 = 0.10;
pub const SCHEMA: &str = "tipforge.diagnosis/1";
/// The second time constant's candidates, in multiples of the steps' median τ (a geometric grid).
const TAU2_STEP: f64 = 1.371;
const TAU2_GRID: [f64; 9] = [2.0, 2.742, 3.759, 5.154, 7.067, 9.689, 13.28, 18.21, 24.97];

use super::catalogue::second_time_constant::Drive;
pub use super::catalogue::Effect;
use super::catalogue::{self, Steps, MODELLED as CATALOGUE};

/// One step of one trial.
#[derive(Debug, Clone)]
struct Seg {
    /// Index of the step's (phase, index) across trials: τ corrections are shared per step.
    key: usize,
    t0: f64,
    load: f64,
    prev: f64,
    tau: f64,
    phase: Phase,
    /// When the change was logged (the load's ramp is placed relative to it).
    t_log: f64,
    /// The load as applied: at once, or over a ramp ending at t0 (an actuator's travel).
    input: LoadIn,
    /// With a simulator baseline: the simulated step (ΔV, τ).
    sim: Option<(f64, f64)>,
}

/// One trial's data as the model sees it.
#[derive(Debug, Clone)]
struct Trial {
    name: String,
    t: Vec<f64>,
    v: Vec<f64>,
    segs: Vec<Seg>,
    sigma: f64,
    /// With a simulator baseline: its level before the first step.
    prior0: Option<f64>,
    /// How far below a clip the filtered series is bent by the clipped raw noise.
    clip_margin: f64,
    /// Half the span of raw samples one filtered sample averages (0 without the filter): the
    /// first-order part is modelled as that average, exact at a step's onset and its curved start.
    half_span_s: f64,
    /// The series as given, handling spikes included (the baseline, the paper's model, is fitted
    /// to it).
    given_t: Vec<f64>,
    given_v: Vec<f64>,
}

impl Trial {
    /// From its first sample to its last (s).
    fn span_s(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0) - self.t.first().copied().unwrap_or(0.0)
    }
    /// The simulator's prediction (0 without a simulator baseline).
    fn prior(&self, t: f64) -> f64 {
        let Some(p0) = self.prior0 else { return 0.0 };
        p0 + self.segs.iter().filter(|s| t >= s.t0).filter_map(|s| s.sim.map(|(dv, tau)| dv * (1.0 - catalogue::decay((t - s.t0) / tau)))).sum::<f64>()
    }
}

/// A model configuration: which terms, and their shape parameters.
#[derive(Debug, Clone, PartialEq)]
struct Config {
    /// Linearised τ corrections per step (free time constants, first order in Δln τ).
    tau_free: bool,
    effects: Vec<Effect>,
    tau2: f64,
    /// What drives the second relaxation (its sign with the change, or the change's size).
    drive: Drive,
    clip: Option<f64>,
    /// With a clip: the time constant and onset of each step the clip shapes, as
    /// ((trial, segment), τ, onset). The clipped shape biases those steps' own first-order fits.
    tau_fixed: Vec<FixedStep>,
    /// With a clip: the (trial, segment) steps that fall from a clipped load. The signal leaves the
    /// clip on a first-order fall from the clip itself (their part-1 fits are of that fall), so they
    /// restart at the clip: v = L_next·u + clip·(1 − u).
    restart: Vec<(usize, usize)>,
    /// With the relaxation spectrum: its grid, the load's ramp and the smoothness penalty.
    relax: Option<Relax>,
    /// A gain per trial (all but the first): the trials' step sizes differ by a factor (the
    /// sensor's temperature, the hand), a nuisance, not physics of the sensor.
    gains: bool,
    /// A relaxation per trial from its first sample, with this time constant: what the sample
    /// brings from before the recording (how long it rested), a nuisance like the gains.
    rest_tau: Option<f64>,
    /// Baseline drift as an exponential warm-up with this time constant from each trial's start
    /// (shared by the trials, as the rate is); None: linear (the warm-up's limit of long τ).
    drift_tau: Option<f64>,
}

/// The relaxation spectrum's shape: kernels on a log grid of τ, driven by the load as applied (a
/// ramp of `ramp_s` ending `end_s` after the logged change), amplitudes penalised by `lambda`
/// (relative to the block's mean column energy; None: chosen by inner cross-validation wherever
/// the model is solved).
#[derive(Debug, Clone, PartialEq)]
struct Relax {
    taus: Vec<f64>,
    ramp_s: f64,
    end_s: f64,
    lambda: Option<f64>,
    /// With the steps' own first-order decay among the columns ([`OWN_TAU_COLS`]).
    own_tau: bool,
    /// One set of amplitudes for loading and unloading changes alike (linear viscoelasticity: the
    /// recovery mirrors the creep); the unloading set's columns stay empty.
    shared: bool,
    /// One more kernel set per trial, from its first sample: the relaxation the sample brings
    /// from before the recording (how long it rested differs between trials).
    trials: usize,
    /// Driven by each step's own ramp (the baseline's, an actuator's), not by `ramp_s`/`end_s`.
    by_steps: bool,
}

impl Relax {
    /// Kernel sets: after loading, after unloading, then one per trial's start.
    fn sets(&self) -> usize {
        2 + self.trials
    }
    fn cols(&self) -> usize {
        self.sets() * self.taus.len() + if self.own_tau { OWN_TAU_COLS } else { 0 }
    }
}

/// A step whose time constant and onset are set, not taken from its own part-1 fit.
#[derive(Debug, Clone, PartialEq)]
struct FixedStep {
    /// (trial, segment)
    at: (usize, usize),
    tau_s: f64,
    t0_s: f64,
}

/// The steps a clip shapes (each as (trial, segment)) and the units its evidence lies in.
struct ClipSteps {
    into: Vec<(usize, usize)>,
    from: Vec<(usize, usize)>,
    units: Vec<(usize, usize)>,
}

impl Config {
    fn fixed(&self, i: usize, s: usize) -> Option<&FixedStep> {
        self.tau_fixed.iter().find(|x| x.at == (i, s))
    }
    fn tau_of(&self, i: usize, s: usize, sg: &Seg) -> f64 {
        self.fixed(i, s).map(|x| x.tau_s).unwrap_or(sg.tau)
    }
    fn t0_of(&self, i: usize, s: usize, sg: &Seg) -> f64 {
        self.fixed(i, s).map(|x| x.t0_s).unwrap_or(sg.t0)
    }
}

/// Baseline quantities the terms are built from (two-stage: fixed from the baseline fit).
#[derive(Debug, Clone, Default)]
struct Hat {
    loads: Vec<f64>,
    level: Vec<f64>,
}

impl Hat {
    fn level_of(&self, l: f64) -> f64 {
        self.loads.iter().position(|&x| x == l).map(|i| self.level[i]).unwrap_or(0.0)
    }
    fn max_level(&self) -> f64 {
        self.loads.iter().zip(&self.level).max_by(|a, b| a.0.partial_cmp(b.0).unwrap()).map(|x| *x.1).unwrap_or(0.0)
    }
}

#[derive(Clone)]
struct Design {
    loads: Vec<f64>,
    n_trials: usize,
    n_keys: usize,
    /// The (trial, segment) steps whose onset is refitted (a handling spike was cut from their
    /// edge, taking the samples that fixed it in part 1), each with its column among them.
    refit_onset: Vec<(usize, usize)>,
    /// The simulator gives the first-order part: no level or τ columns.
    prior: bool,
    /// The shape columns (Δ ln τ, onset shifts) as the exact derivatives of the filtered-sample
    /// model (the final refit's Gauss–Newton); otherwise of the point value (selection: its rules
    /// were set with those columns).
    exact_shape: bool,
}

impl Design {
    fn n_levels(&self) -> usize {
        self.n_trials + if self.prior { 0 } else { self.loads.len().saturating_sub(1) }
    }
    /// Columns of the first-order shape corrections (τ per step, onsets of the steps cut by spikes).
    fn n_shape(&self, cfg: &Config) -> usize {
        if cfg.tau_free && !self.prior {
            self.n_keys + self.refit_onset.len()
        } else {
            0
        }
    }
    fn ncols(&self, cfg: &Config) -> usize {
        self.n_levels() + self.n_shape(cfg) + cfg.effects.iter().map(|e| effect_cols(*e, cfg)).sum::<usize>() + self.n_gains(cfg) + self.n_rests(cfg)
    }
    /// First column of the per-trial gains.
    fn gain_col(&self, cfg: &Config) -> usize {
        self.ncols(cfg) - self.n_gains(cfg) - self.n_rests(cfg)
    }
    /// First column of the per-trial rest relaxations (the last columns of a row).
    fn rest_col(&self, cfg: &Config) -> usize {
        self.ncols(cfg) - self.n_rests(cfg)
    }
    fn n_rests(&self, cfg: &Config) -> usize {
        if cfg.rest_tau.is_some() && !self.prior && self.n_trials >= 2 {
            self.n_trials
        } else {
            0
        }
    }
    /// Columns of the per-trial gains (the last columns of a row).
    fn n_gains(&self, cfg: &Config) -> usize {
        if cfg.gains && !self.prior && self.n_trials >= 2 {
            GAIN_COLS * self.n_trials
        } else {
            0
        }
    }
    /// The design row of trial `i` at time t.
    fn row(&self, i: usize, tr: &Trial, t: f64, cfg: &Config, hat: &Hat, out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.ncols(cfg), 0.0);
        out[i] = 1.0;
        let base = self.n_trials;
        // level columns: loads[0] is the reference level (absorbed by o_i)
        let h = tr.half_span_s;
        let active: Vec<usize> = (0..tr.segs.len()).filter(|&s| t + h >= cfg.t0_of(i, s, &tr.segs[s]) - tr.segs[s].input.ramp_s).collect();
        for &s in active.iter().filter(|_| !self.prior) {
            let sg = &tr.segs[s];
            let u = rise(t, cfg.t0_of(i, s, sg), cfg.tau_of(i, s, sg), h, sg.input);
            if let Some(c) = self.loads.iter().position(|&x| x == sg.load).filter(|&c| c > 0) {
                out[base + c - 1] += u;
            }
            let restart = cfg.restart.contains(&(i, s));
            if let Some(c) = self.loads.iter().position(|&x| x == sg.prev).filter(|&c| c > 0) {
                out[base + c - 1] -= if restart { 1.0 } else { u };
            }
            if restart {
                // v = L_next·u + clip·(1 − u) in absolute levels: the offset takes part only by u
                out[i] -= 1.0 - u;
            }
        }
        let mut col = self.n_levels();
        let _ = base;
        if cfg.tau_free && !self.prior {
            for &s in &active {
                let sg = &tr.segs[s];
                // a jump (faster than one sample) has no shape to correct
                if cfg.fixed(i, s).is_some() || is_jump(tr, sg) {
                    continue;
                }
                let dv = hat.level_of(sg.load) - hat.level_of(sg.prev);
                // −∂/∂ln τ of dv·rise: the coefficient is −Δ ln τ
                if sg.input.ramp_s > 0.0 {
                    // a ramped load's response: its derivatives by central differences
                    out[col + sg.key] -= dv * ramp_dln_tau(t, sg.t0, sg.tau, h, sg.input);
                    if let Some(q) = self.refit_onset.iter().position(|&k| k == (i, s)) {
                        out[col + self.n_keys + q] = dv * ramp_dt0(t, sg.t0, sg.tau, h, sg.input);
                    }
                } else if self.exact_shape {
                    // −∂/∂ln τ and ∂/∂t0 of dv·rise: the coefficients are −Δ ln τ and the onset's
                    // shift (s)
                    out[col + sg.key] -= dv * rise_dln_tau(t, sg.t0, sg.tau, h);
                    if let Some(q) = self.refit_onset.iter().position(|&k| k == (i, s)) {
                        out[col + self.n_keys + q] = dv * rise_dt0(t, sg.t0, sg.tau, h);
                    }
                } else {
                    // the point value's derivatives, continued over the filtered span before the
                    // onset (as the selection rules were set)
                    let x = (t - sg.t0) / sg.tau;
                    if x <= SETTLED {
                        out[col + sg.key] += dv * x * (-x).exp();
                        if let Some(q) = self.refit_onset.iter().position(|&k| k == (i, s)) {
                            out[col + self.n_keys + q] = -dv * (-x).exp() / sg.tau;
                        }
                    }
                }
            }
            col += self.n_keys + self.refit_onset.len();
        }
        // the catalogue's terms start where a step's load has landed (a ramp's end): the steps on
        // their ramp are not theirs yet
        // (the steps are in time order: those still on their ramp are the last of the active)
        let on_ramp = active.iter().rev().take_while(|&&s| tr.segs[s].input.ramp_s > 0.0 && t + h < cfg.t0_of(i, s, &tr.segs[s])).count();
        let landed = &active[..active.len() - on_ramp];
        let cur = landed.last().copied();
        let steps = TrialSteps { i, tr, cfg, hat, l0: hat.level_of(self.loads[0]), top: hat.max_level() };
        for e in &cfg.effects {
            match e {
                Effect::Creep => out[col] = cur.map(|s| catalogue::creep::column(&steps, s, t)).unwrap_or(0.0),
                Effect::Hysteresis => out[col] = cur.map(|s| catalogue::hysteresis::column(&steps, s, t)).unwrap_or(0.0),
                Effect::SecondTimeConstant => catalogue::second_time_constant::columns(&steps, landed, t, cfg.tau2, cfg.drive, &mut out[col..col + cfg.drive.columns()]),
                Effect::BaselineDrift => out[col] = catalogue::baseline_drift::column(t, tr.t[0], cfg.drift_tau),
                Effect::Relaxation => {
                    if let Some(rx) = &cfg.relax {
                        relax_columns(i, tr, &steps, t, rx, &mut out[col..col + rx.cols()]);
                    }
                }
                Effect::Saturation | Effect::HandlingSpikes | Effect::RestRelaxation => {}
            }
            col += effect_cols(*e, cfg);
        }
        // a trial's gain scales its steps as the shared levels give them (two-stage: the levels
        // from the fit before), to second order in the level: a gain of the sensor's conductance
        // reaches the output through the read-out's curve (a divider compresses the top levels);
        // the shared levels carry the trials' mean gain (a faint ridge on the gains, see
        // solve_normal)
        if self.n_gains(cfg) > 0 {
            let top = steps.top - steps.l0;
            for &s in &active {
                let sg = &tr.segs[s];
                let (a, b) = (hat.level_of(sg.load) - steps.l0, hat.level_of(sg.prev) - steps.l0);
                let u = rise(t, steps.t0(s), steps.tau(s), h, sg.input);
                out[col + GAIN_COLS * i] += (a - b) * u;
                if top != 0.0 {
                    out[col + GAIN_COLS * i + 1] += (a * a - b * b) / top * u;
                }
            }
        }
        if let (Some(tau), true) = (cfg.rest_tau, self.n_rests(cfg) > 0) {
            out[self.rest_col(cfg) + i] = catalogue::decay((t - tr.t[0]).max(0.0) / tau);
        }
    }
}

/// Columns of one trial's gain: the change of level, and of its square (over the top level).
const GAIN_COLS: usize = 2;

/// Time constants after which a first-order rise is taken as settled (e^(−40) ≈ 4e-18).
const SETTLED: f64 = 40.0;

/// The first-order rise 1 − e^(−(t − t0)/τ) (0 before t0), averaged over [t − h, t + h] (a filtered
/// sample's span; h = 0: the value at t).
fn block_rise(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
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
fn rise_dt0(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
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
fn rise_dln_tau(t: f64, t0: f64, tau: f64, h: f64) -> f64 {
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

/// One trial's steps as the catalogue's terms see them.
struct TrialSteps<'a> {
    i: usize,
    tr: &'a Trial,
    cfg: &'a Config,
    hat: &'a Hat,
    l0: f64,
    top: f64,
}

impl Steps for TrialSteps<'_> {
    fn t0(&self, q: usize) -> f64 {
        self.cfg.t0_of(self.i, q, &self.tr.segs[q])
    }
    fn tau(&self, q: usize) -> f64 {
        self.cfg.tau_of(self.i, q, &self.tr.segs[q])
    }
    fn dv(&self, q: usize) -> f64 {
        let sg = &self.tr.segs[q];
        self.hat.level_of(sg.load) - self.hat.level_of(sg.prev)
    }
    fn level(&self, q: usize) -> f64 {
        self.hat.level_of(self.tr.segs[q].load) - self.l0
    }
    fn below_top(&self, q: usize) -> f64 {
        self.top - self.hat.level_of(self.tr.segs[q].load)
    }
    fn unloading(&self, q: usize) -> bool {
        self.tr.segs[q].phase == Phase::Unloading
    }
    fn after_peak(&self, q: usize) -> bool {
        // a step of a later cycle: an earlier step of this trial reached its highest load (loads,
        // not levels: a read-out whose level falls with the load has its top level at no load)
        self.unloading(q) || {
            let top = self.tr.segs.iter().map(|sg| sg.load).fold(f64::NEG_INFINITY, f64::max);
            self.tr.segs[..q].iter().any(|sg| sg.load >= top)
        }
    }
}

/// Design columns of a catalogue term.
fn effect_cols(e: Effect, cfg: &Config) -> usize {
    match e {
        Effect::Saturation | Effect::HandlingSpikes | Effect::RestRelaxation => 0,
        Effect::SecondTimeConstant => cfg.drive.columns(),
        Effect::Relaxation => cfg.relax.as_ref().map(|r| r.cols()).unwrap_or(0),
        _ => 1,
    }
}

/// The constant part of the steps that restart at the clip: clip·(1 − u) each.
fn clip_offset(i: usize, tr: &Trial, t: f64, cfg: &Config) -> f64 {
    let Some(c) = cfg.clip else { return 0.0 };
    cfg.restart
        .iter()
        .filter(|(k, _)| *k == i)
        .map(|&(_, s)| {
            let sg = &tr.segs[s];
            // as the design row: active from t + h ≥ t0 (less a ramp), with the filtered-sample
            // average of u
            if t + tr.half_span_s >= cfg.t0_of(i, s, sg) - sg.input.ramp_s {
                c * (1.0 - rise(t, cfg.t0_of(i, s, sg), cfg.tau_of(i, s, sg), tr.half_span_s, sg.input))
            } else {
                0.0
            }
        })
        .sum()
}

fn usable(tr: &Trial, j: usize, cfg: &Config) -> bool {
    match cfg.clip {
        Some(c) => tr.v[j] < c - tr.clip_margin.max(0.5 * tr.sigma).max(1e-12),
        None => true,
    }
}

fn predict(d: &Design, i: usize, tr: &Trial, t: f64, x: &[f64], cfg: &Config, hat: &Hat, buf: &mut Vec<f64>) -> f64 {
    d.row(i, tr, t, cfg, hat, buf);
    let v: f64 = buf.iter().zip(x).map(|(a, b)| a * b).sum::<f64>() + tr.prior(t) + clip_offset(i, tr, t, cfg);
    match cfg.clip {
        Some(c) => v.min(c),
        None => v,
    }
}

#[derive(Debug, Clone, Serialize)]
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
}

fn all_rows(trials: &[Trial]) -> Vec<(usize, usize)> {
    trials.iter().enumerate().flat_map(|(i, tr)| (0..tr.t.len()).map(move |j| (i, j))).collect()
}

/// BIC of the fit on everything (no folds): what shape parameters are chosen by.
fn train_bic(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(f64, Vec<f64>)> {
    let rows = all_rows(trials);
    let x = solve(d, trials, &rows, cfg, hat)?;
    let mut buf = Vec::new();
    let rss: f64 = rows.iter().map(|&(i, j)| (trials[i].v[j] - predict(d, i, &trials[i], trials[i].t[j], &x, cfg, hat, &mut buf)).powi(2)).sum();
    let (n, p) = (rows.len() as f64, (d.ncols(cfg) + usize::from(cfg.clip.is_some())) as f64);
    Some((n * (rss / n).max(1e-300).ln() + p * n.ln(), x))
}

/// A term's parameters in the fitted model (the coefficients of its columns and its shape).
fn term_params(d: &Design, c: &Config, x: &[f64], e: Effect, hat: &Hat) -> serde_json::Value {
    let k = term_col(d, c, e);
    // the terms scale with the model's levels: their sizes in the response unit, for the change
    // from zero load to the highest load
    let span = hat.max_level() - hat.level_of(d.loads[0]);
    let at = |i: usize| x.get(i).copied().unwrap_or(f64::NAN);
    match e {
        Effect::Creep => serde_json::json!({"per_decade_fraction": at(k), "time_s": catalogue::creep::TIME_S, "per_decade_at_top_load": at(k) * span}),
        Effect::Hysteresis => serde_json::json!({"fraction": at(k), "offset_at_lowest_load": at(k) * span}),
        Effect::RestRelaxation => {
            let r0 = d.rest_col(c);
            serde_json::json!({"tau_s": c.rest_tau, "amplitude_at_start_by_trial": (0..d.n_rests(c)).map(|q| at(r0 + q)).collect::<Vec<_>>()})
        }
        Effect::SecondTimeConstant if c.drive == Drive::Size => {
            serde_json::json!({"drive": c.drive.label(), "after_loading_fraction": at(k), "after_unloading_fraction": at(k + 1), "tau2_s": c.tau2, "jump_after_loading_full_change": at(k) * span.abs(), "jump_after_unloading_full_change": at(k + 1) * span.abs()})
        }
        Effect::SecondTimeConstant => serde_json::json!({"drive": c.drive.label(), "fraction": at(k), "tau2_s": c.tau2}),
        Effect::BaselineDrift => match c.drift_tau {
            Some(tau) => serde_json::json!({"form": "exponential warm-up", "initial_rate_per_s": at(k), "warmup_tau_s": tau, "amplitude": at(k) * tau}),
            None => serde_json::json!({"rate_per_s": at(k)}),
        },
        Effect::Saturation => serde_json::json!({"level": c.clip}),
        Effect::HandlingSpikes => serde_json::json!({}),
        Effect::Relaxation => {
            let Some(rx) = &c.relax else { return serde_json::json!({}) };
            let n = rx.taus.len();
            let amps: Vec<f64> = (0..2 * n).map(|j| at(k + j)).collect();
            let shape = catalogue::relaxation::name(&rx.taus, &amps);
            let (peak_l, share_l) = catalogue::relaxation::peak(&rx.taus, &amps[..n]);
            let (peak_u, share_u) = catalogue::relaxation::peak(&rx.taus, &amps[n..]);
            let mut v = serde_json::json!({
                "shape": match shape { catalogue::relaxation::Shape::Creep => "broad band (creep)", catalogue::relaxation::Shape::SecondTimeConstant => "one narrow peak (second time constant)", catalogue::relaxation::Shape::ChangeDriven => "one sign after loading and unloading (change-driven)" },
                "tau_s": rx.taus,
                "after_loading_per_unit_change": &amps[..n],
                "after_unloading_per_unit_change": &amps[n..],
                "peak_tau_after_loading_s": peak_l, "peak_share_after_loading": share_l,
                "peak_tau_after_unloading_s": peak_u, "peak_share_after_unloading": share_u,
                "penalty": rx.lambda,
                "first_order_share_after_loading": if rx.own_tau { at(k + rx.sets() * n) } else { 0.0 }, "first_order_share_after_unloading": if rx.own_tau { at(k + rx.sets() * n + 1) } else { 0.0 },
            });
            // the spectrum's own ramp, or (an actuator's) the steps' own ramps it is driven by
            if rx.by_steps {
                v["driven_by_the_steps_ramps"] = serde_json::json!(true);
            } else {
                v["ramp_s"] = serde_json::json!(rx.ramp_s);
                v["ramp_end_after_logged_change_s"] = serde_json::json!(rx.end_s);
            }
            v
        }
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
fn refit_onsets(d: &Design, fit: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Vec<Trial>, Vec<f64>)> {
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

/// τ2 of the second relaxation refined by golden-section search in log τ2 within one grid step
/// either side of the chosen value, on the training BIC (the number of parameters is the same
/// throughout, so this is the training RSS). Returns the refined configuration and its score.
fn refine_tau2(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Config, Score, Vec<f64>)> {
    let at = |ln_tau2: f64| {
        let mut c = cfg.clone();
        c.tau2 = ln_tau2.exp();
        train_bic(d, trials, &c, hat).map(|(b, _)| b).unwrap_or(f64::INFINITY)
    };
    // 10 steps shrink the bracket to 0.8 % of a grid step (0.3 % in τ2)
    let br = super::golden::golden(at, cfg.tau2.ln() - TAU2_STEP.ln(), cfg.tau2.ln() + TAU2_STEP.ln(), 10, 0.0);
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

/// Index of a term's first column in the design.
fn term_col(d: &Design, cfg: &Config, e: Effect) -> usize {
    d.n_levels() + d.n_shape(cfg) + cfg.effects.iter().take_while(|x| **x != e).map(|x| effect_cols(*x, cfg)).sum::<usize>()
}

/// A held-out trial's own columns (its offset, and its gains and rest relaxation when the model has
/// them), fitted on the samples before its first step and its odd segments (for scoring the even
/// ones), and on those before and its even segments (for the odd ones), by least squares on the
/// residual of the fold's model without them. Returns (columns, values per parity).
fn trial_terms_halves(d: &Design, k: usize, tr: &Trial, xk: &[f64], cfg: &Config, hat: &Hat) -> (Vec<usize>, [Vec<f64>; 2]) {
    let mut cols = vec![k];
    if d.n_gains(cfg) > 0 {
        cols.extend((0..GAIN_COLS).map(|c| d.gain_col(cfg) + GAIN_COLS * k + c));
    }
    if d.n_rests(cfg) > 0 {
        cols.push(d.rest_col(cfg) + k);
    }
    let m = cols.len();
    let mut x = xk.to_vec();
    cols.iter().for_each(|&c| x[c] = 0.0);
    let mut a = [DMatrix::<f64>::zeros(m, m), DMatrix::<f64>::zeros(m, m)];
    let mut r = [DVector::<f64>::zeros(m), DVector::<f64>::zeros(m)];
    let mut buf = Vec::new();
    let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
    for j in 0..tr.t.len() {
        let seg = tr.segs.iter().filter(|s| s.t0 <= tr.t[j]).count();
        if (seg == 0 && tr.t[j] >= t_first - 0.2) || at_jump(tr, tr.t[j]) || !usable(tr, j, cfg) {
            continue;
        }
        let e = tr.v[j] - predict(d, k, tr, tr.t[j], &x, cfg, hat, &mut buf);
        let c = DVector::from_iterator(m, cols.iter().map(|&q| buf[q]));
        // fitted on this segment's parity, used for the other's; before the first step, for both
        for p in 0..2 {
            if seg == 0 || p != seg % 2 {
                a[p] += &c * c.transpose();
                r[p] += &c * e;
            }
        }
    }
    let vals = [0, 1].map(|p| {
        let mut ap = a[p].clone();
        let scale = 1e-9 * (0..m).map(|q| ap[(q, q)]).sum::<f64>().max(1e-300);
        for q in 0..m {
            ap[(q, q)] += scale;
        }
        ap.cholesky().map(|ch| ch.solve(&r[p]).iter().copied().collect()).unwrap_or_else(|| vec![0.0; m])
    });
    (cols, vals)
}

/// Fit on everything (rmse, BIC) and on folds (held-out RMSE).
fn score(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Score, Vec<f64>)> {
    score_on(d, trials, trials, cfg, hat)
}

/// Fitted to `fit` (the same trials, possibly as given with handling spikes), scored on `trials`.
fn score_on(d: &Design, fit: &[Trial], trials: &[Trial], cfg: &Config, hat: &Hat) -> Option<(Score, Vec<f64>)> {
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
        solve_normal(d, cfg, &sum_normals(d, cfg, &parts), support, lambda)
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
    let (mut hss, mut hn) = (0.0, 0usize);
    let mut units: std::collections::BTreeMap<(usize, usize), f64> = Default::default();
    let seg_of = |tr: &Trial, t: f64| tr.segs.iter().filter(|s| s.t0 <= t).count();
    if trials.len() >= 2 {
        for k in 0..trials.len() {
            let Some((mut xk, _)) = fold(&|u| u.0 != k, None) else { continue };
            // the held-out trial's own offset, from its samples before the first step
            let tr = &trials[k];
            let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
            xk[k] = 0.0;
            let pre: Vec<f64> = (0..tr.t.len()).filter(|&j| tr.t[j] < t_first - 0.2).map(|j| tr.v[j] - predict(d, k, tr, tr.t[j], &xk, cfg, hat, &mut buf)).collect();
            xk[k] = if pre.is_empty() { 0.0 } else { pre.iter().sum::<f64>() / pre.len() as f64 };
            // per-trial terms are validated inside their trial: fitted (with the offset) on every
            // other step of it and scored on the steps between (both halves in turn)
            let own = (d.n_gains(cfg) + d.n_rests(cfg) > 0).then(|| trial_terms_halves(d, k, tr, &xk, cfg, hat));
            for j in 0..tr.t.len() {
                if tr.t[j] >= t_first - 0.2 && !at_jump(tr, tr.t[j]) {
                    if let Some((cols, vals)) = &own {
                        for (c, v) in cols.iter().zip(&vals[seg_of(tr, tr.t[j]) % 2]) {
                            xk[*c] = *v;
                        }
                    }
                    let e = tr.v[j] - predict(d, k, tr, tr.t[j], &xk, cfg, hat, &mut buf);
                    hss += e * e;
                    hn += 1;
                    *units.entry((k, seg_of(tr, tr.t[j]))).or_default() += e * e;
                }
            }
        }
    } else if blocks > 0 {
        // one recording whose levels are not held in two steps each: the validation split inside
        // the trial, forward in time — each block of a hold after its first is predicted from
        // the blocks before it in the same hold and every other hold (a forecast: a trend the
        // model leaves out shows in every block, not only at a hold's ends)
        let tr = &trials[0];
        let keys: std::collections::BTreeSet<(usize, usize)> = tr.t.iter().map(|&t| unit_key(tr, t, blocks)).filter(|k| k.1 > 0 && (k.1 - 1) % blocks > 0).collect();
        for u in keys {
            let (hold, block) = ((u.1 - 1) / blocks, (u.1 - 1) % blocks);
            let later = |x: &(usize, usize)| x.1 > 0 && (x.1 - 1) / blocks == hold && (x.1 - 1) % blocks >= block;
            let Some((xk, _)) = fold(&|x| !later(x), Some(&full_diag)) else { continue };
            for j in (0..tr.t.len()).filter(|&j| unit_key(tr, tr.t[j], blocks) == u && !at_jump(tr, tr.t[j])) {
                let e = tr.v[j] - predict(d, 0, tr, tr.t[j], &xk, cfg, hat, &mut buf);
                hss += e * e;
                hn += 1;
                *units.entry(u).or_default() += e * e;
            }
        }
    } else {
        // one recording: leave one step out
        let tr = &trials[0];
        for s in 0..tr.segs.len() {
            let (a, b) = (tr.segs[s].t0, tr.segs.get(s + 1).map(|x| x.t0).unwrap_or(f64::INFINITY));
            // the step's rows are unit s + 1 (segments count from the first onset)
            let Some((mut xk, _)) = fold(&|u| *u != (0, s + 1), Some(&full_diag)) else { continue };
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
                    hss += e * e;
                    hn += 1;
                    *units.entry((0, s)).or_default() += e * e;
                }
            }
        }
    }
    // a fold that predicts a unit worse than any constant inside the signal's range has not
    // determined what that unit needs (a level held once or briefly, shape corrections running
    // off): the model cannot be scored held out on these data
    let (lo, hi) = trials.iter().flat_map(|tr| tr.v.iter().copied()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    let range = (hi - lo).max(0.0);
    let mut counts: std::collections::BTreeMap<(usize, usize), usize> = Default::default();
    if trials.len() >= 2 {
        for (k, tr) in trials.iter().enumerate() {
            let t_first = tr.segs.first().map(|s| s.t0).unwrap_or(f64::INFINITY);
            for &t in tr.t.iter().filter(|&&t| t >= t_first - 0.2) {
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
            let b = tr.segs.get(s + 1).map(|x| x.t0).unwrap_or(f64::INFINITY);
            counts.insert((0, s), tr.t.iter().filter(|&&t| t >= sg.t0 && t < b).count());
        }
    }
    if units
        .iter()
        .any(|(k, &e)| !(e / counts.get(k).copied().unwrap_or(1).max(1) as f64).sqrt().is_finite() || (e / counts.get(k).copied().unwrap_or(1).max(1) as f64).sqrt() > range)
    {
        return None;
    }
    let unit_keys: Vec<(usize, usize)> = units.keys().copied().collect();
    let unit_n = unit_keys.iter().map(|k| counts.get(k).copied().unwrap_or(1).max(1)).collect();
    Some((
        Score {
            rmse: (rss / n.max(1) as f64).sqrt(),
            heldout_rmse: (hss / hn.max(1) as f64).sqrt(),
            bic,
            params: p,
            n,
            units: units.into_values().collect(),
            unit_keys,
            unit_n,
            blocks,
        },
        x,
    ))
}

/// Paired z statistic of the held-out improvement over units (positive: the candidate predicts
/// better). Scale-free, so it does not depend on the noise per sample or the sampling rate.
/// The held-out evidence for `after` over `before`, per unit (squared errors): the paired z of the
/// differences, or, when `after` is at least [`MIN_ROBUST_GAIN`] better in held-out RMSE, the
/// larger of it and the Wilcoxon signed-rank z of the differences. The differences' z is vetoed by
/// one unit (a large change in one step widens their spread as much as a loss would); the ranks
/// weigh every unit alike, so a term that makes most units better passes however unevenly, and the
/// minimum gain keeps a consistent but negligible change out.
fn paired_z(before: &[f64], after: &[f64]) -> f64 {
    let z = diff_z(before, after);
    let (sb, sa) = (before.iter().sum::<f64>(), after.iter().sum::<f64>());
    if before.len() == after.len() && sb > 0.0 && 1.0 - (sa / sb).sqrt() >= MIN_ROBUST_GAIN {
        z.max(signed_rank_z(before, after))
    } else {
        z
    }
}

/// Least held-out RMSE gain for the signed-rank route of [`paired_z`].
pub const MIN_ROBUST_GAIN: f64 = 0.03;

/// The Wilcoxon signed-rank statistic of before − after over units, as a z (normal approximation;
/// zero differences left out, tied magnitudes given their mean rank).
fn signed_rank_z(before: &[f64], after: &[f64]) -> f64 {
    let mut d: Vec<f64> = before.iter().zip(after).map(|(a, b)| a - b).filter(|x| *x != 0.0).collect();
    let n = d.len();
    if n < 3 {
        return 0.0;
    }
    d.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let mut w = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && d[j + 1].abs() == d[i].abs() {
            j += 1;
        }
        let rank = 0.5 * ((i + 1) + (j + 1)) as f64;
        w += d[i..=j].iter().map(|x| rank * x.signum()).sum::<f64>();
        i = j + 1;
    }
    let nf = n as f64;
    w / (nf * (nf + 1.0) * (2.0 * nf + 1.0) / 6.0).sqrt()
}

/// The paired z of the per-unit differences.
fn diff_z(before: &[f64], after: &[f64]) -> f64 {
    if before.len() != after.len() || before.len() < 3 {
        return 0.0;
    }
    let d: Vec<f64> = before.iter().zip(after).map(|(a, b)| a - b).collect();
    let m = d.len() as f64;
    let mean = d.iter().sum::<f64>() / m;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
    if sd <= 0.0 {
        return 0.0;
    }
    mean / (sd / m.sqrt())
}

#[derive(Debug, Clone, Serialize)]
pub struct Window {
    pub recording: String,
    pub start_s: f64,
    pub end_s: f64,
    /// What the window was flagged for and its value (residual RMS / noise, lag-1 autocorrelation).
    pub statistic: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct Term {
    pub name: String,
    pub params: serde_json::Value,
}

#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    pub effect: &'static str,
    pub confidence: &'static str,
    pub explanation: String,
    pub windows: Vec<Window>,
    pub term: Term,
    pub heldout_rmse_before: f64,
    pub heldout_rmse_after: f64,
    pub delta_bic: f64,
    /// Other effects whose terms, in this one's place, explain the same residual about as well on
    /// this data (the drop-one test of `alternatives`); empty when the name stands alone.
    pub alternatives: Vec<Alternative>,
    /// With alternatives: the sentence that says the recording cannot tell them apart.
    pub ambiguity: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Baseline {
    pub model: String,
    pub rmse: f64,
    pub heldout_rmse: f64,
    pub bic: f64,
    /// The load's ramp the first-order steps are driven by (an actuator's recordings: chosen
    /// once per data set by the baseline's held-out RMSE); absent when the load changes at once.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load_ramp: Option<super::preprocess::Ramp>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Unexplained {
    pub flag: bool,
    pub evidence: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Final {
    pub effects: Vec<&'static str>,
    pub rmse: f64,
    pub heldout_rmse: f64,
    /// Held-out units (a trial's hold, or one step of a single recording) the improved model
    /// predicts better than the baseline, of those scored by both.
    pub units_better: usize,
    pub units_scored: usize,
    /// The held-out RMSE of every unit, baseline and improved.
    pub heldout_by_unit: Vec<UnitError>,
    /// The improved model's first-order part (what a twin is calibrated from): the level at every
    /// load (the trials' mean offset plus the shared level), and every step's refitted time
    /// constant with the load it goes to. Empty with a simulator baseline.
    pub levels: Vec<[f64; 2]>,
    pub taus: Vec<[f64; 2]>,
}

/// One held-out unit's error: the hold from `start_s` (the step's onset; the trial's start for
/// the rest before its first step) of one recording.
#[derive(Debug, Clone, Serialize)]
pub struct UnitError {
    pub recording: String,
    pub start_s: f64,
    pub baseline_rmse: f64,
    pub improved_rmse: f64,
}

/// The units both scores hold, each with its start and both errors.
fn unit_errors(trials: &[Trial], base: &Score, cur: &Score) -> Vec<UnitError> {
    let rmse = |s: &Score, k: &(usize, usize)| s.unit_keys.iter().position(|x| x == k).map(|i| (s.units[i] / s.unit_n.get(i).copied().unwrap_or(1).max(1) as f64).sqrt());
    cur.unit_keys
        .iter()
        .filter_map(|k| {
            let tr = trials.get(k.0)?;
            // multi-trial units count segments from 1 at the first onset; a single recording's
            // units are its steps from 0
            let seg = if trials.len() >= 2 {
                k.1.checked_sub(1)
            } else if cur.blocks > 0 {
                k.1.checked_sub(1).map(|x| x / cur.blocks)
            } else {
                Some(k.1)
            };
            let start_s = seg.and_then(|s| tr.segs.get(s)).map(|s| s.t0).unwrap_or(tr.t.first().copied().unwrap_or(0.0));
            Some(UnitError { recording: tr.name.clone(), start_s, baseline_rmse: rmse(base, k)?, improved_rmse: rmse(cur, k)? })
        })
        .collect()
}

#[derive(Debug, Clone, Serialize)]
pub struct Decision {
    pub step: usize,
    pub candidate: &'static str,
    pub heldout_rmse: f64,
    pub gain: f64,
    /// Paired z of the held-out improvement over units.
    pub z: f64,
    pub delta_bic: f64,
    pub accepted: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    pub schema: &'static str,
    pub recordings: Vec<String>,
    pub unit: String,
    pub baseline: Baseline,
    pub findings: Vec<Finding>,
    pub unexplained: Unexplained,
    #[serde(rename = "final")]
    pub final_: Final,
    /// Every selection decision with its numbers (the stop rule: gain ≥ MIN_GAIN and ΔBIC ≤ MIN_DBIC).
    pub decisions: Vec<Decision>,
    /// Where the baseline fails, before any term is chosen: each catalogue signature's windows and
    /// the whiteness test's, each with its statistic.
    pub located: Vec<LocatedWindow>,
    /// What the baseline's own fits say about themselves: steps whose fitted τ describes creep
    /// (of the order of the hold, or slower than the jump it follows).
    pub notes: Vec<String>,
    /// Nuisances of the set-up the improved model carries (per-trial gains), with their evidence.
    pub nuisances: Vec<NuisanceTerm>,
    #[serde(skip)]
    pub predictions: Vec<Prediction>,
    /// For each finding whose name does not stand alone: the recording that would separate the
    /// names, with both predicted (issue 16, item 2; set by `cli::diagnose` through `advice`).
    pub advice: Vec<Advice>,
    /// Why an ambiguous finding got no advice.
    pub advice_notes: Vec<String>,
}

/// A window where the baseline fails, with the test that flagged it.
#[derive(Debug, Clone, Serialize)]
pub struct LocatedWindow {
    /// The test: an effect's signature ("creep", …) or "whiteness".
    pub test: &'static str,
    pub recording: String,
    pub start_s: f64,
    pub end_s: f64,
    pub statistic: String,
}

/// The most rows a prediction file holds: a longer recording's predictions are given at every
/// stride-th sample.
pub const MAX_PREDICTION_ROWS: usize = 1_000_000;

/// Per recording, per sample (every `stride`-th): measured, baseline and improved predictions.
#[derive(Debug, Clone)]
pub struct Prediction {
    pub stem: String,
    pub time_s: Vec<f64>,
    pub measured: Vec<f64>,
    pub baseline: Vec<f64>,
    pub improved: Vec<f64>,
    pub windows: Vec<(f64, f64)>,
    /// Samples of the (working-rate) recording per row.
    pub stride: usize,
    /// Each modelled term's contribution to the improved prediction at these samples (the
    /// prediction minus the same model with that term's coefficients at zero), with its name.
    pub contributions: Vec<(&'static str, Vec<f64>)>,
}

/// A sample beside a jump (a step faster than one sample): where within the sample interval the
/// load landed is unknown, so the samples from one interval before its onset to one and a half
/// after are not scored held out.
fn at_jump(tr: &Trial, t: f64) -> bool {
    let dt = sample_interval(tr);
    tr.segs.iter().any(|s| s.tau < dt && t >= s.t0 - dt && t <= s.t0 + 1.5 * dt)
}

/// A step faster than one sample (its τ set by [`super::fit::JUMP_TAU_SHARE`]).
fn is_jump(tr: &Trial, sg: &Seg) -> bool {
    sg.tau < sample_interval(tr)
}

fn sample_interval(tr: &Trial) -> f64 {
    let n = tr.t.len();
    if n < 2 {
        return f64::INFINITY;
    }
    (tr.t[n - 1] - tr.t[0]) / (n - 1) as f64
}

fn trials_from(report: &Report, prep: &Prepared, recs: &[Recording], opts: &Options) -> Vec<Trial> {
    let ramp = opts.pre.ramp.filter(|r| r.duration_s > 0.0);
    let mut out = Vec::new();
    for (ri, rec) in recs.iter().enumerate() {
        let block = analyze::filter_block(rec, opts);
        let series = &prep.series[ri];
        let mut segs = Vec::new();
        for st in &prep.steps[ri] {
            let Some(key) = report.steps.iter().position(|s| s.phase == st.phase && s.index == st.index) else { continue };
            let sr = &report.steps[key];
            let Some(f) = sr.lsq.as_ref() else { continue };
            let q = f.trials.iter().position(|tp| tp.recording == rec.source);
            let mut t0 = q.map(|q| f.trials[q].t0).unwrap_or(st.t_log);
            let mut tau = f.tau_s;
            // a ramped load: the step's onset is the ramp's end, where the data set's ramp puts it;
            // its duration is the step's own (an actuator's travel differs from step to step)
            let mut input = LoadIn::default();
            if let Some(r) = ramp {
                // a trial without its own part-1 fit of this step keeps the data set's ramp
                t0 = st.t_log + r.end_after_log_s;
                input = LoadIn { ramp_s: r.duration_s, smooth: r.smooth, curve: 0.0 };
                if let Some(q) = q {
                    let prev_end_s = prep.steps[ri].iter().filter(|p| p.t_log < st.t_log).map(|p| p.t_log + r.end_after_log_s).fold(series.t.first().copied().unwrap_or(0.0), f64::max);
                    let next_start_s = prep.steps[ri].iter().filter(|p| p.t_log > st.t_log).map(|p| p.t_log + r.end_after_log_s - r.duration_s).fold(f64::INFINITY, f64::min);
                    (t0, input) = step_ramp(series, t0, (f.trials[q].v0, f.k, f.tau_s), r, (prev_end_s, next_start_s));
                }
            }
            // a jump within one sample (fit::jump_time) is modelled as one; the creep or
            // relaxation after it is the diagnosis's
            if let Some(tj) = q.and_then(|q| sr.jumps.get(q).copied().flatten()) {
                t0 = tj;
                tau = super::fit::JUMP_TAU_SHARE / rec.sample_rate_hz();
            }
            segs.push(Seg { key, t0, load: st.after, prev: st.before, tau, phase: st.phase, t_log: st.t_log, input, sim: None });
        }
        let keep: Vec<usize> = (0..series.t.len()).filter(|&j| series.ok[j]).collect();
        out.push(Trial {
            name: rec.source.clone(),
            t: keep.iter().map(|&j| series.t[j]).collect(),
            v: keep.iter().map(|&j| series.v[j]).collect(),
            segs,
            sigma: series.sigma,
            // the raw samples' noise: a clip bends the filtered series within a few of these
            clip_margin: 2.0 * series.sigma * (block as f64).sqrt(),
            half_span_s: if block > 1 { 0.5 * block as f64 / rec.sample_rate_hz() } else { 0.0 },
            prior0: None,
            given_t: series.given_t.clone(),
            given_v: series.given_v.clone(),
        });
    }
    out
}

/// Paired z over the units listed in `only` (all units when it is empty). With fewer than three
/// such units a z cannot be formed: every one of them must then at least halve its error, which
/// counts as passing (MIN_Z), else 0.
/// The paired z of a change that adds or removes a clip (`clip`): a clip can only change the units
/// that reach it, so its evidence is tested there; any other change over every unit.
fn change_z(clip: bool, before: &Score, after: &Score, clip_steps: &ClipSteps) -> f64 {
    if clip {
        paired_z_on(before, after, &clip_steps.units)
    } else {
        paired_z(&before.units, &after.units)
    }
}

fn paired_z_on(before: &Score, after: &Score, only: &[(usize, usize)]) -> f64 {
    if only.is_empty() {
        return paired_z(&before.units, &after.units);
    }
    let pick = |s: &Score| -> Vec<f64> { s.unit_keys.iter().zip(&s.units).filter(|(k, _)| only.contains(k)).map(|(_, v)| *v).collect() };
    let (b, a) = (pick(before), pick(after));
    if b.len() < 3 {
        return if !b.is_empty() && b.iter().zip(&a).all(|(x, y)| *y <= 0.5 * x) { MIN_Z } else { 0.0 };
    }
    paired_z(&b, &a)
}

/// The steps a clip shapes, per (trial, segment): those rising into it ("into") and those
/// starting from a clipped load ("from"), and the (trial, segment) units where a clip's evidence
/// lies (units count segments from 1).
fn clipped_segments(trials: &[Trial], clip: f64) -> ClipSteps {
    let (mut into, mut from) = (Vec::new(), Vec::new());
    for (k, tr) in trials.iter().enumerate() {
        let at = 0.25 * tr.sigma.max(1e-12);
        let mut prev_clipped = false;
        for (s, sg) in tr.segs.iter().enumerate() {
            let end = tr.segs.get(s + 1).map(|x| x.t0).unwrap_or(f64::INFINITY);
            let reaches = tr.t.iter().zip(&tr.v).any(|(&t, &v)| t >= sg.t0 && t < end && v >= clip - at);
            if prev_clipped && sg.load < sg.prev {
                from.push((k, s));
            } else if reaches {
                into.push((k, s));
            }
            prev_clipped = reaches;
        }
    }
    // the evidence: the rising steps, whose shape the clip changes (the falling steps' onsets are
    // moved so the clip leaves them as they were)
    let units = into.iter().map(|&(k, s)| (k, s + 1)).collect();
    ClipSteps { into, from, units }
}

/// τ of the other steps as a straight line in the load (least squares), as the first-order
/// model's τ(F) is; None with fewer than two other steps.
fn tau_line(trials: &[Trial], skip: &[(usize, usize)]) -> Option<(f64, f64)> {
    let free: Vec<(f64, f64)> = trials
        .iter()
        .enumerate()
        .flat_map(|(k, tr)| tr.segs.iter().enumerate().filter(move |(s, _)| !skip.contains(&(k, *s))).map(|(_, sg)| (sg.load, sg.tau)))
        .filter(|p| p.1 > 0.0)
        .collect();
    if free.len() < 2 {
        return None;
    }
    let n = free.len() as f64;
    let (mx, my) = (free.iter().map(|p| p.0).sum::<f64>() / n, free.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = free.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let b = if sxx > 0.0 { free.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx } else { 0.0 };
    Some((my - b * mx, b))
}

/// The onset of a step rising into the clip with time constant `tau`: a local first-order fit
/// (offset and amplitude free) to its samples below the clip, over a grid of onsets around the
/// part-1 onset.
fn rising_onset(tr: &Trial, s: usize, tau: f64, clip: f64) -> f64 {
    let sg = &tr.segs[s];
    let end = tr.segs.get(s + 1).map(|x| x.t0).unwrap_or(f64::INFINITY);
    let pts: Vec<(f64, f64)> =
        tr.t.iter().zip(&tr.v).filter(|(&t, &v)| t >= sg.t0 - 1.0 && t < end && v < clip - tr.clip_margin.max(0.5 * tr.sigma).max(1e-12)).map(|(&t, &v)| (t, v)).collect();
    let mut best = (f64::INFINITY, sg.t0);
    for g in 0..=120 {
        let t0 = sg.t0 - 0.8 + 0.01 * g as f64;
        // v = a + b·u(t), u = 1 − e^(−(t − t0)/τ) after t0, 0 before: linear least squares in (a, b)
        let (mut s_u, mut s_uu, mut s_v, mut s_uv, mut s_vv) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(t, v) in &pts {
            let u = if t > t0 { 1.0 - catalogue::decay((t - t0) / tau) } else { 0.0 };
            s_u += u;
            s_uu += u * u;
            s_v += v;
            s_uv += u * v;
            s_vv += v * v;
        }
        let n = pts.len() as f64;
        let det = n * s_uu - s_u * s_u;
        if det.abs() < 1e-12 {
            continue;
        }
        let b = (n * s_uv - s_u * s_v) / det;
        let a = (s_v - b * s_u) / n;
        let rss = s_vv - a * s_v - b * s_uv;
        if rss < best.0 {
            best = (rss, t0);
        }
    }
    best.1
}

/// Time constants and onsets of the steps rising into a clip: τ from the other steps' τ line,
/// onset from a local fit below the clip (the part-1 fit of the clipped shape is biased). The steps
/// falling from it restart at the clip instead (`Config::restart`).
fn clip_fixes(trials: &[Trial], clip: f64, steps: &ClipSteps) -> Vec<FixedStep> {
    let Some((a, b)) = tau_line(trials, &[steps.into.as_slice(), steps.from.as_slice()].concat()) else { return vec![] };
    steps
        .into
        .iter()
        .map(|&(k, s)| {
            let tau_s = (a + b * trials[k].segs[s].load).max(1e-3);
            FixedStep { at: (k, s), tau_s, t0_s: rising_onset(&trials[k], s, tau_s, clip) }
        })
        .collect()
}

fn clip_level(trials: &[Trial]) -> Option<f64> {
    let sigma = trials.iter().map(|t| t.sigma).fold(0.0, f64::max);
    catalogue::saturation::clip_level(&trials.iter().map(|t| t.v.as_slice()).collect::<Vec<_>>(), sigma)
}

/// One hold of one trial with a model's residuals (the stretch before the first step included).
struct HoldData {
    trial: usize,
    t: Vec<f64>,
    r: Vec<f64>,
    t0: f64,
    end: f64,
    tau: f64,
    load: f64,
    prev: f64,
}

fn hold_data(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat) -> Vec<HoldData> {
    let mut out = Vec::new();
    let mut buf = Vec::new();
    for (i, tr) in trials.iter().enumerate() {
        let Some(first) = tr.segs.first() else { continue };
        let mut spans = vec![(tr.t[0], first.t0, 0.0, first.prev, first.prev)];
        for (s, sg) in tr.segs.iter().enumerate() {
            let end = tr.segs.get(s + 1).map(|n| n.t0).unwrap_or(tr.t[tr.t.len() - 1] + 1e-9);
            spans.push((cfg.t0_of(i, s, sg), end, cfg.tau_of(i, s, sg), sg.load, sg.prev));
        }
        for (t0, end, tau, load, prev) in spans {
            let idx: Vec<usize> = (0..tr.t.len()).filter(|&j| tr.t[j] >= t0 && tr.t[j] < end).collect();
            let t: Vec<f64> = idx.iter().map(|&j| tr.t[j]).collect();
            let r: Vec<f64> = idx.iter().map(|&j| tr.v[j] - predict(d, i, tr, tr.t[j], x, cfg, hat, &mut buf)).collect();
            out.push(HoldData { trial: i, t, r, t0, end, tau, load, prev });
        }
    }
    out
}

/// Where an effect's signature shows in a model's residuals.
fn signature(e: Effect, holds: &[HoldData], trials: &[Trial], clip: Option<f64>, report: &Report) -> Vec<Window> {
    let views: Vec<catalogue::Hold> = holds
        .iter()
        .map(|h| catalogue::Hold {
            recording: &trials[h.trial].name,
            t: &h.t,
            r: &h.r,
            sigma: trials[h.trial].sigma,
            t0_s: h.t0,
            end_s: h.end,
            tau_s: h.tau,
            load: h.load,
            prev: h.prev,
            trial: h.trial,
        })
        .collect();
    let found = match e {
        Effect::Creep => catalogue::creep::signature(&views),
        Effect::Hysteresis => catalogue::hysteresis::signature(&views),
        Effect::SecondTimeConstant => catalogue::second_time_constant::signature(&views),
        Effect::Relaxation => {
            let mut w = catalogue::creep::signature(&views);
            w.extend(catalogue::second_time_constant::signature(&views));
            w
        }
        Effect::BaselineDrift => catalogue::baseline_drift::signature(&views),
        Effect::Saturation => match clip {
            Some(level) => trials.iter().flat_map(|tr| catalogue::saturation::signature(&tr.name, &tr.t, &tr.v, level, tr.sigma)).collect(),
            None => vec![],
        },
        Effect::HandlingSpikes => report
            .recordings
            .iter()
            .flat_map(|r| {
                r.spikes.iter().map(move |w| catalogue::Located {
                    recording: r.source.clone(),
                    start_s: w.start_s,
                    end_s: w.end_s,
                    statistic: format!("peak {:+.4} {}", w.peak, r.unit),
                    z: f64::INFINITY,
                })
            })
            .collect(),
        Effect::RestRelaxation => vec![],
    };
    found.into_iter().map(|l| Window { recording: l.recording, start_s: l.start_s, end_s: l.end_s, statistic: l.statistic }).collect()
}

/// White noise of a residual segment: 1.4826 × the median absolute deviation of its first
/// differences, over √2.
fn local_noise(r: &[f64]) -> f64 {
    if r.len() < 3 {
        return 0.0;
    }
    let mut d: Vec<f64> = r.windows(2).map(|p| p[1] - p[0]).collect();
    let mid = d.len() / 2;
    let med = *d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let mut dev: Vec<f64> = d.iter().map(|x| (x - med).abs()).collect();
    let mad = *dev.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    1.4826 * mad / std::f64::consts::SQRT_2
}

/// Residual windows per step segment where the model fails.
fn locate(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat) -> Vec<Window> {
    let mut out = Vec::new();
    let mut buf = Vec::new();
    for (i, tr) in trials.iter().enumerate() {
        let mut bounds: Vec<f64> = vec![tr.t[0]];
        bounds.extend(tr.segs.iter().map(|s| s.t0));
        bounds.push(tr.t[tr.t.len() - 1] + 1e-9);
        for w in bounds.windows(2) {
            let idx: Vec<usize> = (0..tr.t.len()).filter(|&j| tr.t[j] >= w[0] && tr.t[j] < w[1]).collect();
            if idx.len() < 10 {
                continue;
            }
            let r: Vec<f64> = idx.iter().map(|&j| tr.v[j] - predict(d, i, tr, tr.t[j], x, cfg, hat, &mut buf)).collect();
            let n = r.len() as f64;
            let rms = (r.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
            let mean = r.iter().sum::<f64>() / n;
            let var = r.iter().map(|e| (e - mean).powi(2)).sum::<f64>().max(1e-300);
            let ac1 = r.windows(2).map(|p| (p[0] - mean) * (p[1] - mean)).sum::<f64>() / var;
            // against the noise where it is: a resistance read without its divider is far noisier
            // loaded than unloaded, so the recording's one noise figure would call the loaded
            // steps' own noise a misfit. The local figure is the robust spread of the residual's
            // sample-to-sample differences, which a slow misfit hardly touches.
            let ratio = rms / tr.sigma.max(local_noise(&r)).max(1e-12);
            if ratio > 1.5 && ac1 > 0.5 {
                out.push(Window { recording: tr.name.clone(), start_s: w[0], end_s: w[1], statistic: format!("residual RMS {ratio:.2} × noise, lag-1 autocorrelation {ac1:.2}") });
            }
        }
    }
    out
}

/// What the residual does right after the steps: a transient of one sign after loading and
/// unloading steps alike (a response to the change itself, which no term of the catalogue has),
/// or one that follows the step's direction (a faster or slower relaxation than modelled).
fn step_transients(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat, unit: &str) -> Option<String> {
    let mut buf = Vec::new();
    let (mut up, mut down) = (Vec::new(), Vec::new());
    for (i, tr) in trials.iter().enumerate() {
        for (s, sg) in tr.segs.iter().enumerate() {
            let end = tr.segs.get(s + 1).map(|n| n.t0).unwrap_or(f64::INFINITY);
            let early = sg.t0 + 0.1 * (end.min(tr.t[tr.t.len() - 1]) - sg.t0);
            let r: Vec<f64> = (0..tr.t.len()).filter(|&j| tr.t[j] >= sg.t0 && tr.t[j] < early).map(|j| tr.v[j] - predict(d, i, tr, tr.t[j], x, cfg, hat, &mut buf)).collect();
            if r.len() < 3 {
                continue;
            }
            let m = r.iter().sum::<f64>() / r.len() as f64;
            if m.abs() > 3.0 * tr.sigma {
                if sg.load > sg.prev {
                    up.push(m)
                } else {
                    down.push(m)
                }
            }
        }
    }
    let (nu, nd) = (up.len(), down.len());
    if nu < 2 || nd < 2 {
        return None;
    }
    let pos = |v: &[f64]| v.iter().filter(|m| **m > 0.0).count() as f64 / v.len() as f64;
    let (pu, pd) = (pos(&up), pos(&down));
    let mean_abs = |v: &[f64]| v.iter().map(|m| m.abs()).sum::<f64>() / v.len() as f64;
    let sig = |v: f64| {
        let digits = (2 - v.abs().max(1e-300).log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    };
    let size = format!("by {} {unit} after loading, {} {unit} after unloading, mean over the first tenth of each step", sig(mean_abs(&up)), sig(mean_abs(&down)));
    if (pu >= 0.8 && pd >= 0.8) || (pu <= 0.2 && pd <= 0.2) {
        let sign = if pu >= 0.8 { "above" } else { "below" };
        Some(format!(
            "after {nu} loading and {nd} unloading steps the data run {sign} the model at first, whichever way the load changed ({size}): a response to the change itself (a strain-rate or overshoot transient), which no term of the catalogue has"
        ))
    } else if (pu >= 0.8 && pd <= 0.2) || (pu <= 0.2 && pd >= 0.8) {
        Some(format!(
            "after {nu} loading and {nd} unloading steps the early residual follows the step's direction ({size}): the relaxation is {} than the model's",
            if pu >= 0.8 { "faster at first" } else { "slower at first" }
        ))
    } else {
        None
    }
}

/// The simulator as the baseline: its sensor model and the preload (g) on top of the logged loads.
pub struct SimBaseline<'a> {
    pub sensor: &'a crate::params::sensor::SensorParams,
    pub preload_g: f64,
}

pub fn diagnose(recs: &[Recording], opts: &Options) -> Option<Diagnosis> {
    diagnose_with(recs, opts, None)
}

/// With `sim`, the simulator's first-order prediction for each trial's logged protocol (at the
/// onsets found in the data) is the baseline; only per-trial offsets and catalogue terms are fitted.
///
/// A simulator whose preload is not the recordings' is corrected first: the preload that fits the
/// recordings best is sought, and when it predicts held-out data better it is named as a preload
/// (or offset) mismatch, the first finding, and the rest of the diagnosis runs on the corrected
/// simulator (a wrong preload changes every level and time constant, and would otherwise be
/// taken for other effects).
pub fn diagnose_with(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>) -> Option<Diagnosis> {
    let Some(sb) = sim else { return run_spike_checked(recs, opts, None, false) };
    let Some((given, best, best_score)) = preload_search(recs, opts, sb) else { return run_spike_checked(recs, opts, sim, false) };
    let gain = (given.heldout_rmse - best_score.heldout_rmse) / given.heldout_rmse.max(1e-300);
    if gain < MIN_PRELOAD_GAIN || (best - sb.preload_g).abs() < 1.0 {
        return run_spike_checked(recs, opts, sim, false);
    }
    let corrected = SimBaseline { sensor: sb.sensor, preload_g: best };
    let mut d = run_spike_checked(recs, opts, Some(&corrected), false)?;
    let dbic = best_score.bic - given.bic + (given.n.max(2) as f64).ln();
    d.findings.insert(
        0,
        Finding {
            effect: "preload_mismatch",
            confidence: if gain > 0.25 { "high" } else { "medium" },
            explanation: format!(
                "the recordings sit where the simulator puts a preload of {} g, not the {} g it was given (--rig manifest or the sensor file's rig.preload_g): a constant load the logged protocol leaves out (the plunger's mass, a pre-tensioned cover) or a level offset; corrected before any other term was sought",
                catalogue::sig3(best),
                catalogue::sig3(sb.preload_g)
            ),
            windows: vec![],
            term: Term { name: "preload_mismatch".into(), params: serde_json::json!({"preload_g_given": sb.preload_g, "preload_g_fitted": best}) },
            heldout_rmse_before: given.heldout_rmse,
            heldout_rmse_after: best_score.heldout_rmse,
            delta_bic: dbic,
            alternatives: vec![],
            ambiguity: None,
        },
    );
    d.final_.effects.insert(0, "preload_mismatch");
    d.baseline.rmse = given.rmse;
    d.baseline.heldout_rmse = given.heldout_rmse;
    d.baseline.bic = given.bic;
    Some(d)
}

/// A preload correction is named when it lowers the simulator baseline's held-out RMSE by this.
pub const MIN_PRELOAD_GAIN: f64 = 0.10;

/// The simulator baseline's score at the given preload, and the preload (g) that fits the
/// recordings best with its score: a coarse grid over 0 to max(200 g, 4 × given, the largest
/// load), then golden section around the best point (on the fit RMSE; held-out decides above).
fn preload_search(recs: &[Recording], opts: &Options, sb: &SimBaseline) -> Option<(Score, f64, Score)> {
    let score_at = |p: f64| -> Option<Score> {
        match run(recs, opts, Some(&SimBaseline { sensor: sb.sensor, preload_g: p }), false, true)? {
            Outcome::Baseline(s) => Some(s),
            _ => None,
        }
    };
    let given = score_at(sb.preload_g)?;
    let kind = recs.first()?.protocol_kind;
    let top = recs.iter().flat_map(|r| r.protocol.iter().filter_map(|&x| kind.grams(x))).fold(0.0f64, f64::max);
    let hi = 200f64.max(4.0 * sb.preload_g).max(top);
    let grid: Vec<f64> = (0..=12).map(|i| hi * (i as f64 / 12.0).powi(2)).collect();
    let mut scored: Vec<(f64, f64)> = grid.iter().filter_map(|&p| score_at(p).map(|s| (p, s.rmse))).collect();
    scored.push((sb.preload_g, given.rmse));
    scored.sort_by(|a, b| a.0.total_cmp(&b.0));
    let k = (0..scored.len()).min_by(|&a, &b| scored[a].1.total_cmp(&scored[b].1))?;
    let (mut a, mut b) = (scored[k.saturating_sub(1)].0, scored[(k + 1).min(scored.len() - 1)].0);
    let phi = 0.618_033_988_749_895;
    for _ in 0..14 {
        let (c, e) = (b - phi * (b - a), a + phi * (b - a));
        match (score_at(c), score_at(e)) {
            (Some(sc), Some(se)) if sc.rmse <= se.rmse => b = e,
            (Some(_), Some(_)) => a = c,
            _ => break,
        }
    }
    let best = 0.5 * (a + b);
    let s = score_at(best)?;
    Some((given, best, s))
}

/// The load's ramp of an actuator's recordings as `diagnose` fits it (None for loads placed by
/// hand, or when no ramp beats the step at once): for `fit`, whose step fits then take the level
/// before each ramp and fit from its end.
pub fn load_ramp(recs: &[Recording], opts: &Options) -> Option<super::preprocess::Ramp> {
    let lsq = Options { method: analyze::Method::Lsq, ..opts.clone() };
    with_ramp(recs, &lsq).pre.ramp
}

/// The estimation floor of the model's first-order part: [`diagnose`] with the final refit done
/// even when no term is chosen, so its `baseline` predictions are what the improved model reduces
/// to when the data hold no effect. On the same noise without an effect, their error to the truth
/// is the least error any model with the baseline's freedom (levels, time constants, onsets) plus
/// terms can be expected to reach (the discovery benchmark's floor column).
pub fn refitted_baseline(recs: &[Recording], opts: &Options) -> Option<Diagnosis> {
    run_spike_checked(recs, opts, None, true)
}

/// What one pass of the diagnosis gives: the diagnosis, or the finding that the handling spikes it
/// would exclude are not spikes, decided before any term is selected.
enum Outcome {
    Done(Box<Diagnosis>),
    SpikesRejected {
        windows: Vec<Window>,
        before: f64,
        after: f64,
        unit: String,
    },
    /// Only the baseline was scored (a simulator preload being searched).
    Baseline(Score),
}

/// Handling spikes are excluded only when held-out evidence agrees. Excluding true spikes lowers
/// the baseline's held-out error (the bench's spike cases: −36 % to −91 %); short excursions at
/// step edges that are the first-order model's misfit (a large, slow second relaxation: the curve
/// leaves the data right at the edge) look alike to the detectors, but excluding them cuts the
/// edges that pin the onsets and raises it (0.033 → 0.045 V on a 22 % second relaxation). `run`
/// compares the two baselines before selection and stops there; the diagnosis then runs on the
/// data as given, and the windows are kept as located failures of the baseline, each saying why
/// it was not excluded.
fn run_spike_checked(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool) -> Option<Diagnosis> {
    let with_ramp = if sim.is_none() { with_ramp(recs, opts) } else { opts.clone() };
    let opts = &with_ramp;
    let (windows, before, after, unit) = match run(recs, opts, sim, refit_always, false)? {
        Outcome::Done(d) => return Some(*d),
        Outcome::SpikesRejected { windows, before, after, unit } => (windows, before, after, unit),
        Outcome::Baseline(_) => return None,
    };
    let mut as_given = opts.clone();
    as_given.pre.handling = false;
    let Outcome::Done(mut again) = run(recs, &as_given, sim, refit_always, false)? else { return None };
    let why = format!(
        "short excursion at a step edge, not excluded as a handling spike: excluding the {} such window(s) raised the baseline's held-out RMSE {} → {} {unit}, so they are the model's misfit at the edges",
        windows.len(),
        catalogue::sig3(before),
        catalogue::sig3(after),
    );
    again.located.extend(windows.into_iter().map(|w| LocatedWindow {
        test: Effect::HandlingSpikes.name(),
        recording: w.recording,
        start_s: w.start_s,
        end_s: w.end_s,
        statistic: format!("{}; {why}", w.statistic),
    }));
    Some(*again)
}

/// Where a term's signature shows in the residuals of the model before it entered (the whiteness
/// test's windows when the signature alone does not reach its threshold).
#[allow(clippy::too_many_arguments)]
fn entry_windows(e: Effect, d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat, clip: Option<f64>, report: &Report) -> Vec<Window> {
    let windows = signature(e, &hold_data(d, trials, x, cfg, hat), trials, clip, report);
    if windows.is_empty() {
        locate(d, trials, x, cfg, hat)
    } else {
        windows
    }
}

/// The z of the accepted candidate `e` in round `round`.
fn z_of(decisions: &[Decision], round: usize, e: Effect) -> f64 {
    decisions.iter().rev().find(|dc| dc.step == round && dc.candidate == e.name()).map(|dc| dc.z).unwrap_or(f64::NAN)
}

/// A finding's confidence from its held-out gain and its ΔBIC.
fn confidence(dbic: f64, gain: f64) -> &'static str {
    if dbic < -100.0 && gain > 0.05 {
        "high"
    } else if dbic < -30.0 {
        "medium"
    } else {
        "low"
    }
}

/// What the forward step needs to propose a term: the design, the trials, the levels, the clip
/// and the median first-order τ (the second relaxation's grid is relative to it).
struct Ctx<'a> {
    d: &'a Design,
    trials: &'a [Trial],
    hat: &'a Hat,
    clip: Option<f64>,
    clip_steps: &'a ClipSteps,
    med_tau: f64,
}

/// The model `cur` with effect `e` added, its shape parameters chosen on the training fit (not on
/// held-out data): the second relaxation's τ2 and drive on their grid, a clip at the recording's
/// level, a rest relaxation's τ; a second relaxation already in the model has its τ2 refitted.
fn candidate(e: Effect, cur: &Config, ctx: &Ctx) -> Option<Config> {
    let (d, trials, hat, clip, clip_steps, med_tau) = (ctx.d, ctx.trials, ctx.hat, ctx.clip, ctx.clip_steps, ctx.med_tau);
    let cands: Vec<Config> = match e {
        Effect::RestRelaxation => nuisance::rest_candidates(d, trials, cur),
        Effect::SecondTimeConstant => [Drive::Change, Drive::Size]
            .iter()
            .flat_map(|&drive| TAU2_GRID.iter().map(move |m| (drive, m)))
            .map(|(drive, m)| {
                let mut c = cur.clone();
                c.effects.push(e);
                c.tau2 = m * med_tau;
                c.drive = drive;
                c
            })
            .collect(),
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
            vec![c]
        }
        _ => {
            let mut c = cur.clone();
            c.effects.push(e);
            vec![c]
        }
    };
    // shape parameters are chosen on the training fit (not on held-out data)
    let mut pick: Option<(Config, f64)> = None;
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
            if pick.as_ref().is_none_or(|p| b < p.1) {
                pick = Some((c, b));
            }
        }
    }
    let (mut c, mut b0) = pick?;
    // a second relaxation already in the model: its τ2 is refitted with the new term (a
    // term left out biases it — drift lengthens τ2), by a local search on the grid
    if e != Effect::SecondTimeConstant && c.effects.contains(&Effect::SecondTimeConstant) {
        loop {
            let mut moved = false;
            for f in [1.0 / TAU2_STEP, TAU2_STEP] {
                let mut cand = c.clone();
                cand.tau2 *= f;
                if cand.tau2 < TAU2_GRID[0] * med_tau * 0.99 || cand.tau2 > TAU2_GRID[TAU2_GRID.len() - 1] * med_tau * 1.01 {
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
    }
    Some(c)
}

/// The model `cur` without its `idx`-th effect (a clip's fixed steps and a rest relaxation's τ
/// go with it).
fn without(cur: &Config, idx: usize) -> Config {
    let mut c = cur.clone();
    let e = c.effects.remove(idx);
    if e == Effect::Saturation {
        c.clip = None;
        c.tau_fixed.clear();
        c.restart.clear();
    }
    if e == Effect::RestRelaxation {
        c.rest_tau = None;
    }
    if e == Effect::BaselineDrift {
        c.drift_tau = None;
    }
    c
}

/// Where the baseline fails, before any term is chosen: the whiteness test's windows and every
/// catalogue signature's on the baseline's residuals (the clean fit `xc`).
fn located_windows(d: &Design, trials: &[Trial], xc: &[f64], base_cfg: &Config, hat: &Hat, clip: Option<f64>, report: &Report) -> Vec<LocatedWindow> {
    let holds = hold_data(d, trials, xc, base_cfg, hat);
    let mut all: Vec<LocatedWindow> = locate(d, trials, xc, base_cfg, hat)
        .into_iter()
        .map(|w| LocatedWindow { test: "whiteness", recording: w.recording, start_s: w.start_s, end_s: w.end_s, statistic: w.statistic })
        .collect();
    for e in [Effect::Creep, Effect::Hysteresis, Effect::SecondTimeConstant, Effect::BaselineDrift, Effect::Saturation, Effect::HandlingSpikes] {
        all.extend(signature(e, &holds, trials, clip, report).into_iter().map(|w| LocatedWindow {
            test: e.name(),
            recording: w.recording,
            start_s: w.start_s,
            end_s: w.end_s,
            statistic: w.statistic,
        }));
    }
    all
}

/// The findings that are reported, not modelled: a clipped plateau the free levels absorbed (the
/// plateau is its own evidence: samples piled at one value with no noise on them), and handling
/// spikes (excluded from every fit; their held-out numbers are the baseline's on the data as given
/// and without them).
fn reported_only(trials: &[Trial], cur: &Config, cur_score: &Score, clip: Option<f64>, report: &Report, (base, clean): (&Score, &Score)) -> Vec<Finding> {
    let mut out = Vec::new();
    // saturation the free levels absorbed: the clipped plateau is its own evidence (samples piled
    // at one value with no noise on them)
    if let (Some(level), false) = (clip, cur.effects.contains(&Effect::Saturation)) {
        let windows = signature(Effect::Saturation, &[], trials, clip, report);
        if !windows.is_empty() {
            out.push(Finding {
                effect: Effect::Saturation.name(),
                confidence: "medium",
                explanation: format!(
                    "{}; the per-load levels absorb the clip, so held-out prediction cannot improve: the evidence is the plateau itself",
                    Effect::Saturation.explanation()
                ),
                windows,
                term: Term { name: "saturation_term".into(), params: serde_json::json!({"level": level}) },
                heldout_rmse_before: cur_score.heldout_rmse,
                heldout_rmse_after: cur_score.heldout_rmse,
                delta_bic: 0.0,
                alternatives: vec![],
                ambiguity: None,
            });
        }
    }
    // handling spikes: reported and excluded, never modelled
    let spikes = signature(Effect::HandlingSpikes, &[], trials, clip, report);
    if !spikes.is_empty() {
        let n_spikes = spikes.len();
        out.push(Finding {
            effect: Effect::HandlingSpikes.name(),
            confidence: if spikes.len() >= 2 { "high" } else { "medium" },
            explanation: Effect::HandlingSpikes.explanation().to_string(),
            windows: spikes,
            term: Term { name: "excluded".into(), params: serde_json::json!({"windows_excluded": n_spikes}) },
            heldout_rmse_before: base.heldout_rmse,
            heldout_rmse_after: clean.heldout_rmse,
            delta_bic: clean.bic - base.bic,
            alternatives: vec![],
            ambiguity: None,
        });
    }
    out
}

/// The first-order part of a solved model: (load, level) for every load (the trials' mean offset
/// plus the shared level) and (load, τ) for every step.
fn first_order_part(d: &Design, cfg: &Config, x: &[f64], trials: &[Trial]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let n = d.n_trials;
    let offset = x.iter().take(n).sum::<f64>() / n.max(1) as f64;
    let levels = d.loads.iter().enumerate().map(|(j, &l)| [l, offset + if j == 0 { 0.0 } else { x.get(n + j - 1).copied().unwrap_or(f64::NAN) }]).collect();
    // τ as the model has it: a clip's fixed τ, or the step's τ with its shape correction
    // (coefficient −Δ ln τ); a jump (faster than a sample) has no τ to tell
    let taus = trials
        .iter()
        .enumerate()
        .flat_map(|(i, tr)| {
            tr.segs.iter().enumerate().filter(|(_, sg)| !is_jump(tr, sg)).map(move |(s, sg)| {
                let mut tau = cfg.tau_of(i, s, sg);
                if cfg.tau_free && !d.prior && cfg.fixed(i, s).is_none() {
                    tau *= (-x.get(d.n_levels() + sg.key).copied().unwrap_or(0.0)).exp();
                }
                [sg.load, tau]
            })
        })
        .collect();
    (levels, taus)
}

/// The diagnosis; with `baseline_only`, only the baseline's score.
fn run(recs: &[Recording], opts: &Options, sim: Option<&SimBaseline>, refit_always: bool, baseline_only: bool) -> Option<Outcome> {
    let (report, prep) = analyze::analyze(recs, opts);
    let mut trials = trials_from(&report, &prep, recs, opts);
    // the baseline is the paper's model fitted to the data as given: with handling spikes found,
    // its steps (onsets, time constants) are the part-1 fits of the series with the spikes left in
    let has_spikes = report.recordings.iter().any(|r| !r.spikes.is_empty());
    let mut given_trials: Option<Vec<Trial>> = if has_spikes {
        let mut o = opts.clone();
        o.pre.handling = false;
        let (rep_g, prep_g) = analyze::analyze(recs, &o);
        let g = trials_from(&rep_g, &prep_g, recs, opts);
        let same = g.len() == trials.len() && g.iter().zip(&trials).all(|(a, b)| a.segs.len() == b.segs.len() && a.segs.iter().zip(&b.segs).all(|(x, y)| x.key == y.key));
        same.then_some(g)
    } else {
        None
    };
    if let Some(sb) = sim {
        let kind = recs.first()?.protocol_kind;
        let force = |load: f64| kind.grams(load).map(|g| (g + sb.preload_g) / 1000.0 * super::sim::G_N_PER_KG);
        for tr in trials.iter_mut().chain(given_trials.iter_mut().flatten()) {
            let f0 = force(tr.segs.first().map(|s| s.prev).unwrap_or(0.0))?;
            tr.prior0 = Some(sb.sensor.v_eq(f0));
            for sg in &mut tr.segs {
                let (fa, fb) = (force(sg.load)?, force(sg.prev)?);
                sg.sim = Some((sb.sensor.v_eq(fa) - sb.sensor.v_eq(fb), sb.sensor.tau(fa)));
                sg.tau = sb.sensor.tau(fa);
            }
        }
    }
    let mut loads: Vec<f64> = trials.iter().flat_map(|t| t.segs.iter().flat_map(|s| [s.load, s.prev])).collect();
    loads.sort_by(|a, b| a.partial_cmp(b).unwrap());
    loads.dedup();
    if loads.len() < 2 {
        return None;
    }
    let n_keys = trials.iter().flat_map(|t| t.segs.iter().map(|s| s.key + 1)).max().unwrap_or(0);
    // steps whose edge lost a handling spike: their onsets are refitted with the shared levels
    let refit_onset: Vec<(usize, usize)> = trials
        .iter()
        .enumerate()
        .flat_map(|(k, tr)| {
            let spikes = report.recordings.iter().find(|r| r.source == tr.name).map(|r| r.spikes.clone()).unwrap_or_default();
            tr.segs
                .iter()
                .enumerate()
                .filter(move |(_, sg)| spikes.iter().any(|w| w.end_s >= sg.t0 - 0.5 && w.start_s <= sg.t0 + 1.0))
                .map(move |(s, _)| (k, s))
                .collect::<Vec<_>>()
        })
        .collect();
    let d = Design { loads: loads.clone(), n_trials: trials.len(), n_keys, refit_onset, prior: sim.is_some(), exact_shape: false };
    // levels per load for the terms built on them (two-stage): from a first fit, or the simulator's
    let hat = match sim {
        Some(sb) => {
            let kind = recs[0].protocol_kind;
            let level = loads.iter().map(|&l| kind.grams(l).map(|g| sb.sensor.v_eq((g + sb.preload_g) / 1000.0 * super::sim::G_N_PER_KG)).unwrap_or(0.0)).collect();
            Hat { loads: loads.clone(), level }
        }
        None => {
            let level_cfg = Config {
                tau_free: false,
                effects: vec![],
                tau2: 1.0,
                drive: Drive::Change,
                clip: None,
                tau_fixed: vec![],
                restart: vec![],
                relax: None,
                gains: false,
                rest_tau: None,
                drift_tau: None,
            };
            let rows = all_rows(&trials);
            let x0 = solve(&d, &trials, &rows, &level_cfg, &Hat::default())?;
            let mut level = vec![0.0];
            level.extend(x0[trials.len()..trials.len() + loads.len() - 1].iter().copied());
            Hat { loads: loads.clone(), level }
        }
    };
    let hat0 = hat.clone();
    // the baseline: first-order steps with their levels and time constants refitted jointly
    let base_cfg =
        Config { tau_free: true, effects: vec![], tau2: 1.0, drive: Drive::Change, clip: None, tau_fixed: vec![], restart: vec![], relax: None, gains: false, rest_tau: None, drift_tau: None };
    // fitted to the series as given (with the steps fitted to it), scored on the series without
    // the spikes (with the same steps); the diagnosis works on the latter, and the spikes are
    // reported and excluded below
    let base_eval: Vec<Trial> = match &given_trials {
        Some(g) => trials.iter().zip(g).map(|(tr, gt)| Trial { segs: gt.segs.clone(), ..tr.clone() }).collect(),
        None => trials.clone(),
    };
    let base_fit: Vec<Trial> =
        if has_spikes { base_eval.iter().map(|tr| Trial { t: tr.given_t.clone(), v: tr.given_v.clone(), ..tr.clone() }).collect() } else { base_eval.clone() };
    let (base, xb) = score_on(&d, &base_fit, &base_eval, &base_cfg, &hat)?;
    if baseline_only {
        return Some(Outcome::Baseline(base));
    }
    let (clean, xc) = if has_spikes { score(&d, &trials, &base_cfg, &hat)? } else { (base.clone(), xb.clone()) };
    if has_spikes && clean.heldout_rmse > base.heldout_rmse {
        let windows = signature(Effect::HandlingSpikes, &[], &trials, None, &report);
        return Some(Outcome::SpikesRejected { windows, before: base.heldout_rmse, after: clean.heldout_rmse, unit: report.unit.clone() });
    }
    let clip = clip_level(&trials);
    // locate: every test on the baseline's residuals (the clean fit), before any term is chosen
    let located = located_windows(&d, &trials, &xc, &base_cfg, &hat, clip, &report);
    let clip_steps = match clip {
        Some(c) => clipped_segments(&trials, c),
        None => ClipSteps { into: vec![], from: vec![], units: vec![] },
    };
    let actuator = !opts.pre.handling || recs.iter().any(|r| r.meta.all.get("loading").is_some_and(|l| l.trim() == "actuator"));
    let med_tau = {
        let mut t: Vec<f64> = trials.iter().flat_map(|t| t.segs.iter().map(|s| s.tau)).collect();
        super::preprocess::median(&mut t)
    };
    let Selected { cfg: mut cur, score: mut cur_score, x: mut cur_x, hat, mut findings, mut decisions, mut nuisances, round0_exact } =
        select::select(&base_cfg, clean.clone(), xc.clone(), hat, &Ctx { d: &d, trials: &trials, hat: &Hat::default(), clip, clip_steps: &clip_steps, med_tau }, &report);
    let mut spectrum_exact: Option<Exact> = None;
    // honest naming: the other effects that explain each finding's residual about as well
    for (e, alts) in alternatives::alternatives(&cur, &cur_score, &Ctx { d: &d, trials: &trials, hat: &hat, clip, clip_steps: &clip_steps, med_tau }) {
        if let Some(f) = findings.iter_mut().find(|f| f.effect == e.name()) {
            f.alternatives = alts;
            alternatives::apply(f);
        }
    }
    // the relaxation spectrum (issue 15): the exact forms of relaxation (creep, one second time
    // constant) give way to a spectrum over every change when it predicts the held-out data
    // clearly better than the whole model the catalogue found
    if !d.prior {
        spectrum_exact = replace_exact(&d, &trials, &hat, (&mut cur, &mut cur_score, &mut cur_x), &mut findings, &mut decisions, round0_exact.as_ref(), actuator, clip, &report);
    }
    // the second relaxation's τ2 was chosen on a grid (steps of ×1.371): refined between the grid
    // points around it by golden-section search on the training fit (the same rule that chose it),
    // so the final model's slow relaxation is not off by up to half a grid step. Here with the
    // simulator's first-order part; otherwise the final refit does it with the refitted shape.
    if cur.effects.contains(&Effect::SecondTimeConstant) && d.prior {
        if let Some((c, s, x)) = refine_tau2(&d, &trials, &cur, &hat) {
            cur = c;
            cur_score = s;
            cur_x = x;
        }
    }
    // the terms' parameters as in the final model (all terms fitted jointly, levels re-estimated)
    for f in findings.iter_mut() {
        if let Some(&e) = cur.effects.iter().find(|e| e.name() == f.effect) {
            f.term.params = term_params(&d, &cur, &cur_x, e, &hat);
        }
    }
    findings.extend(reported_only(&trials, &cur, &cur_score, clip, &report, (&base, &clean)));
    let remaining = locate(&d, &trials, &cur_x, &cur, &hat);
    let mut evidence: Vec<String> = remaining.iter().map(|w| format!("{} {:.1}–{:.1} s: {}", w.recording, w.start_s, w.end_s, w.statistic)).collect();
    if !remaining.is_empty() {
        if let Some(line) = step_transients(&d, &trials, &cur_x, &cur, &hat, &report.unit) {
            evidence.insert(0, line);
        }
    }
    let unexplained = Unexplained { flag: !remaining.is_empty(), evidence };
    let (cur, cur_x, final_trials, final_base, xb) = refit::final_refit(&d, trials, base_eval, &base_fit, (&base_cfg, &hat0, xb), (cur, cur_x, &hat), &mut findings, refit_always);
    let predictions = refit::predictions(recs, &d, &final_trials, &final_base, (&base_cfg, &hat0, &xb), (&cur, &hat, &cur_x), &findings);
    let by_unit = unit_errors(&final_base, &base, &cur_score);
    let (levels, taus) = if d.prior { (vec![], vec![]) } else { first_order_part(&d, &cur, &cur_x, &final_trials) };
    // the spectrum's finding takes the name its fitted shape gives
    let mut final_names: Vec<&'static str> = cur.effects.iter().filter(|e| **e != Effect::RestRelaxation).map(|e| e.name()).collect();
    // the nuisances' parameters as in the final model
    for n in nuisances.iter_mut().filter(|n| n.name == Effect::RestRelaxation.name()) {
        n.params = term_params(&d, &cur, &cur_x, Effect::RestRelaxation, &hat);
    }
    for f in findings.iter_mut().filter(|f| f.effect == Effect::Relaxation.name()) {
        name_spectrum(f, spectrum_exact.as_ref());
        let own = f.effect;
        f.alternatives.retain(|a| a.effect != own);
        alternatives::apply(f);
        for n in final_names.iter_mut().filter(|n| **n == Effect::Relaxation.name()) {
            *n = f.effect;
        }
    }
    let notes =
        report.steps.iter().filter_map(|s| s.tau_describes_creep.as_ref().map(|why| format!("{:?} step {} ({} → {}): {why}", s.phase, s.index + 1, s.before, s.after))).collect();
    let diagnosis = Diagnosis {
        advice: Vec::new(),
        advice_notes: Vec::new(),
        notes,
        nuisances,
        schema: SCHEMA,
        recordings: recs.iter().map(|r| r.source.clone()).collect(),
        unit: report.unit.clone(),
        baseline: Baseline {
            model: if sim.is_some() {
                "the simulator's first-order prediction for the logged protocol (per-trial offsets fitted)".into()
            } else {
                "first-order step per load change, levels shared across trials (the paper's model, fitted exactly)".into()
            },
            rmse: base.rmse,
            heldout_rmse: base.heldout_rmse,
            bic: base.bic,
            load_ramp: opts.pre.ramp.filter(|r| r.duration_s > 0.0 && sim.is_none()),
        },
        final_: Final {
            effects: final_names,
            rmse: cur_score.rmse,
            heldout_rmse: cur_score.heldout_rmse,
            units_better: by_unit.iter().filter(|u| u.improved_rmse < u.baseline_rmse).count(),
            units_scored: by_unit.len(),
            heldout_by_unit: by_unit,
            levels,
            taus,
        },
        findings,
        unexplained,
        decisions,
        located,
        predictions,
    };
    Some(Outcome::Done(Box::new(diagnosis)))
}

// The advice's data (computed by `sensor::advice`, which reads the diagnosis; kept here so the
// diagnosis names no module downstream of it).

/// One protocol change and the separation it gives.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    pub change: &'static str,
    pub duration_s: f64,
    pub separation_sigma: f64,
    /// RMS of the difference between the two predicted signals, in the response unit.
    pub rms_difference: f64,
}

/// The advice for one ambiguous finding.
#[derive(Debug, Clone, Serialize)]
pub struct Advice {
    /// Index of the finding in `findings`.
    pub finding: usize,
    pub effect: &'static str,
    pub alternative: &'static str,
    /// The advised change (one of the candidates).
    pub change: &'static str,
    pub sentence: String,
    /// The advised protocol, relative to the output folder.
    pub protocol_file: String,
    pub plot: String,
    /// The expected paired z between the two names on the advised protocol and on the recording's own.
    pub separation_sigma: f64,
    pub separation_sigma_now: f64,
    /// The paired z by which the named model predicted the recording's held-out units better than
    /// the alternative (what the recording itself showed).
    pub z_observed: f64,
    /// The held-out RMSE each name is expected to reach on the advised recording when the other
    /// is true (√(σ² + mean squared difference)), against σ when it is the true one.
    pub heldout_rmse_if_right: f64,
    pub heldout_rmse_if_wrong: f64,
    pub candidates: Vec<Candidate>,
    #[serde(skip)]
    pub protocol_toml: String,
    /// Time, load (g), the named and the alternative's predictions on the advised protocol.
    #[serde(skip)]
    pub curves: [Vec<f64>; 4],
}

#[cfg(test)]
mod tests {

    #[test]
    fn local_noise_is_the_white_part_of_a_residual_not_its_slow_misfit() {
        // white noise of sigma 2 (a fixed pseudo-random sequence) on a slow ramp of 40 over the segment
        let mut seed = 12345u64;
        let mut gauss = || {
            let mut u = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()
        };
        let r: Vec<f64> = (0..4000).map(|i| 40.0 * i as f64 / 4000.0 + 2.0 * gauss()).collect();
        let s = super::local_noise(&r);
        assert!((s - 2.0).abs() < 0.15, "{s}");
        // the ramp alone is no noise
        let ramp: Vec<f64> = (0..4000).map(|i| 40.0 * i as f64 / 4000.0).collect();
        assert!(super::local_noise(&ramp) < 1e-9);
    }
    use super::*;

    /// One unit that improves a lot does not veto a term that makes every unit better (issue 15,
    /// item 5): the differences' z falls under MIN_Z, the log ratios' does not; a change that
    /// makes no unit better passes neither way, nor does a consistent change under 3 %.
    #[test]
    fn one_unit_does_not_veto_a_term_that_helps_every_unit() {
        let before: Vec<f64> = (0..30).map(|k| 1.0 + 0.1 * (k % 7) as f64).collect();
        let mut after: Vec<f64> = before.iter().enumerate().map(|(k, b)| b * (0.8 + 0.05 * (k % 3) as f64)).collect();
        let mut b2 = before.clone();
        b2[29] = 40.0;
        after[29] = 1.0;
        assert!(diff_z(&b2, &after) < MIN_Z, "{}", diff_z(&b2, &after));
        assert!(paired_z(&b2, &after) >= MIN_Z, "{}", paired_z(&b2, &after));
        let worse: Vec<f64> = before.iter().map(|b| b * 1.05).collect();
        assert!(paired_z(&before, &worse) < 0.0);
        let tiny: Vec<f64> = before.iter().map(|b| b * 0.99).collect();
        assert_eq!(paired_z(&before, &tiny), diff_z(&before, &tiny));
    }

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
