//! Saturation's shape: the clip level, the steps a clip shapes, and the time constants and onsets
//! of the steps rising into it (their own part-1 fits are biased by the clipped shape).

use super::*;

/// The steps a clip shapes (each as (trial, segment)) and the units its evidence lies in.
pub(super) struct ClipSteps {
    pub(super) into: Vec<(usize, usize)>,
    pub(super) from: Vec<(usize, usize)>,
    pub(super) units: Vec<(usize, usize)>,
}

/// The steps a clip shapes, per (trial, segment): those rising into it ("into") and those
/// starting from a clipped load ("from"), and the (trial, segment) units where a clip's evidence
/// lies (units count segments from 1).
pub(super) fn clipped_segments(trials: &[Trial], clip: f64) -> ClipSteps {
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
pub(super) fn tau_line(trials: &[Trial], skip: &[(usize, usize)]) -> Option<(f64, f64)> {
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
pub(super) fn rising_onset(tr: &Trial, s: usize, tau: f64, clip: f64) -> f64 {
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
pub(super) fn clip_fixes(trials: &[Trial], clip: f64, steps: &ClipSteps) -> Vec<FixedStep> {
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

pub(super) fn clip_level(trials: &[Trial]) -> Option<f64> {
    let sigma = trials.iter().map(|t| t.sigma).fold(0.0, f64::max);
    catalogue::saturation::clip_level(&trials.iter().map(|t| t.v.as_slice()).collect::<Vec<_>>(), sigma)
}

impl ClipSteps {
    /// The steps a clip at `clip` shapes (none without a clip).
    pub(super) fn of(trials: &[Trial], clip: Option<f64>) -> ClipSteps {
        match clip {
            Some(c) => clipped_segments(trials, c),
            None => ClipSteps { into: vec![], from: vec![], units: vec![] },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A clip at 1.55 V cuts the top load's holds only (1000 g reads about 1.65 V): the level is
    /// found, the three steps into it and the three falling from it are the ones it shapes; no
    /// clip on clean data.
    #[test]
    fn a_clip_shapes_the_steps_into_it_and_from_it_only() {
        let b = fixture::built(&fixture::recs(7000, |s| s.effects.saturation_v = 1.55));
        let level = clip_level(&b.trials).expect("the clip level");
        assert!((level - 1.55).abs() < 0.01, "{level}");
        let steps = ClipSteps::of(&b.trials, Some(level));
        let load = |&(k, s): &(usize, usize)| (b.trials[k].segs[s].prev, b.trials[k].segs[s].load);
        assert_eq!(steps.into.iter().map(load).collect::<Vec<_>>(), vec![(800.0, 1000.0); 3]);
        assert_eq!(steps.from.iter().map(load).collect::<Vec<_>>(), vec![(1000.0, 800.0); 3]);
        let fixes = clip_fixes(&b.trials, level, &steps);
        assert_eq!(fixes.len(), 3);
        assert!(clip_level(&fixture::built(&fixture::recs(7000, |_| {})).trials).is_none());
    }
}
