//! Preprocessing: handling-spike detection, the paper's 10-sample mean filter, and step
//! segmentation from the protocol column into loading (Part 1) and unloading (Part 2) steps.

use super::recording::Recording;
use serde::Serialize;

/// A sampled series after preprocessing; `ok[i]` is false where a handling spike was excluded.
#[derive(Debug, Clone)]
pub struct Series {
    pub t: Vec<f64>,
    pub v: Vec<f64>,
    pub protocol: Vec<f64>,
    pub ok: Vec<bool>,
    /// Robust noise estimate of the series (same unit as v).
    pub sigma: f64,
    /// The series as given: the same filter over every sample, handling spikes included (what the
    /// paper's method fits).
    pub given_t: Vec<f64>,
    pub given_v: Vec<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    Loading,
    Unloading,
}

/// One protocol step: the level changes from `before` to `after` at `t_log` (when it was logged).
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    pub phase: Phase,
    /// 0-based index of the step within its phase.
    pub index: usize,
    pub t_log: f64,
    /// End of the step's hold: the next logged change, or the end of the recording.
    pub t_end: f64,
    pub before: f64,
    pub after: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct SpikeWindow {
    pub start_s: f64,
    pub end_s: f64,
    /// Largest deviation from the running median, in the response unit.
    pub peak: f64,
}

/// Handling spikes are looked for this close to a logged step (s).
pub const HANDLING_WINDOW_S: f64 = 3.0;

#[derive(Debug, Clone)]
pub struct Options {
    /// Apply the paper's block mean of `block` samples (the paper: 10 at 100 Hz → 10 Hz).
    pub mean_filter: bool,
    pub block: usize,
    /// Protocol changes that revert within this time are logging glitches, not steps.
    pub min_step_s: f64,
    /// Spike threshold in robust standard deviations.
    pub spike_sigma: f64,
    /// Deviations longer than this are not handling spikes.
    pub max_spike_s: f64,
    /// Loads placed by hand (true, the paper's method): short excursions near a step are handling
    /// spikes and are excluded. False for loads applied by a machine (`--actuator`, or a recording
    /// whose metadata says `loading=actuator`): there is nothing to exclude.
    pub handling: bool,
    /// The load as an actuator applies it: a ramp of this duration (s) ending this long (s) after
    /// each logged change, shared by the data set (`diagnose` chooses it by cross-validation).
    /// None: the load changes at once, around an onset fitted near the logged change.
    pub ramp: Option<Ramp>,
}

/// A load ramp: its duration and where it ends relative to the logged change (s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ramp {
    pub duration_s: f64,
    pub end_after_log_s: f64,
    /// The load's course over the ramp: an S-curve (3x² − 2x³: the speed rises and falls
    /// smoothly), or a constant speed (false).
    pub smooth: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options { mean_filter: true, block: 10, min_step_s: 1.0, spike_sigma: 8.0, max_spike_s: 1.0, handling: true, ramp: None }
    }
}

/// The median, by selection (linear time; the slice is reordered).
pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let n = v.len();
    let (lower, mid, _) = v.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b));
    let mid = *mid;
    if n % 2 == 1 {
        mid
    } else {
        0.5 * (lower.iter().copied().fold(f64::NEG_INFINITY, f64::max) + mid)
    }
}

/// The most samples a robust statistic (median interval, noise σ) is computed from.
pub const MAX_STAT_SAMPLES: usize = 1 << 20;

/// Robust noise sigma from first differences: 1.4826 · MAD(diff) / √2.
pub fn noise_sigma(v: &[f64]) -> f64 {
    // at most ~MAX_STAT_SAMPLES differences, evenly strided (a robust σ from 10^6 differences is
    // as good as from 10^7, and a long recording's memory is not doubled for it)
    let stride = v.len().div_ceil(MAX_STAT_SAMPLES).max(1);
    diff_sigma(v.windows(2).step_by(stride).map(|w| w[1] - w[0]).collect())
}

/// The noise σ behind first differences `d` of a series: 1.4826 · MAD(d) / √2 (the MAD on an ADC's
/// grid when the differences sit on one).
pub fn diff_sigma(mut d: Vec<f64>) -> f64 {
    let m = median(&mut d);
    for x in d.iter_mut() {
        *x = (*x - m).abs();
    }
    1.4826 * quantised_median(&mut d) / std::f64::consts::SQRT_2
}

