//! `saturation`: the response is clipped at a ceiling.
//!
//! Signature: a clipped plateau — at least 2 % of all samples within a quarter of the noise of the
//! largest value (noise piles up at one value there), with at least 5 % of them clearly below it
//! (4 σ): a response that never leaves one value is not clipped but not responding.
//! Term: the prediction is clipped at that level; samples within two raw noise σ of it are left out
//! of the fit, the steps rising into it take τ from the other steps' τ line and an onset fitted
//! below it, the steps falling from it restart at the clip (in the diagnosis, which owns the step
//! model). Physics: the ADC reference or an amplifier rail.

use super::Located;

pub const EXPLANATION: &str =
    "the response is clipped at a ceiling (ADC reference or amplifier rail): samples pile up at one value under the highest loads, modelled by clipping the prediction";

/// An amplifier's rail before the noise: no samples pile up.
pub const RAIL_EXPLANATION: &str = "the response is clipped at an amplifier's rail before the noise (its plateau is the rail ± the noise, so no samples pile up): the levels' staircase is cut at the top, and the steps falling from the rail leave it late; modelled by clipping the prediction";

/// The clip level of the series, if they show a clipped plateau.
pub fn clip_level(series: &[&[f64]], sigma: f64) -> Option<f64> {
    let vmax = series.iter().flat_map(|v| v.iter().copied()).fold(f64::NEG_INFINITY, f64::max);
    let n: usize = series.iter().map(|v| v.len()).sum();
    let sigma = sigma.max(1e-12);
    let at = series.iter().flat_map(|v| v.iter()).filter(|&&v| v >= vmax - 0.25 * sigma).count();
    let below = series.iter().flat_map(|v| v.iter()).filter(|&&v| v < vmax - 4.0 * sigma).count();
    (n > 0 && at as f64 >= 0.02 * n as f64 && below as f64 >= 0.05 * n as f64).then_some(vmax)
}

/// A ceiling the raw samples touch: their largest value repeats exactly in at least 0.2 % of them
/// (and 5 times) — a clipped ADC pins samples to one code, noise does not. Looser than
/// [`clip_level`] (which must see a plateau): used to keep the edge-spike search away from steps
/// that run into a clip too small to model.
pub fn ceiling(values: &[f64]) -> Option<f64> {
    let vmax = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let at = values.iter().filter(|&&v| v == vmax).count();
    (at >= 5 && at as f64 >= 0.002 * values.len() as f64).then_some(vmax)
}

/// The plateaus (longer than 1 s) at the clip level.
pub fn signature(recording: &str, t: &[f64], v: &[f64], level: f64, sigma: f64) -> Vec<Located> {
    let mut out = Vec::new();
    let mut start: Option<f64> = None;
    let push = |out: &mut Vec<Located>, s0: f64, s1: f64| {
        if s1 - s0 > 1.0 {
            out.push(Located { recording: recording.to_string(), start_s: s0, end_s: s1, statistic: format!("clipped at {level:.4}"), z: f64::INFINITY });
        }
    };
    for j in 0..t.len() {
        let at = v[j] >= level - 0.25 * sigma.max(1e-12);
        match (at, start) {
            (true, None) => start = Some(t[j]),
            (false, Some(s0)) => {
                push(&mut out, s0, t[j]);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s0) = start {
        push(&mut out, s0, t[t.len() - 1]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plateau_is_a_clip_and_a_peak_is_not() {
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.01).collect();
        let clipped: Vec<f64> = t.iter().map(|&x| (x * 0.3).min(1.5)).collect();
        assert_eq!(clip_level(&[&clipped], 0.003), Some(1.5));
        assert_eq!(signature("a", &t, &clipped, 1.5, 0.003).len(), 1);
        let ramp: Vec<f64> = t.iter().map(|&x| x * 0.3).collect();
        assert_eq!(clip_level(&[&ramp], 0.003), None);
        assert_eq!(ceiling(&clipped), Some(1.5));
        assert_eq!(ceiling(&ramp), None);
        // a response that never moves (a disconnected sensor) is not a clip, noisy or not
        let flat = vec![0.1; 1000];
        assert_eq!(clip_level(&[&flat], 0.0), None);
        let noisy: Vec<f64> = (0..1000).map(|i| 0.1 + 0.003 * ((i * 7919 % 13) as f64 / 6.0 - 1.0)).collect();
        assert_eq!(clip_level(&[&noisy], 0.003), None);
        // mostly clipped but leaving it now and then still is one
        let mostly: Vec<f64> = t.iter().map(|&x| if x < 1.0 { x * 0.3 } else { 1.5 }).collect();
        assert_eq!(clip_level(&[&mostly], 0.003), Some(1.5));
    }
}
