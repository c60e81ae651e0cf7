//! CSV → recording → preprocessing → step fits (lsq and/or the paper's method) → fashion curves →
//! one report. Diagnosis, tables and plots read the report only.

use super::catalogue::handling_spikes::{self, EdgeStep};
use super::catalogue::saturation;
use super::edges::{self, Bounded, Edge};
use super::fashion::{self, Fashion, Readout};
use super::fit::{self, PaperFit, StepData, StepFit};
use super::preprocess::{self, Phase, Series, SpikeWindow, Step};
use super::recording::{Divider, ProtocolKind, Recording};
use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    Paper,
    Lsq,
    Both,
}

#[derive(Debug, Clone)]
pub struct Options {
    pub pre: preprocess::Options,
    pub method: Method,
    pub paper_grid: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options { pre: preprocess::Options::default(), method: Method::Lsq, paper_grid: 100 }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct RecordingInfo {
    pub source: String,
    pub samples: usize,
    pub sample_rate_hz: f64,
    pub unit: String,
    /// Noise σ of the samples as fitted: after the mean filter when it is on (`filter_block`
    /// samples per point), else of the raw samples.
    pub noise_sigma: f64,
    /// Noise σ of the raw samples, before any filter (what a simulator's σ describes).
    pub noise_sigma_raw: f64,
    /// Samples per fitted point (10 with the paper's filter, else 1).
    pub filter_block: usize,
    pub steps: usize,
    pub spikes: Vec<SpikeWindow>,
    pub notes: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct StepReport {
    pub phase: Phase,
    pub index: usize,
    pub before: f64,
    pub after: f64,
    /// The load W of the paper's Eq. 2, in kg when the protocol is a load or force.
    pub weight: f64,
    pub weight_unit: &'static str,
    /// Pooled lsq fit over all trials.
    pub lsq: Option<StepFit>,
    pub lsq_eq4: Option<f64>,
    /// k divided by the weight, the paper's normalisation (V per kg).
    pub lsq_k_per_weight: Option<f64>,
    /// One lsq fit per trial.
    pub lsq_trials: Vec<StepFit>,
    pub paper: Option<PaperFit>,
    pub trials: usize,
    /// The hold after the step (logged change to the next), s.
    pub hold_s: f64,
    /// Why the fitted τ describes creep rather than a first-order step, when it does.
    pub tau_describes_creep: Option<String>,
    /// Per trial of the pooled fit (in its order): the time of the step's jump when the step is a
    /// jump within one sample ([`fit::jump_time`]), else None.
    pub jumps: Vec<Option<f64>>,
    /// Per trial of the pooled fit (in its order): the step's edge, the jump, the fitted onset or
    /// one bounded to the detected change ([`edges`]).
    pub edges: Vec<Edge>,
    /// The data set's typical τ and onset, when this step's fitted onset lies further back than
    /// the data allow ([`edges`]).
    pub bounded: Option<Bounded>,
}

impl StepReport {
    /// The time of trial `q`'s jump (in the pooled fit's order), when its step is a jump within
    /// one sample.
    pub fn jump(&self, q: usize) -> Option<f64> {
        self.jumps.get(q).copied().flatten()
    }
    /// Trial `q`'s edge (in the pooled fit's order).
    pub fn edge(&self, q: usize) -> Option<Edge> {
        self.edges.get(q).copied()
    }
}

/// A fitted τ of at least this share of the hold describes creep: the step would not settle
/// (within 1 %) before the hold ends.
pub const CREEP_TAU_HOLD_SHARE: f64 = 0.2;

/// Why a step's fitted τ describes creep rather than the first-order part, if it does (a τ
/// determined to better than ±50 %): τ of the order of the hold, or a step that lands within one
/// sample (`jumps`, from [`fit::jump_time`]) while its fitted τ spans many samples.
fn tau_describes_creep(f: &fit::StepFit, hold_s: f64, jumps: &[Option<f64>], dt: f64) -> Option<String> {
    // a τ the data do not determine (a step small against the noise) describes nothing
    if f.se_tau_s.is_nan() || f.se_tau_s >= 0.5 * f.tau_s {
        return None;
    }
    if f.tau_s >= CREEP_TAU_HOLD_SHARE * hold_s {
        return Some(format!(
            "τ = {:.3} s is of the order of the hold ({:.1} s): the step does not settle within it, so the fitted τ describes the slow creep under the load, not a first-order response",
            f.tau_s, hold_s
        ));
    }
    (jumps.iter().any(Option::is_some) && f.tau_s > JUMP_SPAN_SAMPLES * dt).then(|| {
        format!(
            "the response jumps within one sample, where a first-order step of τ = {:.3} s would take {:.0} samples: the fit's τ describes the slow creep after the jump",
            f.tau_s,
            f.tau_s / dt
        )
    })
}

/// A fitted τ longer than this many sample intervals after a jump describes what follows it.
const JUMP_SPAN_SAMPLES: f64 = 10.0;

#[derive(Debug, Clone, Serialize)]
pub struct Report {
    pub schema: &'static str,
    pub unit: String,
    pub protocol: &'static str,
    pub recordings: Vec<RecordingInfo>,
    pub steps: Vec<StepReport>,
    pub fashion: Option<Fashion>,
    pub notes: Vec<String>,
}

/// Everything the fits were made from, kept for plots and diagnosis.
pub struct Prepared {
    pub series: Vec<Series>,
    pub steps: Vec<Vec<Step>>,
    pub groups: Vec<StepData>,
}

pub fn readout(rec: &Recording) -> Option<Readout> {
    match (rec.unit, rec.meta.vcc_v, rec.meta.r_m_ohm, rec.meta.divider) {
        ("V", Some(vcc_v), Some(r_m_ohm), Some(Divider::SensorHigh)) => Some(Readout::DividerHigh { vcc_v, r_m_ohm }),
        ("V", Some(vcc_v), Some(r_m_ohm), Some(Divider::SensorLow)) => Some(Readout::DividerLow { vcc_v, r_m_ohm }),
        ("ohm", ..) => Some(Readout::Ohm),
        _ => None,
    }
}

/// Preprocesses every recording and groups the steps across trials by (phase, index).
pub fn prepare(recs: &[Recording], opts: &Options) -> (Prepared, Vec<RecordingInfo>) {
    prepare_with(recs, opts, &vec![Vec::new(); recs.len()])
}

/// The samples one filtered sample averages for this recording: the paper's block mean is a
/// 10-sample mean at 100 Hz; at other rates the filter stays off (1).
pub fn filter_block(rec: &Recording, opts: &Options) -> usize {
    if opts.pre.mean_filter && (rec.sample_rate_hz() - 100.0).abs() <= 5.0 {
        opts.pre.block.max(1)
    } else {
        1
    }
}

/// As [`prepare`], with further spike windows per recording excluded.
fn prepare_with(recs: &[Recording], opts: &Options, extra: &[Vec<SpikeWindow>]) -> (Prepared, Vec<RecordingInfo>) {
    let mut infos = Vec::new();
    let mut series = Vec::new();
    let mut steps_all = Vec::new();
    for (ri, r) in recs.iter().enumerate() {
        let mut o = opts.pre.clone();
        // the paper's filter is a 10-sample block mean at 100 Hz; at other rates it stays off
        if (r.sample_rate_hz() - 100.0).abs() > 5.0 {
            o.mean_filter = false;
        }
        let (s, spikes) = preprocess::prepare_with(r, &o, &extra[ri]);
        let (steps, mut notes) = preprocess::segment(r, &o);
        if let Some(raw) = &r.raw {
            notes.push(format!(
                "{} samples at {:.1} Hz block-averaged {} to one ({:.1} Hz) before fitting: the model's time constants are far slower",
                raw.samples,
                raw.sample_rate_hz,
                raw.block,
                r.sample_rate_hz()
            ));
        }
        if !o.mean_filter && opts.pre.mean_filter {
            notes.push(format!("mean filter off: the recording is at {:.2} Hz, not 100 Hz", r.sample_rate_hz()));
        }
        infos.push(RecordingInfo {
            source: r.source.clone(),
            samples: r.len(),
            sample_rate_hz: r.sample_rate_hz(),
            unit: r.unit.to_string(),
            noise_sigma: s.sigma,
            noise_sigma_raw: r.raw.as_ref().map(|x| x.noise_sigma).unwrap_or_else(|| preprocess::noise_sigma(&r.response)),
            filter_block: if o.mean_filter { o.block.max(1) } else { 1 },
            steps: steps.len(),
            spikes,
            notes,
        });
        series.push(s);
        steps_all.push(steps);
    }
    let mut keys: Vec<(Phase, usize)> = steps_all.iter().flatten().map(|s| (s.phase, s.index)).collect();
    keys.sort_by_key(|k| (k.0 == Phase::Unloading, k.1));
    keys.dedup();
    let mut groups = Vec::new();
    for key in keys {
        let mut trials = Vec::new();
        let mut step0 = None;
        for (ri, steps) in steps_all.iter().enumerate() {
            if let Some(st) = steps.iter().find(|s| (s.phase, s.index) == key) {
                if let Some(tr) = fit::trial_window(&series[ri], st, &recs[ri].source, opts.pre.ramp) {
                    trials.push(tr);
                    step0.get_or_insert_with(|| st.clone());
                }
            }
        }
        if let Some(step) = step0 {
            groups.push(StepData { step, trials });
        }
    }
    (Prepared { series, steps: steps_all, groups }, infos)
}

fn weight_of(kind: ProtocolKind, s: &Step) -> (f64, &'static str) {
    let w = match s.phase {
        Phase::Loading => s.after,
        Phase::Unloading => s.before,
    };
    match kind.grams(w) {
        Some(g) => (g / 1000.0, "kg"),
        None => ((s.after - s.before).abs(), "input"),
    }
}

/// Handling spikes at the steps' edges, from the fitted steps (a second look after part 1's
/// running-median detector): per recording, the windows not already excluded.
fn edge_spikes(recs: &[Recording], opts: &Options, prep: &Prepared, steps: &[StepReport], infos: &[RecordingInfo]) -> Vec<Vec<SpikeWindow>> {
    // the recordings placed by hand, each with its steps' edges and noise
    let series: Vec<(usize, handling_spikes::EdgeSeries)> = recs
        .iter()
        .enumerate()
        .filter(|(_, rec)| preprocess::by_hand(rec, &opts.pre))
        .map(|(ri, rec)| {
            let own = &prep.steps[ri];
            // the read-out's map, inverted: a level to u = 1 + Rm·G (a divider) or G (a resistance)
            let ro = readout(rec);
            let to_u = |v: f64| ro.and_then(|r| r.divider_u(v));
            let through = handling_spikes::read_out_course(&rec.time_s, &rec.response, own, to_u);
            let edges: Vec<EdgeStep> = own
                .iter()
                .enumerate()
                .filter_map(|(k, st)| {
                    let report_of = |o: &Step| steps.iter().find(|s| s.phase == o.phase && s.index == o.index);
                    let sr = report_of(st)?;
                    let f = sr.lsq.as_ref()?;
                    let q = f.trials.iter().position(|tp| tp.recording == rec.source)?;
                    // the step's edge (`edges`): a jump's is the jump (the fitted curve's, slower,
                    // would take the samples after it for spikes); a fitted onset further back
                    // than the data allow is bounded to the detected change
                    let Edge { t0_s: t0, tau_s: tau, .. } = sr.edge(q)?;
                    let from = (st.t_log - preprocess::HANDLING_WINDOW_S).max(if k > 0 { own[k - 1].t_log + 0.5 * (st.t_log - own[k - 1].t_log) } else { f64::NEG_INFINITY });
                    let to = (st.t_log + preprocess::HANDLING_WINDOW_S).min(st.t_end);
                    // the level the step leaves: the step before it, or for the first the one that
                    // ends at its load
                    let left = if k > 0 { Some(&own[k - 1]) } else { own.iter().rev().find(|o| (o.after - st.before).abs() < 1e-9) };
                    let tau_before_s = left.and_then(report_of).and_then(|s| s.lsq.as_ref()).map(|f| f.tau_s);
                    Some(EdgeStep { t0_s: t0, tau_s: tau, from_s: from, to_s: to, through: through[k], tau_before_s })
                })
                .collect();
            let ceiling = saturation::ceiling(&rec.response);
            // the noise of the samples off the ceiling (clipped samples have none and would lower it)
            let sigma = match ceiling {
                Some(c) => preprocess::noise_sigma(&rec.response.iter().copied().filter(|&v| v < c).collect::<Vec<_>>()),
                None => preprocess::noise_sigma(&rec.response),
            };
            // a step that reaches a clip is not first order at its edge: not searched
            let edges: Vec<EdgeStep> = match saturation::clip_level(&[&rec.response], sigma).or(ceiling) {
                Some(clip) => edges.into_iter().filter(|e| !rec.time_s.iter().zip(&rec.response).any(|(&t, &v)| t >= e.from_s && t <= e.to_s && v >= clip - 2.0 * sigma)).collect(),
                None => edges,
            };
            (ri, handling_spikes::EdgeSeries { t: &rec.time_s, v: &rec.response, steps: edges, sigma })
        })
        .collect();
    let (idx, ser): (Vec<usize>, Vec<handling_spikes::EdgeSeries>) = series.into_iter().unzip();
    let mut out = vec![Vec::new(); recs.len()];
    for (ri, found) in idx.into_iter().zip(handling_spikes::detect_all(&ser, opts.pre.max_spike_s)) {
        let known = &infos[ri].spikes;
        out[ri] = found.into_iter().filter(|w| !known.iter().any(|k| k.start_s <= w.end_s && w.start_s <= k.end_s)).collect();
    }
    out
}

pub fn analyze(recs: &[Recording], opts: &Options) -> (Report, Prepared) {
    let (prep, infos) = prepare(recs, opts);
    let steps = fit_steps(recs, opts, &prep);
    let extra = if opts.method != Method::Paper { edge_spikes(recs, opts, &prep, &steps, &infos) } else { vec![Vec::new(); recs.len()] };
    let (prep, infos, steps) = if extra.iter().any(|e| !e.is_empty()) {
        let (p, i) = prepare_with(recs, opts, &extra);
        let s = fit_steps(recs, opts, &p);
        (p, i, s)
    } else {
        (prep, infos, steps)
    };
    finish_report(recs, opts, prep, infos, steps)
}

fn fit_steps(recs: &[Recording], opts: &Options, prep: &Prepared) -> Vec<StepReport> {
    let kind = recs.first().map(|r| r.protocol_kind).unwrap_or(ProtocolKind::Input);
    let mut steps = Vec::new();
    for g in &prep.groups {
        let (weight, weight_unit) = weight_of(kind, &g.step);
        let lsq = if opts.method != Method::Paper { fit::varpro(g) } else { None };
        let lsq_eq4 = lsq.as_ref().map(|f| fit::eq4(g, |i, t| f.model(i, t)));
        let lsq_trials = if opts.method != Method::Paper {
            g.trials.iter().filter_map(|tr| fit::varpro(&StepData { step: g.step.clone(), trials: vec![tr.clone()] })).collect()
        } else {
            vec![]
        };
        let paper = if opts.method != Method::Lsq { fit::paper(g, weight.max(1e-12), opts.paper_grid) } else { None };
        let hold_s = g.step.t_end - g.step.t_log;
        // a load that ramps in is no jump, whatever the fitted onset (it stands inside the ramp)
        let ramped = opts.pre.ramp.is_some_and(|r| r.duration_s > 0.0);
        let jumps: Vec<Option<f64>> = match &lsq {
            Some(_) if ramped => vec![None; g.trials.len()],
            Some(f) => g.trials.iter().zip(&f.trials).map(|(tr, tp)| fit::jump_time(tr, tp, f)).collect(),
            None => vec![],
        };
        let dt = g.trials.iter().filter_map(fit::sample_interval).fold(f64::INFINITY, f64::min);
        let creep = lsq.as_ref().and_then(|f| tau_describes_creep(f, hold_s, &jumps, dt));
        steps.push(StepReport {
            jumps,
            edges: Vec::new(),
            bounded: None,
            hold_s,
            tau_describes_creep: creep,
            phase: g.step.phase,
            index: g.step.index,
            before: g.step.before,
            after: g.step.after,
            weight,
            weight_unit,
            lsq_k_per_weight: lsq.as_ref().map(|f| f.k / weight.max(1e-12)),
            lsq,
            lsq_eq4,
            lsq_trials,
            paper,
            trials: g.trials.len(),
        });
    }
    edges::set(&mut steps, recs, opts.pre.ramp);
    steps
}

fn finish_report(recs: &[Recording], opts: &Options, prep: Prepared, infos: Vec<RecordingInfo>, steps: Vec<StepReport>) -> (Report, Prepared) {
    let kind = recs.first().map(|r| r.protocol_kind).unwrap_or(ProtocolKind::Input);
    // the paper method's τ where it is only a bound (its Eq. 3 optimum on the c grid's edge)
    let mut notes: Vec<String> =
        steps.iter().flat_map(|s| s.paper.iter().flat_map(move |p| p.edge_notes.iter().map(move |n| format!("paper method, {:?} step {}: {n}", s.phase, s.index + 1)))).collect();
    let fashion = match recs.first().and_then(readout) {
        Some(ro) if opts.method != Method::Paper => {
            let mut levels = Vec::new();
            let mut taus = Vec::new();
            for s in steps.iter().filter(|s| s.phase == Phase::Loading) {
                if let Some(f) = &s.lsq {
                    let v0 = f.trials.iter().map(|t| t.v0).sum::<f64>() / f.trials.len() as f64;
                    if s.index == 0 {
                        levels.push((s.before, v0));
                    }
                    levels.push((s.after, v0 + f.k));
                    taus.push((s.after, f.tau_s));
                }
            }
            let mut distinct: Vec<f64> = levels.iter().map(|l| l.0).collect();
            distinct.sort_by(|a, b| a.partial_cmp(b).unwrap());
            distinct.dedup();
            if distinct.len() < 3 {
                notes.push(format!("fashion curves need at least three load levels; the protocol has {}", distinct.len()));
                None
            } else {
                fashion::fit(ro, &levels, &taus)
            }
        }
        Some(_) => {
            notes.push("fashion curves are fitted to the lsq levels: run with --method lsq or --method both to get them".into());
            None
        }
        None => {
            notes.push("fashion curves need the divider metadata (vcc_v, r_m_ohm, divider) or a resistance recording".into());
            None
        }
    };
    let report =
        Report { schema: "tipforge.fit/1", unit: recs.first().map(|r| r.unit.to_string()).unwrap_or_default(), protocol: kind.column(), recordings: infos, steps, fashion, notes };
    (report, prep)
}

/// The table in the layout of the paper's Tables 1–2 (weight, k, τ, error), for one method.
pub fn table(report: &Report, paper: bool) -> (String, String) {
    let mut csv = String::from("phase,step,load_before,load_after,weight,k,tau_s,eq4_error\n");
    let mut md = format!(
        "| phase | step | load | weight ({w}) | k ({u} per {w}) | τ (s) | Eq. 4 error ({u}) |\n|---|---|---|---|---|---|---|\n",
        w = report.steps.first().map(|s| s.weight_unit).unwrap_or("kg"),
        u = report.unit
    );
    for s in &report.steps {
        let row = if paper {
            s.paper.as_ref().map(|p| (p.k, p.tau_s, p.eq4))
        } else {
            s.lsq.as_ref().map(|f| (s.lsq_k_per_weight.unwrap_or(f64::NAN), f.tau_s, s.lsq_eq4.unwrap_or(f64::NAN)))
        };
        if let Some((k, tau, e)) = row {
            let ph = if s.phase == Phase::Loading { "loading" } else { "unloading" };
            csv += &format!("{ph},{},{},{},{},{:.6},{:.6},{:.6}\n", s.index, s.before, s.after, s.weight, k, tau, e);
            md += &format!("| {ph} | {} | {} → {} | {} | {:.4} | {:.4} | {:.4} |\n", s.index + 1, s.before, s.after, s.weight, k, tau, e);
        }
    }
    (csv, md)
}
