//! The model the diagnosis fits: each trial's steps (`Seg`, `Trial`), a model configuration
//! (`Config`: which terms, their shape parameters), the levels the terms are built on (`Hat`) and
//! the design row that makes every configuration linear given its shape (`Design::row`, `predict`).

use super::*;

/// One step of one trial.
#[derive(Debug, Clone)]
pub(super) struct Seg {
    /// Index of the step's (phase, index) across trials: τ corrections are shared per step.
    pub(super) key: usize,
    pub(super) t0: f64,
    pub(super) load: f64,
    pub(super) prev: f64,
    pub(super) tau: f64,
    pub(super) phase: Phase,
    /// When the change was logged (the load's ramp is placed relative to it).
    pub(super) t_log: f64,
    /// The load as applied: at once, or over a ramp ending at t0 (an actuator's travel).
    pub(super) input: LoadIn,
    /// With a simulator baseline: the simulated step (ΔV, τ).
    pub(super) sim: Option<(f64, f64)>,
}

/// One trial's data as the model sees it.
#[derive(Debug, Clone)]
pub(super) struct Trial {
    pub(super) name: String,
    pub(super) t: Vec<f64>,
    pub(super) v: Vec<f64>,
    pub(super) segs: Vec<Seg>,
    pub(super) sigma: f64,
    /// With a simulator baseline: its level before the first step.
    pub(super) prior0: Option<f64>,
    /// How far below a clip the filtered series is bent by the clipped raw noise.
    pub(super) clip_margin: f64,
    /// Half the span of raw samples one filtered sample averages (0 without the filter): the
    /// first-order part is modelled as that average, exact at a step's onset and its curved start.
    pub(super) half_span_s: f64,
    /// The series as given, handling spikes included (the baseline, the paper's model, is fitted
    /// to it).
    pub(super) given_t: Vec<f64>,
    pub(super) given_v: Vec<f64>,
    /// How the response maps to the sensor's conductance (the recording's read-out metadata).
    pub(super) readout: Option<crate::sensor::fashion::Readout>,
}

impl Trial {
    /// Where segment `s` ends: the next segment's onset (s), or never after the last one.
    pub(super) fn seg_end(&self, s: usize) -> f64 {
        self.segs.get(s + 1).map_or(f64::INFINITY, |g| g.t0)
    }
    /// From its first sample to its last (s).
    pub(super) fn span_s(&self) -> f64 {
        self.t.last().copied().unwrap_or(0.0) - self.t.first().copied().unwrap_or(0.0)
    }
    /// The simulator's prediction (0 without a simulator baseline).
    pub(super) fn prior(&self, t: f64) -> f64 {
        let Some(p0) = self.prior0 else { return 0.0 };
        p0 + self.segs.iter().filter(|s| t >= s.t0).filter_map(|s| s.sim.map(|(dv, tau)| dv * (1.0 - catalogue::decay((t - s.t0) / tau)))).sum::<f64>()
    }
}

/// A model configuration: which terms, and their shape parameters.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Config {
    /// Linearised τ corrections per step (free time constants, first order in Δln τ).
    pub(super) tau_free: bool,
    pub(super) effects: Vec<Effect>,
    pub(super) tau2: f64,
    /// What drives the second relaxation (its sign with the change, or the change's size).
    pub(super) drive: Drive,
    pub(super) clip: Option<f64>,
    /// With a clip: the time constant and onset of each step the clip shapes, as
    /// ((trial, segment), τ, onset). The clipped shape biases those steps' own first-order fits.
    pub(super) tau_fixed: Vec<FixedStep>,
    /// With a clip: the (trial, segment) steps that fall from a clipped load. The signal leaves the
    /// clip on a first-order fall from the clip itself (their part-1 fits are of that fall), so they
    /// restart at the clip: v = L_next·u + clip·(1 − u).
    pub(super) restart: Vec<(usize, usize)>,
    /// With an amplifier's rail: the spans (trial, from, to; s) where the model sits on it, from
    /// where the fitted model reaches it to where the next step leaves it (`terms::settle_rail_spans`;
    /// settled once, when the clip is proposed). Only these
    /// samples are left out of the fit: min(model, rail) is flat in the model there (the
    /// Gauss–Newton step of the clip), and elsewhere the samples are the model ± a noise the
    /// rail did not cut (`usable`).
    pub(super) rail_spans: Vec<(usize, f64, f64)>,
    /// With the relaxation spectrum: its grid, the load's ramp and the smoothness penalty.
    pub(super) relax: Option<Relax>,
    /// A gain per trial (every trial; a faint ridge leaves their common factor with the levels):
    /// the trials' step sizes differ by a factor (the sensor's temperature, the hand), a nuisance,
    /// not physics of the sensor.
    pub(super) gains: bool,
    /// A relaxation per trial from its first sample, with this time constant: what the sample
    /// brings from before the recording (how long it rested), a nuisance like the gains.
    pub(super) rest_tau: Option<f64>,
    /// Baseline drift as an exponential warm-up with this time constant from each trial's start
    /// (shared by the trials, as the rate is); None: linear (the warm-up's limit of long τ).
    pub(super) drift_tau: Option<f64>,
    /// The clip is an amplifier's rail before the noise (its plateau is the rail ± the noise).
    pub(super) clip_rail: bool,
    /// Hysteresis whose peak memory fades toward the present level with this time (s); None: the
    /// peak is remembered for good.
    pub(super) hyst_memory_s: Option<f64>,
    /// The hysteresis acts in the sensor's conductance and is seen through the read-out
    /// (`TrialSteps::hysteresis_through_column`); false: in the response.
    pub(super) hyst_through: bool,
    /// The creep term's form.
    pub(super) creep: CreepForm,
}

/// The creep term's form.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) enum CreepForm {
    /// Log-time creep of the response restarting at every step (the previous step's relaxing away).
    #[default]
    Restarting,
    /// Superposed over the load history: every change's own log-time creep keeps going.
    Superposed,
    /// Superposed, of the sensor's conductance, seen through the read-out: each change drives it
    /// by its change of the read-out's u (linear in the conductance), and it shows scaled by the
    /// read-out's slope at the current level (a divider's top compresses a creep its bottom shows
    /// in full). Only with the recordings' read-out known. `at`: the per-decade fraction at which
    /// it is taken exactly (its column is then the response's change at that size, per unit of
    /// it; iterated to the fitted fraction); None: linearised at the first-order response.
    Through { at: Option<f64> },
}

