//! Saturation's shape: the clip level, the steps a clip shapes, and the time constants and onsets
//! of the steps rising into it (their own part-1 fits are biased by the clipped shape).

use super::*;

/// The steps a clip shapes (each as (trial, segment)) and the units its evidence lies in.
pub(super) struct ClipSteps {
    pub(super) into: Vec<(usize, usize)>,
    pub(super) from: Vec<(usize, usize)>,
    /// The units where a clip's evidence lies, in groups tested each on its own: the rising steps
    /// (a piled clip); a rail's rising steps from below it and its falling steps that leave it.
    pub(super) units: Vec<Vec<(usize, usize)>>,
    /// An amplifier's rail before the noise ([`rail_level`]): the steps falling from it leave it
    /// late, up to seconds after their landing; their onsets are fitted where they leave it.
    pub(super) rail: bool,
}

/// The steps a clip shapes, per (trial, segment): those rising into it ("into") and those
/// starting from a clipped load ("from"), and the (trial, segment) units where a clip's evidence
/// lies (units count segments from 1).
pub(super) fn clipped_segments(trials: &[Trial], clip: f64, rail: bool) -> ClipSteps {
    let (mut into, mut from) = (Vec::new(), Vec::new());
    for (k, tr) in trials.iter().enumerate() {
        let at = 0.25 * tr.sigma.max(1e-12);
        let mut prev_clipped = false;
        for (s, sg) in tr.segs.iter().enumerate() {
            let end = tr.seg_end(s);
            // at a rail, whose plateau is the rail ± the noise, a step reaches it when its hold ends
            // there (a lone sample of the hold below it may touch it)
            let reaches = if rail { ends_at(tr, (sg.t0, end), clip) } else { tr.t.iter().zip(&tr.v).any(|(&t, &v)| t >= sg.t0 && t < end && v >= clip - at) };
            if prev_clipped && sg.load < sg.prev {
                from.push((k, s));
            } else if reaches && sg.load > sg.prev {
                into.push((k, s));
            }
            // the next step falls from the clip only when this hold ends at it (a step falling from
            // the clip touches it at its start, and its hold is below)
            prev_clipped = reaches && ends_at(tr, (sg.t0, end), clip);
        }
    }
    // the evidence: the rising steps, whose shape the clip changes (a piled clip's falling steps'
    // onsets are moved so the clip leaves them as they were); a rail's also its falling steps, which
    // leave it late — two kinds of evidence (the rise's corner, the late fall), each tested on its
    // own; steps that start and end at the rail have no shape to change
    // the held-out units: segments from 1 at the first onset of each trial; one recording's are
    // its steps (left out one by one), or blocks of holds, which a clip's steps do not map to
    // (no group: every unit)
    let one = trials.len() == 1;
    if one && hold_blocks(trials) > 0 {
        return ClipSteps { into, from, units: vec![], rail };
    }
    let unit = |&(k, s): &(usize, usize)| if one { (k, s) } else { (k, s + 1) };
    let units = if rail {
        let rises = into.iter().filter(|&&(k, s)| !starts_at(&trials[k], s, clip)).map(unit).collect();
        let falls = from.iter().filter(|&&(k, s)| !ends_at(&trials[k], (trials[k].segs[s].t0, trials[k].seg_end(s)), clip)).map(unit).collect();
        vec![rises, falls]
    } else {
        vec![into.iter().map(unit).collect()]
    };
    ClipSteps { into, from, units, rail }
}

/// Whether step `s` starts at the clip: the hold before it ends there.
fn starts_at(tr: &Trial, s: usize, clip: f64) -> bool {
    s > 0 && ends_at(tr, (tr.segs[s - 1].t0, tr.segs[s].t0), clip)
}

/// Whether a hold (from `t0_s` to `end_s`) ends at the clip: the median of its last quarter is
/// within the samples' margin of it (a plateau piled at the clip, or a rail ± the noise).
fn ends_at(tr: &Trial, (t0_s, end_s): (f64, f64), clip: f64) -> bool {
    let end_s = end_s.min(tr.t.last().copied().unwrap_or(t0_s));
    let from_s = t0_s + 0.75 * (end_s - t0_s);
    let mut last: Vec<f64> = tr.t.iter().zip(&tr.v).filter(|(&t, _)| t >= from_s && t <= end_s).map(|(_, &v)| v).collect();
    !last.is_empty() && crate::sensor::preprocess::median(&mut last) >= clip - tr.clip_margin.max(0.5 * tr.sigma).max(1e-12)
}

