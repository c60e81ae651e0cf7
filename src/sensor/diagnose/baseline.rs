//! The baseline: the paper's model (a first-order step per load change, levels shared by the
//! trials) built from part 1's per-step fits, or the simulator's prediction, and scored held out.

use super::*;

pub(super) fn trials_from(report: &Report, prep: &Prepared, recs: &[Recording], opts: &Options) -> Vec<Trial> {
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
                tau = crate::sensor::fit::JUMP_TAU_SHARE / rec.sample_rate_hz();
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

/// The simulator as the baseline: its sensor model and the preload (g) on top of the logged loads.
pub struct SimBaseline<'a> {
    pub sensor: &'a crate::params::sensor::SensorParams,
    pub preload_g: f64,
}

/// A preload correction is named when it lowers the simulator baseline's held-out RMSE by this.
pub const MIN_PRELOAD_GAIN: f64 = 0.10;

/// The simulator baseline's score at the given preload, and the preload (g) that fits the
/// recordings best with its score: a coarse grid over 0 to max(200 g, 4 × given, the largest
/// load), then golden section around the best point (on the fit RMSE; held-out decides above).
pub(super) fn preload_search(recs: &[Recording], opts: &Options, sb: &SimBaseline) -> Option<(Score, f64, Score)> {
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
