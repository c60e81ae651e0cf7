//! Locate: where the model fails in its residuals (the whiteness test per hold), each effect's
//! signature, and what the residual does right after the steps.

use super::*;

/// One hold of one trial with a model's residuals (the stretch before the first step included).
pub(super) struct HoldData {
    pub(super) trial: usize,
    pub(super) t: Vec<f64>,
    pub(super) r: Vec<f64>,
    pub(super) t0: f64,
    pub(super) end: f64,
    pub(super) tau: f64,
    pub(super) load: f64,
    pub(super) prev: f64,
}

pub(super) fn hold_data(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat) -> Vec<HoldData> {
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
pub(super) fn signature(e: Effect, holds: &[HoldData], trials: &[Trial], clip: Option<f64>, report: &Report) -> Vec<Window> {
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
pub(super) fn local_noise(r: &[f64]) -> f64 {
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
pub(super) fn locate(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat) -> Vec<Window> {
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
pub(super) fn step_transients(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat, unit: &str) -> Option<String> {
    let mut buf = Vec::new();
    let (mut up, mut down) = (Vec::new(), Vec::new());
    for (i, tr) in trials.iter().enumerate() {
        for (s, sg) in tr.segs.iter().enumerate() {
            let end = tr.seg_end(s);
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

/// Where a term's signature shows in the residuals of the model before it entered (the whiteness
/// test's windows when the signature alone does not reach its threshold).
#[allow(clippy::too_many_arguments)]
pub(super) fn entry_windows(e: Effect, d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat, clip: Option<f64>, report: &Report) -> Vec<Window> {
    let windows = signature(e, &hold_data(d, trials, x, cfg, hat), trials, clip, report);
    if windows.is_empty() {
        locate(d, trials, x, cfg, hat)
    } else {
        windows
    }
}

/// Where the baseline fails, before any term is chosen: the whiteness test's windows and every
/// catalogue signature's on the baseline's residuals (the clean fit `xc`).
pub(super) fn located_windows(d: &Design, trials: &[Trial], xc: &[f64], base_cfg: &Config, hat: &Hat, clip: Option<f64>, report: &Report) -> Vec<LocatedWindow> {
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

/// What the improved model leaves unexplained: the whiteness test's windows on its residuals, led
/// by what the residual does right after the steps when there are any.
pub(super) fn unexplained(d: &Design, trials: &[Trial], x: &[f64], cfg: &Config, hat: &Hat, unit: &str) -> Unexplained {
    let remaining = locate(d, trials, x, cfg, hat);
    let mut evidence: Vec<String> = remaining.iter().map(|w| format!("{} {:.1}–{:.1} s: {}", w.recording, w.start_s, w.end_s, w.statistic)).collect();
    if !remaining.is_empty() {
        if let Some(line) = step_transients(d, trials, x, cfg, hat, unit) {
            evidence.insert(0, line);
        }
    }
    Unexplained { flag: !remaining.is_empty(), evidence }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let s = local_noise(&r);
        assert!((s - 2.0).abs() < 0.15, "{s}");
        // the ramp alone is no noise
        let ramp: Vec<f64> = (0..4000).map(|i| 40.0 * i as f64 / 4000.0).collect();
        assert!(local_noise(&ramp) < 1e-9);
    }
}