/// τ of the other steps as a straight line in the load (least squares, `fashion::line`), as the
/// first-order model's τ(F) is: (intercept, slope); None with fewer than two other steps.
pub(super) fn tau_line(trials: &[Trial], skip: &[(usize, usize)]) -> Option<(f64, f64)> {
    let (loads, taus): (Vec<f64>, Vec<f64>) = trials
        .iter()
        .enumerate()
        .flat_map(|(k, tr)| tr.segs.iter().enumerate().filter(move |(s, _)| !skip.contains(&(k, *s))).map(|(_, sg)| (sg.load, sg.tau)))
        .filter(|p| p.1 > 0.0)
        .unzip();
    if loads.len() < 2 {
        return None;
    }
    let (slope, intercept, _) = crate::sensor::fashion::line(&loads, &taus);
    Some((intercept, slope))
}

/// The onset of a step rising into the clip with time constant `tau`: a local first-order fit
/// (offset and amplitude free) to its samples below the clip, over a grid of onsets around the
/// part-1 onset.
pub(super) fn rising_onset(tr: &Trial, s: usize, tau: f64, clip: f64) -> f64 {
    let sg = &tr.segs[s];
    let end = tr.seg_end(s);
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

/// The onset of a step falling from the clip with time constant `tau`: where a first-order fall
/// from the clip (its amplitude free) fits the samples best, on a grid from 1 s before the step's
/// onset or logged change to 6 s + 3τ after the change (a rail's fall starts when the noise-free
/// signal, above the rail, comes down to it) or the next step.
fn falling_onset(tr: &Trial, s: usize, tau: f64, clip: f64) -> f64 {
    let sg = &tr.segs[s];
    let end = tr.seg_end(s);
    let (lo, hi) = (sg.t0.min(sg.t_log) - 1.0, end.min(sg.t_log + 6.0 + 3.0 * tau));
    let pts: Vec<(f64, f64)> = tr.t.iter().zip(&tr.v).filter(|(&t, _)| t >= lo && t < end.min(hi + 5.0 * tau)).map(|(&t, &v)| (t, v - clip)).collect();
    let mut best = (f64::INFINITY, sg.t0);
    let n = (((hi - lo) / 0.01).ceil() as usize).clamp(1, 2000);
    for g in 0..=n {
        let t0 = lo + (hi - lo) * g as f64 / n as f64;
        // v − clip = b·u(t), u the step's rise from t0 (its ramp, if any): least squares in b
        let (mut s_uu, mut s_uv, mut s_vv) = (0.0, 0.0, 0.0);
        for &(t, v) in &pts {
            let u = if t + sg.input.ramp_s > t0 { rise(t, t0, tau, 0.0, sg.input) } else { 0.0 };
            s_uu += u * u;
            s_uv += u * v;
            s_vv += v * v;
        }
        if s_uu <= 0.0 {
            continue;
        }
        let rss = s_vv - s_uv * s_uv / s_uu;
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
    let tau_at = |k: usize, s: usize| (a + b * trials[k].segs[s].load).max(1e-3);
    let into = steps.into.iter().map(|&(k, s)| FixedStep { at: (k, s), tau_s: tau_at(k, s), t0_s: rising_onset(&trials[k], s, tau_at(k, s), clip) });
    // a rail's falling steps leave it late (the noise-free signal falls from above it): their onset
    // is where they leave it, fitted below it with the τ line's τ (part 1 looked for it near the log)
    let from = steps.from.iter().filter(|_| steps.rail).map(|&(k, s)| FixedStep { at: (k, s), tau_s: tau_at(k, s), t0_s: falling_onset(&trials[k], s, tau_at(k, s), clip) });
    into.chain(from).collect()
}

/// Where a rail's signal may sit on it, per step it shapes: (trial, from where to look, where the
/// data first read the rail, to; s). A step rising into it: from its fixed onset (the first sample
/// at or above the rail after it) to the next step's start. A step falling from it: from its start
/// to its fixed onset, where it leaves the rail, or to the next step's start when its hold ends on
/// the rail too. `terms::settle_rail_spans` then starts each where the fitted model reaches the rail.
pub(super) fn rail_spans(trials: &[Trial], clip: f64, steps: &ClipSteps, fixed: &[FixedStep]) -> Vec<(usize, f64, f64, f64)> {
    let onset = |at: (usize, usize)| fixed.iter().find(|f| f.at == at).map(|f| f.t0_s);
    let next = |k: usize, s: usize| trials[k].seg_end(s);
    let rises = steps.into.iter().map(|&(k, s)| {
        let tr = &trials[k];
        let start = onset((k, s)).unwrap_or(tr.segs[s].t0);
        // none read the rail: the window is kept, its span empty until the model reaches the rail
        let hit = tr.t.iter().zip(&tr.v).find(|(&t, &v)| t >= start && t < next(k, s) && v >= clip).map_or(next(k, s), |(&t, _)| t);
        (k, start, hit, next(k, s))
    });
    let falls = steps.from.iter().map(|&(k, s)| {
        let t0 = trials[k].segs[s].t0;
        let end = if ends_at(&trials[k], (t0, next(k, s)), clip) { next(k, s) } else { onset((k, s)).unwrap_or(t0) };
        (k, t0, t0, end)
    });
    rises.chain(falls).collect()
}

pub(super) fn clip_level(trials: &[Trial]) -> Option<f64> {
    let sigma = trials.iter().map(|t| t.sigma).fold(0.0, f64::max);
    catalogue::saturation::clip_level(&trials.iter().map(|t| t.v.as_slice()).collect::<Vec<_>>(), sigma)
}

/// How far the top load's increment must fall short of what the two increments below it predict
/// (their geometric continuation) for a rail to be proposed. A divider's compression slows the
/// increments smoothly: noise-free, over power laws G ∝ F^n with n 0.6–1.25, the top load at
/// 30–96 % of the divider's span, 5 equal weights of 10–500 g and preloads of 0–0.5 N, the top
/// increment is at least 0.978 × that continuation (at least 0.997 for n ≤ 1.1); on family A's
/// tuning seeds the least without a rail was 0.985 (a second time constant on 40 g steps), and
/// 1.020 on the 0–1000 g protocol with the trials' nuisances. A rail whose height is set by its
/// RMS of 1σ, as every other effect's, cuts it to 0.89 on 40 g steps and 0.96 on 200 g steps; at
/// stop 41's 0.85 neither was proposed (saturation 0/8 on both rows).
/// A proposal only lets the clip term compete: it must still pass the gate.
pub(super) const RAIL_COLLAPSE: f64 = 0.97;

/// An amplifier's rail before the noise (issue 15, item 4): the samples do not pile up at one value
/// (the plateau is the rail ± the noise, so [`clip_level`] sees none), but the staircase of levels
/// collapses at the top — the highest load's level rises by under [`RAIL_COLLAPSE`] of the
/// geometric continuation of the two increments below it. The rail is then proposed at the median
/// of the top load's settled samples (the second half of each of its holds); whether the clip there
/// predicts held-out data better is the gate's to decide, and a rail is never reported on its
/// plateau alone.
pub(super) fn rail_level(d: &Design, trials: &[Trial], hat: &Hat) -> Option<f64> {
    // with a simulator baseline the levels are the simulator's, not the data's
    if d.prior {
        return None;
    }
    let mut lv: Vec<(f64, f64)> = hat.loads.iter().copied().zip(hat.level.iter().copied()).collect();
    lv.sort_by(|a, b| a.0.total_cmp(&b.0));
    let m = lv.len();
    if m < 4 {
        return None;
    }
    // increments per unit of load (the weights may differ)
    let inc: Vec<f64> = lv.windows(2).map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0)).collect();
    if !cut_at_the_top(&inc) {
        return None;
    }
    let top_load = lv[m - 1].0;
    let mut settled: Vec<f64> = Vec::new();
    for tr in trials {
        let last = tr.t.last().copied().unwrap_or(0.0);
        for (s, sg) in tr.segs.iter().enumerate().filter(|(_, sg)| sg.load == top_load) {
            let end = tr.seg_end(s).min(last);
            let mid = sg.t0 + 0.5 * (end - sg.t0);
            settled.extend(tr.t.iter().zip(&tr.v).filter(|(&t, _)| t >= mid && t < end).map(|(_, &v)| v));
        }
    }
    (settled.len() >= 10).then(|| crate::sensor::preprocess::median(&mut settled))
}