impl CreepForm {
    /// Whether every change's own creep keeps going (superposed, through the read-out or not).
    pub(super) fn superposed(self) -> bool {
        self != CreepForm::Restarting
    }
    pub(super) fn through(self) -> bool {
        matches!(self, CreepForm::Through { .. })
    }
    /// The size at which the conductance's creep is taken exactly, when it is.
    pub(super) fn exact_at(self) -> Option<f64> {
        match self {
            CreepForm::Through { at } => at,
            _ => None,
        }
    }
}

/// What drives the relaxation spectrum's kernels: the load as the spectrum applies it, a ramp of
/// `ramp_s` ending `end_s` after each logged change (0, 0: at the log), or each step's own ramp as
/// the baseline applies it (an actuator's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum KernelDrive {
    Ramp { ramp_s: f64, end_s: f64 },
    StepsOwn,
}

/// The relaxation spectrum's shape: kernels on a log grid of τ, driven by the load as applied
/// (`drive`), amplitudes penalised by `lambda` (relative to the block's mean column energy; None:
/// chosen by inner cross-validation wherever the model is solved).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Relax {
    pub(super) taus: Vec<f64>,
    pub(super) drive: KernelDrive,
    pub(super) lambda: Option<f64>,
    /// With the steps' own first-order decay among the columns ([`OWN_TAU_COLS`]).
    pub(super) own_tau: bool,
    /// One set of amplitudes for loading and unloading changes alike (linear viscoelasticity: the
    /// recovery mirrors the creep); the unloading set's columns stay empty.
    pub(super) shared: bool,
    /// One more kernel set per trial, from its first sample: the relaxation the sample brings
    /// from before the recording (how long it rested differs between trials).
    pub(super) trials: usize,
}

impl Relax {
    /// Kernel sets: after loading, after unloading, then one per trial's start.
    pub(super) fn sets(&self) -> usize {
        2 + self.trials
    }
    pub(super) fn cols(&self) -> usize {
        self.sets() * self.taus.len() + if self.own_tau { OWN_TAU_COLS } else { 0 }
    }
}

/// The time from each step's onset to the next one's, over every trial (s).
pub(super) fn step_spacings_s(trials: &[Trial]) -> Vec<f64> {
    trials.iter().flat_map(|t| t.segs.windows(2).map(|w| w[1].t0 - w[0].t0)).collect()
}

/// The median of the steps' part-1 time constants (the second relaxation's grid is relative to it).
pub(super) fn median_tau(trials: &[Trial]) -> f64 {
    let mut t: Vec<f64> = trials.iter().flat_map(|t| t.segs.iter().map(|s| s.tau)).collect();
    crate::sensor::preprocess::median(&mut t)
}

/// The scale of a second relaxation's τ2 grid (`terms::TAU2_GRID` times it): the steps' median
/// part-1 τ; but when that is under one sample interval (the steps land within a sample: their τ
/// is a jump's nominal one and says nothing of what the samples can resolve after it), at least
/// the median hold over [`TAU2_HOLD_SHARE`], so that the grid reaches an eighth of a hold. (On an
/// FSR402-like 10 Hz step of 10 min the grid was 0.01–0.13 s, and a 5 % second relaxation of 30 s
/// gained 1 % in its best place; the relaxation spectrum took its residual and was named creep.)
pub(super) fn tau2_scale(trials: &[Trial]) -> f64 {
    let tau = median_tau(trials);
    let mut dt: Vec<f64> = trials.iter().map(sample_interval).filter(|x| x.is_finite()).collect();
    let mut holds = step_spacings_s(trials);
    if dt.is_empty() || holds.is_empty() || tau >= crate::sensor::preprocess::median(&mut dt) {
        return tau;
    }
    tau.max(crate::sensor::preprocess::median(&mut holds) / TAU2_HOLD_SHARE)
}

/// See [`tau2_scale`].
pub(super) const TAU2_HOLD_SHARE: f64 = 200.0;

/// A step whose time constant and onset are set, not taken from its own part-1 fit.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct FixedStep {
    /// (trial, segment)
    pub(super) at: (usize, usize),
    pub(super) tau_s: f64,
    pub(super) t0_s: f64,
}

impl Config {
    /// The paper's model: first-order steps with free time constants, no term.
    pub(super) fn first_order() -> Config {
        Config {
            tau_free: true,
            effects: vec![],
            tau2: 1.0,
            drive: Drive::Change,
            clip: None,
            tau_fixed: vec![],
            rail_spans: vec![],
            restart: vec![],
            relax: None,
            gains: false,
            rest_tau: None,
            drift_tau: None,
            clip_rail: false,
            hyst_memory_s: None,
            hyst_through: false,
            creep: CreepForm::Restarting,
        }
    }
    pub(super) fn fixed(&self, i: usize, s: usize) -> Option<&FixedStep> {
        self.tau_fixed.iter().find(|x| x.at == (i, s))
    }
    pub(super) fn tau_of(&self, i: usize, s: usize, sg: &Seg) -> f64 {
        self.fixed(i, s).map(|x| x.tau_s).unwrap_or(sg.tau)
    }
    pub(super) fn t0_of(&self, i: usize, s: usize, sg: &Seg) -> f64 {
        self.fixed(i, s).map(|x| x.t0_s).unwrap_or(sg.t0)
    }
}

/// Baseline quantities the terms are built from (two-stage: fixed from the baseline fit).
#[derive(Debug, Clone, Default)]
pub(super) struct Hat {
    pub(super) loads: Vec<f64>,
    /// Per load, relative to the reference (zero) load's, which is 0.
    pub(super) level: Vec<f64>,
    /// Per trial, its response at the reference load (its offset; empty when the levels are
    /// absolute, as the simulator's are).
    pub(super) offset: Vec<f64>,
}