/// The median of non-negative values that may sit on a coarse grid (an ADC's steps): when the
/// grid step is over 0.4 × the plain median, the median of the values spread evenly over their
/// grid cells (the plain median of values of one or two steps is off by up to half the noise: on
/// a 10-bit, 10 Hz recording with σ = 2 steps it read σ/2); else the plain median.
fn quantised_median(a: &mut [f64]) -> f64 {
    let plain = median(a);
    a.sort_by(|x, y| x.total_cmp(y));
    // the grid step: the smallest gap between values that is not a rounding of one value
    let q = a.windows(2).map(|w| w[1] - w[0]).filter(|g| *g > 0.05 * plain).fold(f64::INFINITY, f64::min);
    if !q.is_finite() || q <= 0.4 * plain || a.is_empty() {
        return plain;
    }
    // each value spread over [v − q/2, v + q/2] (the zero cell over [0, q/2]): the point where
    // half the mass lies below
    let half = 0.5 * a.len() as f64;
    let mut below = 0.0;
    let mut i = 0;
    while i < a.len() {
        let v = a[i];
        let mut j = i;
        while j < a.len() && (a[j] - v).abs() <= 0.25 * q {
            j += 1;
        }
        let count = (j - i) as f64;
        if below + count >= half {
            let (lo, width) = if v < 0.5 * q { (0.0, 0.5 * q) } else { (v - 0.5 * q, q) };
            return lo + width * (half - below) / count;
        }
        below += count;
        i = j;
    }
    plain
}

/// The span (s) over which the spike detector measures the local noise.
pub const LOCAL_NOISE_S: f64 = 5.0;

/// Handling spikes: short excursions from a running median (edge-preserving, so monotone steps
/// and relaxations are not flagged). Returns windows and a per-sample mask (true = keep).
pub fn spikes(t: &[f64], v: &[f64], opts: &Options) -> (Vec<SpikeWindow>, Vec<bool>) {
    let n = v.len();
    if n < 8 {
        return (Vec::new(), vec![true; n]);
    }
    let dt = (t[n - 1] - t[0]) / (n - 1) as f64;
    // windows in samples, never wider than the series (a time column in femtoseconds must not
    // ask for a buffer of 10^300 samples)
    let samples = |s: f64| ((s / dt).round().min(n as f64) as usize).max(1);
    let half = samples(0.25).max(2);
    // before the residuals are allocated: a long recording's peak memory is the sum
    let diff_sigma = noise_sigma(v);
    // residuals in single precision (compared with a threshold of several σ; half the memory of
    // a long recording)
    let mut resid = vec![0.0f32; n];
    let mut buf = Vec::with_capacity(2 * half + 1);
    for i in 0..n {
        buf.clear();
        let h = half.min(i).min(n - 1 - i); // centred window, narrowed at the ends
        buf.extend_from_slice(&v[i - h..=i + h]);
        resid[i] = (v[i] - median(&mut buf)) as f32;
    }
    let mad = {
        let mut a: Vec<f32> = resid.iter().map(|r| r.abs()).collect();
        let k = a.len() / 2;
        let (lo, mid, _) = a.select_nth_unstable_by(k, |x, y| x.total_cmp(y));
        if n % 2 == 1 {
            *mid as f64
        } else {
            0.5 * (lo.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64 + *mid as f64)
        }
    };
    let sigma = (1.4826 * mad).max(diff_sigma).max(1e-12);
    // the noise where a sample is: a resistance read without its divider has a noise that grows
    // with the resistance (tens of times larger unloaded than loaded), and one threshold for the
    // whole recording would take the unloaded noise for spikes. Robust σ of the residuals per
    // block of LOCAL_NOISE_S, the largest of a block and its neighbours (a step may sit at a
    // block's edge), never below the recording's own σ
    let block = samples(LOCAL_NOISE_S).max(16);
    let local: Vec<f32> = resid
        .chunks(block)
        .map(|c| {
            let mut a: Vec<f32> = c.iter().map(|r| r.abs()).collect();
            let k = a.len() / 2;
            1.4826 * *a.select_nth_unstable_by(k, |x, y| x.total_cmp(y)).1
        })
        .collect();
    let thr_at = |i: usize| -> f32 {
        let b = i / block;
        let near = local[b.saturating_sub(1)].max(local[b]).max(local[(b + 1).min(local.len() - 1)]);
        (opts.spike_sigma as f32) * near.max(sigma as f32)
    };
    let mut mask = vec![true; n];
    let mut windows = Vec::new();
    let mut i = 0;
    while i < n {
        let thr = thr_at(i);
        if resid[i].abs() <= thr {
            i += 1;
            continue;
        }
        let mut j = i;
        let mut peak: f64 = 0.0;
        let mut quiet = 0usize;
        let gap = samples(0.1);
        while j < n && quiet <= gap {
            if resid[j].abs() > thr {
                quiet = 0;
                peak = if f64::from(resid[j].abs()) > peak.abs() { f64::from(resid[j]) } else { peak };
            } else {
                quiet += 1;
            }
            j += 1;
        }
        let end = j - quiet;
        let (s, e) = (t[i], t[(end).min(n - 1)]);
        if e - s <= opts.max_spike_s {
            let pad = samples(0.05);
            for k in i.saturating_sub(pad)..(end + pad).min(n) {
                mask[k] = false;
            }
            windows.push(SpikeWindow { start_s: t[i.saturating_sub(pad)], end_s: t[(end + pad).min(n - 1)], peak });
        }
        i = j;
    }
    (windows, mask)
}