/// Whether a staircase's increments (per unit of load, in the order of the loads; at least three)
/// collapse at the top: the last falls under [`RAIL_COLLAPSE`] of the geometric continuation of the
/// two below it ([`continuation_ratio`]).
fn cut_at_the_top(inc: &[f64]) -> bool {
    continuation_ratio(inc).is_some_and(|r| r < RAIL_COLLAPSE)
}

/// The top increment over the geometric continuation of the two below it (their ratio capped at 1:
/// a staircase that still steepens is continued flat); None unless those two rise.
fn continuation_ratio(inc: &[f64]) -> Option<f64> {
    let m = inc.len();
    if m < 3 {
        return None;
    }
    let (a, b, top) = (inc[m - 3], inc[m - 2], inc[m - 1]);
    (a > 0.0 && b > 0.0).then(|| top / (b * (b / a).min(1.0)))
}

impl ClipSteps {
    /// The steps a clip at `clip` shapes (none without a clip); `rail`: an amplifier's rail before
    /// the noise.
    pub(super) fn of(trials: &[Trial], clip: Option<f64>, rail: bool) -> ClipSteps {
        match clip {
            Some(c) => clipped_segments(trials, c, rail),
            None => ClipSteps { into: vec![], from: vec![], units: vec![vec![]], rail },
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
        let steps = ClipSteps::of(&b.trials, Some(level), false);
        let load = |&(k, s): &(usize, usize)| (b.trials[k].segs[s].prev, b.trials[k].segs[s].load);
        assert_eq!(steps.into.iter().map(load).collect::<Vec<_>>(), vec![(800.0, 1000.0); 3]);
        assert_eq!(steps.from.iter().map(load).collect::<Vec<_>>(), vec![(1000.0, 800.0); 3]);
        let fixes = clip_fixes(&b.trials, level, &steps);
        assert_eq!(fixes.len(), 3);
        assert!(clip_level(&fixture::built(&fixture::recs(7000, |_| {})).trials).is_none());
    }

    /// The noise-free staircase of a power law seen through a divider (sensor between supply and
    /// node: v/Vcc = x/(1+x), x = G·Rm ∝ F^n) is never taken for a rail, whatever the law (n
    /// 0.6–1.25), how far up the divider's span the top load reaches (30–96 %), the equal weights
    /// (10–500 g) and the preload (0–0.5 N): its top increment stays at 0.978 of the continuation or
    /// above (0.997 for n ≤ 1.1), 1 % over the threshold. A rail that cuts 6 % off the top rise (a
    /// 1σ rail on 200 g steps cuts about that much) is seen wherever the law keeps the top increment
    /// within 3 % of the continuation (family A's 200 g staircase: 1.027).
    #[test]
    fn a_divider_power_law_is_no_rail_and_a_cut_top_is() {
        let (mut least, mut least_gentle, mut near, mut cut) = (f64::INFINITY, f64::INFINITY, 0, 0);
        for n in (0..=13).map(|k| 0.6 + 0.05 * k as f64) {
            for share in (0..=22).map(|k| 0.30 + 0.03 * k as f64) {
                for w in [10.0, 20.0, 40.0, 100.0, 200.0, 500.0] {
                    for pre in [0.0, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5] {
                        let top_n = 5.0 * w / 1000.0 * 9.80665 + pre;
                        let g = share / (1.0 - share) / f64::powf(top_n, n);
                        let x = |f: f64| if f > 0.0 { g * f.powf(n) } else { 0.0 };
                        let v: Vec<f64> = (0..6).map(|k| x(k as f64 * w / 1000.0 * 9.80665 + pre)).map(|x| x / (1.0 + x)).collect();
                        let mut inc: Vec<f64> = v.windows(2).map(|p| (p[1] - p[0]) / w).collect();
                        let r = continuation_ratio(&inc).expect("a rising staircase");
                        assert!(!cut_at_the_top(&inc), "n {n} share {share} w {w} pre {pre}: {r}");
                        least = least.min(r);
                        if n <= 1.1 + 1e-9 {
                            least_gentle = least_gentle.min(r);
                        }
                        if r <= 1.03 {
                            near += 1;
                            inc[4] *= 0.94;
                            cut += usize::from(cut_at_the_top(&inc));
                        }
                    }
                }
            }
        }
        assert!(least >= 0.978 && least_gentle >= 0.997, "least {least}, for n ≤ 1.1 {least_gentle}");
        assert!(near > 1000, "{near} laws within 3 % of the continuation");
        assert_eq!(cut, near, "a 6 % cut is seen on every law within 3 % of the continuation");
    }

    /// Compressed top levels (a conductance exponent of 0.85, the top load at 85 % of the span):
    /// no rail is proposed on them; with an amplifier's rail before the noise a quarter of the way
    /// from the fourth level to the top one, it is, at the rail (± a tenth of the top increment),
    /// and its evidence is in two groups (the rises into it, the falls that leave it late).
    #[test]
    fn a_rail_is_proposed_where_the_staircase_is_cut_not_where_it_compresses() {
        let compress = |s: &mut crate::params::sensor::SensorParams| {
            s.exponent = 0.85;
            s.g_ref_s = (0.85 / 0.15) / (s.circuit.r_m_ohm * (1.02 * 9.80665f64).powf(0.85));
        };
        let null = fixture::built(&fixture::recs(94_000, compress));
        assert_eq!(rail_level(&null.d, &null.trials, &null.hat), None);
        let s = fixture::sensor(compress);
        let level = |g: f64| s.v_eq((g + 20.0) / 1000.0 * 9.80665);
        let rail = level(800.0) + 0.25 * (level(1000.0) - level(800.0));
        let (recs, truth) = fixture::recs_and_truth(94_000, |s| {
            compress(s);
            s.effects.saturation_v = rail;
            s.effects.saturation_before_noise = true;
        });
        let b = fixture::built(&recs);
        assert_eq!(clip_level(&b.trials), None, "a rail before the noise piles no samples up");
        let found = rail_level(&b.d, &b.trials, &b.hat).expect("a rail");
        assert!((found - rail).abs() < 0.1 * (level(1000.0) - level(800.0)), "{found} vs {rail}");
        let steps = ClipSteps::of(&b.trials, Some(found), true);
        let load = |&(k, s): &(usize, usize)| (b.trials[k].segs[s].prev, b.trials[k].segs[s].load);
        assert_eq!(steps.into.iter().map(load).collect::<Vec<_>>(), vec![(800.0, 1000.0); 3]);
        assert_eq!(steps.from.iter().map(load).collect::<Vec<_>>(), vec![(1000.0, 800.0); 3]);
        assert_eq!(steps.units, vec![steps.into.iter().map(|&(k, s)| (k, s + 1)).collect::<Vec<_>>(), steps.from.iter().map(|&(k, s)| (k, s + 1)).collect()]);
        // the falls leave the rail when the noise-free signal, from 1000 g's level, comes down to it:
        // a quarter of the step is left at 800 g, after ln 4 time constants
        let fixes = clip_fixes(&b.trials, found, &steps);
        assert_eq!(fixes.len(), 6, "the rises into the rail and the falls from it");
        for fx in fixes.iter().filter(|fx| steps.from.contains(&fx.at)) {
            let land = truth[fx.at.0].steps[fx.at.1].t_land_s;
            let leave = land + 4f64.ln() * s.tau((800.0 + 20.0) / 1000.0 * 9.80665);
            assert!((fx.t0_s - leave).abs() < 0.4, "leaves at {} s, expected {leave} s (landed {land} s)", fx.t0_s);
        }
    }
}