impl Hat {
    pub(super) fn level_of(&self, l: f64) -> f64 {
        self.loads.iter().position(|&x| x == l).map(|i| self.level[i]).unwrap_or(0.0)
    }
    /// Trial `i`'s response at load `l`, its offset included: what a read-out's conversion to the
    /// sensor's conductance needs (a preload keeps the response off zero at "zero" weight).
    pub(super) fn response_of(&self, i: usize, l: f64) -> f64 {
        self.offset.get(i).copied().unwrap_or(0.0) + self.level_of(l)
    }
    /// The level at any load between the recording's: linear between the two nearest loads
    /// (the end's level beyond them).
    pub(super) fn level_at(&self, l: f64) -> f64 {
        let (mut below, mut above) = (None::<(f64, f64)>, None::<(f64, f64)>);
        for (&x, &y) in self.loads.iter().zip(&self.level) {
            if x <= l && below.is_none_or(|b| x > b.0) {
                below = Some((x, y));
            }
            if x >= l && above.is_none_or(|a| x < a.0) {
                above = Some((x, y));
            }
        }
        match (below, above) {
            (Some(b), Some(a)) if a.0 > b.0 => b.1 + (a.1 - b.1) * (l - b.0) / (a.0 - b.0),
            (Some(b), _) => b.1,
            (_, Some(a)) => a.1,
            _ => 0.0,
        }
    }
    pub(super) fn max_level(&self) -> f64 {
        self.loads.iter().zip(&self.level).max_by(|a, b| a.0.partial_cmp(b.0).unwrap()).map(|x| *x.1).unwrap_or(0.0)
    }
}

#[derive(Clone)]
pub(super) struct Design {
    pub(super) loads: Vec<f64>,
    pub(super) n_trials: usize,
    pub(super) n_keys: usize,
    /// The (trial, segment) steps whose onset is refitted (a handling spike was cut from their
    /// edge, taking the samples that fixed it in part 1), each with its column among them.
    pub(super) refit_onset: Vec<(usize, usize)>,
    /// The simulator gives the first-order part: no level or τ columns.
    pub(super) prior: bool,
    /// The shape columns (Δ ln τ, onset shifts) as the exact derivatives of the filtered-sample
    /// model (the final refit's Gauss–Newton); otherwise of the point value (selection: its rules
    /// were set with those columns).
    pub(super) exact_shape: bool,
}

impl Design {
    /// The levels per load in a solution `x` (the reference load's at 0): what the terms are built
    /// on once the model with them has re-estimated the levels (two-stage).
    pub(super) fn levels_in(&self, x: &[f64]) -> Hat {
        let mut level = vec![0.0];
        level.extend(x[self.n_trials..self.n_levels()].iter().copied());
        Hat { loads: self.loads.clone(), level, offset: x[..self.n_trials].to_vec() }
    }
    pub(super) fn n_levels(&self) -> usize {
        self.n_trials + if self.prior { 0 } else { self.loads.len().saturating_sub(1) }
    }
    /// Columns of the first-order shape corrections (τ per step, onsets of the steps cut by spikes).
    pub(super) fn n_shape(&self, cfg: &Config) -> usize {
        if cfg.tau_free && !self.prior {
            self.n_keys + self.refit_onset.len()
        } else {
            0
        }
    }
    pub(super) fn ncols(&self, cfg: &Config) -> usize {
        self.n_levels() + self.n_shape(cfg) + cfg.effects.iter().map(|e| effect_cols(*e, cfg)).sum::<usize>() + self.n_gains(cfg) + self.n_rests(cfg)
    }
    /// First column of the per-trial gains.
    pub(super) fn gain_col(&self, cfg: &Config) -> usize {
        self.ncols(cfg) - self.n_gains(cfg) - self.n_rests(cfg)
    }
    /// First column of the per-trial rest relaxations (the last columns of a row).
    pub(super) fn rest_col(&self, cfg: &Config) -> usize {
        self.ncols(cfg) - self.n_rests(cfg)
    }
    pub(super) fn n_rests(&self, cfg: &Config) -> usize {
        if cfg.rest_tau.is_some() && !self.prior && self.n_trials >= 2 {
            self.n_trials
        } else {
            0
        }
    }
    /// Columns of the per-trial gains: from [`Design::gain_col`], just before the rests'.
    pub(super) fn n_gains(&self, cfg: &Config) -> usize {
        if cfg.gains && !self.prior && self.n_trials >= 2 {
            GAIN_COLS * self.n_trials
        } else {
            0
        }
    }
    /// The design row of trial `i` at time t.
    pub(super) fn row(&self, i: usize, tr: &Trial, t: f64, cfg: &Config, hat: &Hat, out: &mut Vec<f64>) {
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
                Effect::Creep if cfg.creep.through() => out[col] = cur.map(|s| steps.creep_through_column(s, t)).unwrap_or(0.0),
                Effect::Creep if cfg.creep.superposed() => out[col] = cur.map(|s| catalogue::creep::superposed_column(&steps, s, t)).unwrap_or(0.0),
                Effect::Creep => out[col] = cur.map(|s| catalogue::creep::column(&steps, s, t)).unwrap_or(0.0),
                Effect::Hysteresis if cfg.hyst_through => out[col] = cur.map(|s| steps.hysteresis_through_column(s, t)).unwrap_or(0.0),
                Effect::Hysteresis => {
                    out[col] = cur
                        .map(|s| match cfg.hyst_memory_s {
                            Some(m) => {
                                let load = |q: usize| tr.segs[q].load;
                                catalogue::hysteresis::fading_column(&steps, (s, t), m, (tr.segs[0].prev, load), |l| hat.level_at(l) - steps.l0)
                            }
                            None => catalogue::hysteresis::column(&steps, s, t),
                        })
                        .unwrap_or(0.0)
                }
                Effect::SecondTimeConstant if cfg.drive == Drive::Through => out[col] = cur.map(|s| steps.second_through_column(landed, s, t)).unwrap_or(0.0),
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
            out[self.rest_col(cfg) + i] = catalogue::decay(catalogue::since(t, tr.t[0]) / tau);
        }
    }
}

/// Columns of one trial's gain: the change of level, and of its square (over the top level).
pub(super) const GAIN_COLS: usize = 2;