/// Spike removal, then the block mean filter (a block holding a spike sample is kept only from its
/// clean samples; a block with none is dropped). Weights are handled when they are placed or
/// removed, so spikes are only looked for within `HANDLING_WINDOW_S` of a logged step.
pub fn prepare(rec: &Recording, opts: &Options) -> (Series, Vec<SpikeWindow>) {
    prepare_with(rec, opts, &[])
}

/// Were the loads placed by hand (so handling spikes are looked for)?
pub fn by_hand(rec: &Recording, opts: &Options) -> bool {
    opts.handling && rec.meta.all.get("loading").is_none_or(|l| l.trim() != "actuator")
}

/// As [`prepare`], with further spike windows (found at the steps' edges once the steps are
/// fitted) excluded too.
pub fn prepare_with(rec: &Recording, opts: &Options, extra: &[SpikeWindow]) -> (Series, Vec<SpikeWindow>) {
    let (steps, _) = segment(rec, opts);
    let (all, mut mask) = spikes(&rec.time_s, &rec.response, opts);
    let by_hand = by_hand(rec, opts);
    let near = |t: f64| by_hand && steps.iter().any(|s| (t - s.t_log).abs() <= HANDLING_WINDOW_S);
    let mut windows = Vec::new();
    for w in all {
        if near(w.start_s) || near(w.end_s) {
            windows.push(w);
        } else {
            for (i, &t) in rec.time_s.iter().enumerate() {
                if t >= w.start_s && t <= w.end_s {
                    mask[i] = true;
                }
            }
        }
    }
    for w in extra {
        for (i, &t) in rec.time_s.iter().enumerate() {
            if t >= w.start_s && t <= w.end_s {
                mask[i] = false;
            }
        }
        windows.push(w.clone());
    }
    windows.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
    let block = if opts.mean_filter { opts.block.max(1) } else { 1 };
    let (mut t, mut v, mut g, mut ok) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut given_t, mut given_v) = (Vec::new(), Vec::new());
    for start in (0..rec.len()).step_by(block) {
        let end = (start + block).min(rec.len());
        let n_all = (end - start) as f64;
        given_t.push(rec.time_s[start..end].iter().sum::<f64>() / n_all);
        given_v.push(rec.response[start..end].iter().sum::<f64>() / n_all);
        let idx: Vec<usize> = (start..end).filter(|&i| mask[i]).collect();
        if idx.is_empty() {
            continue;
        }
        let m = idx.len() as f64;
        t.push(idx.iter().map(|&i| rec.time_s[i]).sum::<f64>() / m);
        v.push(idx.iter().map(|&i| rec.response[i]).sum::<f64>() / m);
        g.push(rec.protocol[idx[idx.len() - 1]]);
        ok.push(true);
    }
    let sigma = noise_sigma(&v);
    (Series { t, v, protocol: g, ok, sigma, given_t, given_v }, windows)
}