/// Columns after the kernel sets: the steps' own first-order decay after loading and after
/// unloading (the share of each change the spectrum takes from the first-order part).
pub(super) const OWN_TAU_COLS: usize = 2;

/// The relaxation spectrum's columns: every change of the trial drives the kernels of its kind
/// (loading: the first half, unloading: the second) by its change of level.
pub(super) fn relax_columns(i: usize, tr: &Trial, steps: &TrialSteps, t: f64, rx: &Relax, out: &mut [f64]) {
    let k = rx.taus.len();
    if let (Some(&t_start), true) = (tr.t.first(), i < rx.trials) {
        for (j, &tau) in rx.taus.iter().enumerate() {
            out[(2 + i) * k + j] = catalogue::relaxation::kernel(t, t_start, 0.0, tau);
        }
    }
    for (q, sg) in tr.segs.iter().enumerate() {
        // the load as the baseline applies it (an actuator's ramps), else the spectrum's own ramp
        let ramped = rx.drive == KernelDrive::StepsOwn && sg.input.ramp_s > 0.0;
        let (end, ramp_s) = match rx.drive {
            _ if ramped => (sg.t0, sg.input.ramp_s),
            KernelDrive::Ramp { ramp_s, end_s } => (sg.t_log + end_s, ramp_s),
            KernelDrive::StepsOwn => (sg.t_log, 0.0),
        };
        if t <= end - ramp_s {
            break;
        }
        let dv = steps.dv(q);
        let set = if steps.unloading(q) && !rx.shared { k } else { 0 };
        let own = rx.sets() * k + usize::from(steps.unloading(q));
        let since = t - steps.t0(q);
        // the input's course at t, for every kernel of a ramped step
        let w = if sg.input.ramp_s > 0.0 { course_at(t, sg.t0, sg.input) } else { 0.0 };
        if rx.own_tau {
            // the steps' own first-order decay, of the load as the baseline applies it
            if sg.input.ramp_s > 0.0 {
                out[own] += dv * ramp_kernel(t, steps.t0(q), steps.tau(q), sg.input, w);
            } else if since >= 0.0 {
                out[own] += dv * (-since / steps.tau(q)).exp();
            }
        }
        for (j, &tau) in rx.taus.iter().enumerate() {
            out[set + j] += dv * if ramped { ramp_kernel(t, end, tau, sg.input, w) } else { catalogue::relaxation::kernel(t, end, ramp_s, tau) };
        }
    }
}

impl TrialSteps<'_> {
    /// The first-order part's response at `t` (the trial's offset included), step `cur` the
    /// latest begun: where a read-out's slope is taken.
    fn first_order_at(&self, cur: usize, t: f64) -> f64 {
        let segs = &self.tr.segs;
        let h = self.tr.half_span_s;
        self.hat.response_of(self.i, segs[0].prev) + (0..=cur).map(|q| self.dv(q) * rise(t, self.t0(q), self.tau(q), h, segs[q].input)).sum::<f64>()
    }
    /// A hysteresis of the sensor's conductance seen through the read-out: the gap in the
    /// read-out's u (linear in the conductance) between the remembered peak's level and the
    /// present load's, times the read-out's slope dV/du at the first-order part's response at `t`
    /// (the peak's memory as the model has it; 0 without a read-out: the form is offered only
    /// when every trial has one).
    pub(super) fn hysteresis_through_column(&self, cur: usize, t: f64) -> f64 {
        let Some(ro) = self.tr.readout else { return 0.0 };
        let segs = &self.tr.segs;
        let first = self.first_order_at(cur, t);
        let off = self.hat.offset.get(self.i).copied().unwrap_or(0.0);
        // a level the read-out cannot convert (at or past its end) leaves the step out, as `du` does
        let u_at = |l: f64| ro.divider_u(off + self.hat.level_at(l)).unwrap_or(f64::NAN);
        let load = |q: usize| segs[q].load;
        let gap_u = catalogue::hysteresis::fading_column(self, (cur, t), self.cfg.hyst_memory_s.unwrap_or(f64::INFINITY), (segs[0].prev, load), u_at);
        if gap_u.is_finite() {
            ro.slope_du(first) * gap_u
        } else {
            0.0
        }
    }
    /// A second relaxation of the sensor's conductance seen through the read-out: every landed
    /// step's change of u, a share of it relaxing at τ2 instead of at the step's own τ (as
    /// `Drive::Change` does in the response), times the read-out's slope dV/du at the first-order
    /// part's response at `t` (0 without a read-out: the form is offered only when every trial has
    /// one).
    pub(super) fn second_through_column(&self, landed: &[usize], cur: usize, t: f64) -> f64 {
        let Some(ro) = self.tr.readout else { return 0.0 };
        let tau2 = self.cfg.tau2;
        let in_u: f64 = landed.iter().map(|&q| self.du(q).unwrap_or(0.0) * catalogue::second_time_constant::split(catalogue::since(t, self.t0(q)), self.tau(q), tau2)).sum();
        ro.slope_du(self.first_order_at(cur, t)) * in_u
    }
    /// The step's change of the read-out's u (linear in the sensor's conductance), when the
    /// recording says how its response maps to it.
    pub(super) fn du(&self, q: usize) -> Option<f64> {
        let sg = &self.tr.segs[q];
        let ro = self.tr.readout?;
        Some(ro.divider_u(self.hat.response_of(self.i, sg.load))? - ro.divider_u(self.hat.response_of(self.i, sg.prev))?)
    }

    /// The superposed creep of the conductance seen through the read-out, at `t` with step `cur`
    /// the latest begun: the read-out's slope dV/du at the first-order part's response at `t` times
    /// every change's own log-time creep in u (`catalogue::creep::superposed_column` with u for the
    /// level). Without the read-out, the superposed creep of the response.
    pub(super) fn creep_through_column(&self, cur: usize, t: f64) -> f64 {
        let Some(ro) = self.tr.readout else { return catalogue::creep::superposed_column(self, cur, t) };
        // the slope where the sensor is (within a step's rise too: the slope at the held level
        // alone misfits a true creep of this form by 4 % RMS on family A, at the first-order level
        // by 0.05 %)
        let first = self.first_order_at(cur, t);
        let clock = |q: usize| (1.0 + catalogue::since(t, self.t0(q)) / catalogue::creep::TIME_S).log10();
        let creep_u = (0..=cur).map(|q| self.du(q).unwrap_or(0.0) * clock(q)).sum::<f64>();
        // exactly at the fraction given (a large creep spans much of the read-out's curve)
        let exact = self.cfg.creep.exact_at().filter(|c| c.abs() > 1e-12).and_then(|c| {
            let u0 = ro.divider_u(first)?;
            Some((ro.response_of_u(u0 + c * creep_u)? - ro.response_of_u(u0)?) / c)
        });
        exact.unwrap_or_else(|| ro.slope_du(first) * creep_u)
    }
}