/// Steps from the protocol column (of the raw recording, so logged times keep full resolution).
/// Changes that revert within `min_step_s` are logging glitches: returned as notes.
pub fn segment(rec: &Recording, opts: &Options) -> (Vec<Step>, Vec<String>) {
    let (t, g) = (&rec.time_s, &rec.protocol);
    let mut notes = Vec::new();
    // runs of equal protocol value
    let mut runs: Vec<(usize, usize, f64)> = Vec::new();
    for i in 0..g.len() {
        match runs.last_mut() {
            Some(r) if r.2 == g[i] => r.1 = i,
            _ => runs.push((i, i, g[i])),
        }
    }
    // merge glitches: a short run between two runs of the same value
    let mut clean: Vec<(usize, usize, f64)> = Vec::new();
    for r in runs {
        let dur = t[r.1] - t[r.0];
        if let Some(last) = clean.last().cloned() {
            if dur < opts.min_step_s && r.1 + 1 < g.len() {
                notes.push(format!("protocol glitch at {:.3} s ignored ({} for {:.3} s)", t[r.0], r.2, dur));
                clean.last_mut().unwrap().1 = r.1;
                continue;
            }
            if last.2 == r.2 {
                clean.last_mut().unwrap().1 = r.1;
                continue;
            }
        }
        clean.push(r);
    }
    let mut steps = Vec::new();
    let (mut n_load, mut n_unload) = (0, 0);
    for w in clean.windows(2) {
        let (a, b) = (w[0], w[1]);
        let phase = if b.2 > a.2 { Phase::Loading } else { Phase::Unloading };
        let index = match phase {
            Phase::Loading => {
                n_load += 1;
                n_load - 1
            }
            Phase::Unloading => {
                n_unload += 1;
                n_unload - 1
            }
        };
        steps.push(Step { phase, index, t_log: t[b.0], t_end: t[b.1], before: a.2, after: b.2 });
    }
    (steps, notes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::recording::{Meta, ProtocolKind, Recording};

    fn rec(t: Vec<f64>, v: Vec<f64>, g: Vec<f64>) -> Recording {
        Recording {
            source: "x.csv".into(),
            meta: Meta::default(),
            time_s: t,
            response: v,
            unit: "V",
            response_column: "voltage_v",
            protocol: g,
            protocol_kind: ProtocolKind::LoadG,
            ignored_columns: vec![],
            raw: None,
        }
    }

    /// A resistance read without its divider: the noise is 10 times larger unloaded than loaded.
    /// With one threshold for the whole recording the unloaded noise was taken for handling
    /// spikes; against the local noise it is not (and a real spike still is).
    #[test]
    fn load_dependent_noise_is_not_taken_for_spikes() {
        let n = 6000;
        let mut seed = 12345u64;
        let mut gauss = || {
            let mut u = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        };
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|&x| if x < 30.0 { 50_000.0 + 100.0 * gauss() } else { 5_000.0 + 10.0 * gauss() }).collect();
        let (w, _) = spikes(&t, &v, &Options::default());
        assert!(w.is_empty(), "{} false spikes, e.g. {:?}", w.len(), w.first());
        for x in v.iter_mut().skip(4500).take(10) {
            *x += 2_000.0;
        }
        let (w, _) = spikes(&t, &v, &Options::default());
        assert_eq!(w.len(), 1, "{w:?}");
    }

    #[test]
    fn segments_loading_and_unloading_and_ignores_glitches() {
        let n = 6000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let g: Vec<f64> = t
            .iter()
            .map(|&x| {
                if x < 10.0 {
                    0.0
                } else if x < 30.0 {
                    200.0
                } else if x < 45.0 {
                    400.0
                } else {
                    200.0
                }
            })
            .collect();
        let mut g = g;
        g[2000] = 0.0; // a one-sample glitch
        let (steps, notes) = segment(&rec(t.clone(), vec![0.0; n], g), &Options::default());
        assert_eq!(steps.len(), 3);
        assert_eq!(notes.len(), 1);
        assert_eq!((steps[0].phase, steps[1].phase, steps[2].phase), (Phase::Loading, Phase::Loading, Phase::Unloading));
        assert!((steps[1].t_log - 30.0).abs() < 1e-9 && (steps[0].t_end - 29.99).abs() < 1e-9);
    }

    #[test]
    fn spikes_are_found_but_steps_and_relaxations_are_not() {
        let n = 4000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let mut v: Vec<f64> = t.iter().map(|&x| if x < 10.0 { 0.1 } else { 0.1 + 0.5 * (1.0 - (-(x - 10.0) / 0.6f64).exp()) }).collect();
        // deterministic small noise
        for (i, x) in v.iter_mut().enumerate() {
            *x += 0.002 * (((i * 7919) % 1000) as f64 / 1000.0 - 0.5);
        }
        for i in 2500..2512 {
            v[i] += 0.3;
        }
        let (w, mask) = spikes(&t, &v, &Options::default());
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].start_s <= 25.0 && w[0].end_s >= 25.1);
        assert!(!mask[2505] && mask[1000] && mask[1005]);
    }

    #[test]
    fn block_mean_reduces_rate_tenfold() {
        let n = 1000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let r = rec(t, (0..n).map(|i| i as f64).collect(), vec![0.0; n]);
        let (s, _) = prepare(&r, &Options::default());
        assert_eq!(s.t.len(), 100);
        assert!((s.v[0] - 4.5).abs() < 1e-12);
    }
}