/// One trial's steps as the catalogue's terms see them.
pub(super) struct TrialSteps<'a> {
    pub(super) i: usize,
    pub(super) tr: &'a Trial,
    pub(super) cfg: &'a Config,
    pub(super) hat: &'a Hat,
    pub(super) l0: f64,
    pub(super) top: f64,
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
pub(super) fn effect_cols(e: Effect, cfg: &Config) -> usize {
    match e {
        Effect::Saturation | Effect::HandlingSpikes | Effect::RestRelaxation => 0,
        Effect::SecondTimeConstant => cfg.drive.columns(),
        Effect::Relaxation => cfg.relax.as_ref().map(|r| r.cols()).unwrap_or(0),
        _ => 1,
    }
}

/// The constant part of the steps that restart at the clip: clip·(1 − u) each.
pub(super) fn clip_offset(i: usize, tr: &Trial, t: f64, cfg: &Config) -> f64 {
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

/// Whether sample `j` of trial `i` is fitted. With a clip of the ADC's (after the noise) only
/// below it by the raw noise's margin: a clipped sample says only that the model reaches the clip,
/// and the clipped raw samples bend a filtered mean near it. With an amplifier's rail (before the
/// noise) nothing is cut after it: every sample but those where the model sits on the rail
/// ([`Config::rail_spans`]). (With the ADC's rule at a rail, the samples of its plateau below it by
/// the margin are the noise's low side, and under 15 mV of noise a rise into it had almost no other
/// sample left: the top level came out at the one below and the clip's model lost 174 % held out.)
pub(super) fn usable(i: usize, tr: &Trial, j: usize, cfg: &Config) -> bool {
    match cfg.clip {
        Some(_) if cfg.clip_rail => !cfg.rail_spans.iter().any(|&(k, a, b)| k == i && tr.t[j] >= a && tr.t[j] < b),
        Some(c) => tr.v[j] < c - tr.clip_margin.max(0.5 * tr.sigma).max(1e-12),
        None => true,
    }
}

/// The least weight of a load's level column in the model at the end of a rail span for
/// [`raise_to_rail`] to raise it there.
const SETTLED_SHARE: f64 = 0.5;

/// A load held on an amplifier's rail has its level at or above the rail (a censored observation):
/// its samples on the rail are left out of the fit (`Config::rail_spans`), so only the short rise
/// into the rail sets the level, and under the noise a fit to the training trials alone can put it
/// below the rail. The model then predicts a held-out trial's plateau under the rail its data sit
/// on (family A, B's forms at 1σ, 40 g steps, tuning seed 42 860: 0.508 V for a plateau at the
/// rail's 0.541 V, the trial's rise unit 10× worse than without the rail). The level of a load
/// whose every hold in the trials `in_fold` ends on the rail ([`censored_everywhere`]) is raised,
/// where needed, so that the model without the clip reaches the rail at the end of each of them
/// (where the level's column carries at least [`SETTLED_SHARE`] of the model: a fall restarting at
/// the rail is not its level's). `in_fold` names the trials wholly in the fold's fit: a fold that
/// leaves out a step or a block of a single recording raises nothing (its held-out hold must not
/// set the level). The raised solution is no longer the fit's least squares; the fit's other
/// paths (the training BIC, the spans' settling, the shape refit) do not raise.
pub(super) fn raise_to_rail(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat, x: &mut [f64], in_fold: &dyn Fn(usize) -> bool) {
    let (Some(rail), true) = (cfg.clip, cfg.clip_rail) else { return };
    let mut need: std::collections::BTreeMap<usize, f64> = Default::default();
    let mut buf = Vec::new();
    for &(k, from, to) in cfg.rail_spans.iter().filter(|s| in_fold(s.0)) {
        let tr = &trials[k];
        // the span's last sample (the times are sorted)
        let Some(j) = tr.t.partition_point(|&t| t < to).checked_sub(1).filter(|&j| tr.t[j] >= from) else { continue };
        let Some(sg) = tr.segs.iter().rev().find(|g| g.t0 <= tr.t[j]) else { continue };
        let Some(col) = d.loads.iter().position(|&l| l == sg.load).filter(|&c| c > 0).map(|c| d.n_trials + c - 1) else { continue };
        if col >= d.n_levels() {
            continue;
        }
        let v = unclipped(d, k, tr, tr.t[j], x, cfg, hat, &mut buf);
        // only where the level is the model's (a hold settled toward it), not a fall from the rail
        // restarting at it (its level's column there is the fall's small share so far)
        if v < rail && buf[col] >= SETTLED_SHARE && censored_everywhere(trials, cfg, sg.load, in_fold) {
            let e = need.entry(col).or_insert(0.0);
            *e = e.max((rail - v) / buf[col]);
        }
    }
    for (col, up) in need {
        x[col] += up;
    }
}

/// Whether every hold at `load` of the trials `in_fold` ends on the rail (inside one of
/// `cfg.rail_spans`): then no hold pins that load's level, and the rail bounds it from below. A
/// hold that ends below the rail in one trial pins the level shared by all (one trial's higher
/// gain may put its hold on the rail while the others' stay under it; family A, seed 42 800: the
/// 160 g level raised to one trial's rail lost 18 points of held-out gain).
fn censored_everywhere(trials: &[Trial], cfg: &Config, load: f64, in_fold: &dyn Fn(usize) -> bool) -> bool {
    trials.iter().enumerate().filter(|(k, _)| in_fold(*k)).all(|(k, tr)| {
        let last = tr.t.last().copied().unwrap_or(0.0);
        tr.segs.iter().enumerate().filter(|(_, sg)| sg.load == load).all(|(s, _)| {
            let end = if s + 1 < tr.segs.len() { tr.seg_end(s) } else { last };
            cfg.rail_spans.iter().any(|&(i, from, to)| i == k && from < end && to >= end.min(last) - 1e-9)
        })
    })
}

/// The model's value at `t` in trial `i` before any clip (the design row left in `buf`).
pub(super) fn unclipped(d: &Design, i: usize, tr: &Trial, t: f64, x: &[f64], cfg: &Config, hat: &Hat, buf: &mut Vec<f64>) -> f64 {
    d.row(i, tr, t, cfg, hat, buf);
    buf.iter().zip(x).map(|(a, b)| a * b).sum::<f64>() + tr.prior(t) + clip_offset(i, tr, t, cfg)
}

pub(super) fn predict(d: &Design, i: usize, tr: &Trial, t: f64, x: &[f64], cfg: &Config, hat: &Hat, buf: &mut Vec<f64>) -> f64 {
    let v = unclipped(d, i, tr, t, x, cfg, hat, buf);
    match cfg.clip {
        Some(c) => v.min(c),
        None => v,
    }
}

pub(super) fn all_rows(trials: &[Trial]) -> Vec<(usize, usize)> {
    trials.iter().enumerate().flat_map(|(i, tr)| (0..tr.t.len()).map(move |j| (i, j))).collect()
}

/// Index of a term's first column in the design.
pub(super) fn term_col(d: &Design, cfg: &Config, e: Effect) -> usize {
    d.n_levels() + d.n_shape(cfg) + cfg.effects.iter().take_while(|x| **x != e).map(|x| effect_cols(*x, cfg)).sum::<usize>()
}

/// A sample beside a jump (a step faster than one sample): where within the sample interval the
/// load landed is unknown, so the samples from one interval before its onset to one and a half
/// after are not scored held out.
pub(super) fn at_jump(tr: &Trial, t: f64) -> bool {
    let dt = sample_interval(tr);
    tr.segs.iter().any(|s| s.tau < dt && t >= s.t0 - dt && t <= s.t0 + 1.5 * dt)
}

/// A step faster than one sample (its τ set by [`crate::sensor::fit::JUMP_TAU_SHARE`]).
pub(super) fn is_jump(tr: &Trial, sg: &Seg) -> bool {
    sg.tau < sample_interval(tr)
}

pub(super) fn sample_interval(tr: &Trial) -> f64 {
    let n = tr.t.len();
    if n < 2 {
        return f64::INFINITY;
    }
    (tr.t[n - 1] - tr.t[0]) / (n - 1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A load held on the rail in every trial has its level raised to the rail where a fit left
    /// it under ([`raise_to_rail`]); a load whose hold ends on the rail in one trial only keeps the
    /// level the other trials' holds pin; and a trial outside the fold counts for nothing, either
    /// way: the top load held on the rail in trials 1 and 2 only is raised in their fold and not in
    /// the fold with trial 0, whose top hold ends under the rail.
    #[test]
    fn a_level_every_trial_holds_on_the_rail_is_raised_to_it_and_no_other() {
        let b = fixture::built(&fixture::recs(7000, |s| (s.effects.saturation_v, s.effects.saturation_before_noise) = (1.55, true)));
        let (d, trials) = (&b.d, &b.trials);
        let mut cfg = b.base_cfg.clone();
        (cfg.clip, cfg.clip_rail) = (Some(1.55), true);
        let span = |k: usize, load: f64, nth: usize| {
            let tr = &trials[k];
            let s = tr.segs.iter().enumerate().filter(|(_, g)| g.load == load).map(|(s, _)| s).nth(nth).expect("a hold at that load");
            (k, tr.segs[s].t0 + 1.0, tr.segs.get(s + 1).map_or(tr.t[tr.t.len() - 1] + 1.0, |g| g.t0))
        };
        // the top load's one hold in every trial, and the 800 g unloading hold in trial 0 only
        cfg.rail_spans = (0..3).map(|k| span(k, 1000.0, 0)).chain([span(0, 800.0, 1)]).collect();
        let mut x = solve(d, trials, &all_rows(trials), &cfg, &b.hat).expect("a fit");
        let col = |load: f64| d.n_trials + d.loads.iter().position(|&l| l == load).unwrap() - 1;
        let (top, mid) = (col(1000.0), col(800.0));
        x[top] -= 0.2;
        x[mid] -= 0.2;
        let (low_top, low_mid) = (x[top], x[mid]);
        let mut buf = Vec::new();
        let unclipped = |x: &[f64], c: &Config, (k, _, to): (usize, f64, f64), buf: &mut Vec<f64>| {
            let tr = &trials[k];
            let j = (0..tr.t.len()).rev().find(|&j| tr.t[j] < to).unwrap();
            unclipped(d, k, tr, tr.t[j], x, c, &b.hat, buf)
        };
        let before = x.clone();
        raise_to_rail(d, trials, &cfg, &b.hat, &mut x, &|_| true);
        assert!(x[top] > low_top && x[mid] == low_mid, "top {low_top} -> {}, 800 g {low_mid} -> {}", x[top], x[mid]);
        let least = (0..3).map(|k| unclipped(&x, &cfg, cfg.rail_spans[k], &mut buf)).fold(f64::INFINITY, f64::min);
        assert!((least - 1.55).abs() < 1e-9, "the lowest trial reaches the rail: {least}");
        // the top held on the rail in trials 1 and 2 only: trial 0's hold pins it when in the fold
        let mut two = cfg.clone();
        two.rail_spans = (1..3).map(|k| span(k, 1000.0, 0)).collect();
        let (mut with_0, mut without_0) = (before.clone(), before.clone());
        raise_to_rail(d, trials, &two, &b.hat, &mut with_0, &|_| true);
        raise_to_rail(d, trials, &two, &b.hat, &mut without_0, &|k| k > 0);
        assert!(with_0[top] == low_top, "trial 0's top hold under the rail pins the level: {}", with_0[top]);
        assert!(without_0[top] > low_top && (1..3).all(|k| unclipped(&without_0, &two, two.rail_spans[k - 1], &mut buf) >= 1.55 - 1e-9));
    }

    #[test]
    fn the_level_between_loads_is_interpolated() {
        let hat = Hat { loads: vec![400.0, 0.0, 200.0], level: vec![1.0, 0.0, 0.8], offset: vec![] };
        for (l, want) in [(0.0, 0.0), (100.0, 0.4), (200.0, 0.8), (300.0, 0.9), (400.0, 1.0), (500.0, 1.0), (-10.0, 0.0)] {
            assert!((hat.level_at(l) - want).abs() < 1e-12, "{l}: {}", hat.level_at(l));
        }
    }

    fn seg(key: usize, t0: f64, prev: f64, load: f64, tau: f64) -> Seg {
        Seg { key, t0, load, prev, tau, phase: Phase::Loading, t_log: t0, input: LoadIn::default(), sim: None }
    }

    fn trial(h: f64) -> Trial {
        let t: Vec<f64> = (0..400).map(|j| 0.05 * j as f64).collect();
        let v = vec![0.0; t.len()];
        let segs = vec![seg(0, 3.0, 0.0, 1.0, 0.8), seg(1, 9.0, 1.0, 2.0, 1.5)];
        Trial { name: "hand-made".into(), given_t: t.clone(), given_v: v.clone(), t, v, segs, sigma: 1e-3, prior0: None, clip_margin: 0.0, half_span_s: h, readout: None }
    }

    /// The conductance's creep through a divider (sensor high, 3.3 V): the read-out's slope dV/du at
    /// the first-order response times every change's own log-time creep in u = Vcc/(Vcc − V), by
    /// hand; compressed at the top (the slope falls with the level); without a read-out, the
    /// superposed creep of the response.
    #[test]
    fn the_conductance_creep_is_seen_through_the_readout() {
        let vcc = 3.3;
        let tr = Trial { readout: Some(crate::sensor::fashion::Readout::DividerHigh { vcc_v: vcc, r_m_ohm: 1000.0 }), ..trial(0.0) };
        let hat = Hat { loads: vec![0.0, 1.0, 2.0], level: vec![0.0, 1.0, 1.6], offset: vec![] };
        let cfg = Config { creep: CreepForm::Through { at: None }, ..Config::first_order() };
        let steps = TrialSteps { i: 0, tr: &tr, cfg: &cfg, hat: &hat, l0: 0.0, top: 1.6 };
        let u = |v: f64| vcc / (vcc - v);
        let rise = |t: f64, t0: f64, tau: f64| if t >= t0 { 1.0 - (-(t - t0) / tau).exp() } else { 0.0 };
        let log = |t: f64, t0: f64| (1.0 + (t - t0)).log10();
        for &t in &[4.0, 8.5, 9.5, 19.0] {
            let cur = usize::from(t >= 9.0);
            let first = 1.0 * rise(t, 3.0, 0.8) + 0.6 * rise(t, 9.0, 1.5);
            let mut creep = (u(1.0) - u(0.0)) * log(t, 3.0);
            if cur == 1 {
                creep += (u(1.6) - u(1.0)) * log(t, 9.0);
            }
            let want = (vcc - first).powi(2) / vcc * creep;
            let got = steps.creep_through_column(cur, t);
            assert!((got - want).abs() < 1e-12 * want.abs().max(1.0), "t {t}: {got} vs {want}");
        }
        // per unit of u the top shows less than the bottom (a divider compresses its top)
        let per_u = |cur: usize, t: f64| steps.creep_through_column(cur, t) / (0..=cur).map(|q| steps.du(q).unwrap() * log(t, steps.t0(q))).sum::<f64>();
        assert!(per_u(1, 19.0) < 0.6 * per_u(0, 8.5), "{} {}", per_u(1, 19.0), per_u(0, 8.5));
        // a trial whose response sits at 0.4 V at zero weight (a preload): its offset is part of
        // the level the read-out converts (the levels are relative to it), so the column is the
        // same as with the absolute levels and no offset
        let pre = Hat { offset: vec![0.4], ..hat.clone() };
        let abs = Hat { level: vec![0.4, 1.4, 2.0], ..hat.clone() };
        let (with_offset, absolute) = (TrialSteps { hat: &pre, ..steps }, TrialSteps { hat: &abs, ..steps });
        for &t in &[4.0, 8.5, 19.0] {
            let cur = usize::from(t >= 9.0);
            let (a, b) = (with_offset.creep_through_column(cur, t), absolute.creep_through_column(cur, t));
            assert!((a - b).abs() < 1e-12, "t {t}: {a} vs {b}");
        }
        // left out, the offset would overstate the creep at the top (by 16 % at t 19 here)
        let (a, wrong) = (with_offset.creep_through_column(1, 19.0), steps.creep_through_column(1, 19.0));
        assert!(wrong > 1.1 * a, "{wrong} vs {a}");
        let plain = Trial { readout: None, ..tr.clone() };
        let steps = TrialSteps { tr: &plain, ..steps };
        assert_eq!(steps.creep_through_column(1, 19.0), catalogue::creep::superposed_column(&steps, 1, 19.0));
    }

    /// A hysteresis of the conductance through a divider (sensor high, 3.3 V): nothing while the
    /// load rises; on the unloading step, the read-out's slope dV/du at the first-order response
    /// times the gap in u = Vcc/(Vcc − V) between the peak's level and the present load's, reached
    /// with the step's own time constant; a preloaded trial's offset is part of the level.
    #[test]
    fn a_conductance_hysteresis_is_seen_through_the_readout() {
        let vcc = 3.3;
        let mut tr = Trial { readout: Some(crate::sensor::fashion::Readout::DividerHigh { vcc_v: vcc, r_m_ohm: 1000.0 }), ..trial(0.0) };
        tr.segs.push(Seg { phase: Phase::Unloading, ..seg(2, 14.0, 2.0, 1.0, 1.0) });
        let cfg = Config { effects: vec![Effect::Hysteresis], hyst_through: true, ..Config::first_order() };
        let u = |v: f64| vcc / (vcc - v);
        let rise = |t: f64, t0: f64, tau: f64| if t >= t0 { 1.0 - (-(t - t0) / tau).exp() } else { 0.0 };
        for off in [0.0, 0.4] {
            let hat = Hat { loads: vec![0.0, 1.0, 2.0], level: vec![0.0, 1.0, 1.6], offset: vec![off] };
            let steps = TrialSteps { i: 0, tr: &tr, cfg: &cfg, hat: &hat, l0: 0.0, top: 1.6 };
            for &(t, cur) in &[(4.0, 0), (10.0, 1), (14.5, 2), (19.0, 2)] {
                let first = off + 1.0 * rise(t, 3.0, 0.8) + 0.6 * rise(t, 9.0, 1.5) - 0.6 * rise(t, 14.0, 1.0);
                let gap = if cur == 2 { (u(off + 1.6) - u(off + 1.0)) * rise(t, 14.0, 1.0) } else { 0.0 };
                let want = (vcc - first).powi(2) / vcc * gap;
                let got = steps.hysteresis_through_column(cur, t);
                assert!((got - want).abs() < 1e-12, "offset {off}, t {t}: {got} vs {want}");
            }
            assert!(steps.hysteresis_through_column(2, 19.0) > 0.1, "offset {off}");
        }
    }

    /// A second relaxation of the conductance through a divider (sensor high, 3.3 V): the read-out's
    /// slope dV/du at the first-order response times every landed change's u, its share split
    /// between the step's own τ and τ2, by hand; larger per unit of u near no load than at the top
    /// (a divider compresses its top).
    #[test]
    fn a_conductance_second_relaxation_is_seen_through_the_readout() {
        let vcc = 3.3;
        let tr = Trial { readout: Some(crate::sensor::fashion::Readout::DividerHigh { vcc_v: vcc, r_m_ohm: 1000.0 }), ..trial(0.0) };
        let cfg = Config { effects: vec![Effect::SecondTimeConstant], drive: Drive::Through, tau2: 20.0, ..Config::first_order() };
        let hat = Hat { loads: vec![0.0, 1.0, 2.0], level: vec![0.0, 1.0, 1.6], offset: vec![] };
        let steps = TrialSteps { i: 0, tr: &tr, cfg: &cfg, hat: &hat, l0: 0.0, top: 1.6 };
        let u = |v: f64| vcc / (vcc - v);
        let rise = |t: f64, t0: f64, tau: f64| if t >= t0 { 1.0 - (-(t - t0) / tau).exp() } else { 0.0 };
        let split = |t: f64, t0: f64, tau: f64| if t >= t0 { (-(t - t0) / tau).exp() - (-(t - t0) / 20.0).exp() } else { 0.0 };
        for &t in &[4.0, 8.5, 9.5, 19.0] {
            let cur = usize::from(t >= 9.0);
            let landed: Vec<usize> = (0..=cur).collect();
            let first = 1.0 * rise(t, 3.0, 0.8) + 0.6 * rise(t, 9.0, 1.5);
            let in_u = (u(1.0) - u(0.0)) * split(t, 3.0, 0.8) + (u(1.6) - u(1.0)) * split(t, 9.0, 1.5);
            let want = (vcc - first).powi(2) / vcc * in_u;
            let got = steps.second_through_column(&landed, cur, t);
            assert!((got - want).abs() < 1e-12 * want.abs().max(1.0), "t {t}: {got} vs {want}");
            assert!(got < 0.0, "t {t}: the slow share lags the step ({got})");
        }
        // per unit of u the top shows less than the bottom
        let per_u = |cur: usize, t: f64| {
            let landed: Vec<usize> = (0..=cur).collect();
            steps.second_through_column(&landed, cur, t) / landed.iter().map(|&q| steps.du(q).unwrap() * split(t, steps.t0(q), steps.tau(q))).sum::<f64>()
        };
        assert!(per_u(1, 19.0) < 0.6 * per_u(0, 8.5), "{} {}", per_u(1, 19.0), per_u(0, 8.5));
        // without a read-out, nothing (the form is offered only with one)
        let plain = Trial { readout: None, ..tr.clone() };
        assert_eq!(TrialSteps { tr: &plain, ..steps }.second_through_column(&[0, 1], 1, 19.0), 0.0);
    }

    /// The design row makes the model the superposition of first-order steps: with the offset and
    /// the levels as coefficients, `predict` is o + L1·u1 + (L2 − L1)·u2, and with a filtered
    /// sample's span the average of that over the span.
    #[test]
    fn the_design_row_is_the_superposition_of_first_order_steps() {
        let d = Design { loads: vec![0.0, 1.0, 2.0], n_trials: 1, n_keys: 2, refit_onset: vec![], prior: false, exact_shape: false };
        let cfg = Config::first_order();
        let (o, l1, l2) = (0.1, 0.7, 1.1);
        let mut x = vec![0.0; d.ncols(&cfg)];
        (x[0], x[1], x[2]) = (o, l1, l2);
        let point = |t: f64| {
            let u = |t0: f64, tau: f64| if t >= t0 { 1.0 - (-(t - t0) / tau).exp() } else { 0.0 };
            o + l1 * u(3.0, 0.8) + (l2 - l1) * u(9.0, 1.5)
        };
        let mut buf = Vec::new();
        let tr = trial(0.0);
        for &t in &[0.0, 3.0, 3.4, 8.99, 9.0, 10.0, 19.0] {
            let v = predict(&d, 0, &tr, t, &x, &cfg, &Hat::default(), &mut buf);
            assert!((v - point(t)).abs() < 1e-12, "t {t}: {v} vs {}", point(t));
        }
        let h = 0.05;
        let tr = trial(h);
        for &t in &[2.97, 3.02, 3.3, 9.04, 12.0] {
            let avg = (0..=2000).map(|q| point(t - h + 2.0 * h * q as f64 / 2000.0)).sum::<f64>() / 2001.0;
            let v = predict(&d, 0, &tr, t, &x, &cfg, &Hat::default(), &mut buf);
            assert!((v - avg).abs() < 1e-4, "t {t}: {v} vs {avg}");
        }
    }
}
