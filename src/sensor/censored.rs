//! Samples censored at an ADC's floor. A divider read at no load sits near 0 V; the ADC cannot read
//! below 0, so every sample whose noise would take it under the floor reads exactly 0 (a real
//! Interlink FSR402 on an Arduino reads 0 counts at rest). The samples that remain above are the
//! upper half of the noise: a zero-load level fitted to them by least squares sits about 0.4 σ
//! above the truth, and every step to or from zero load then misfits (on family A's advice bench,
//! no preload, a 0.2 % conductance creep lost to a warm-up drift that took up that misfit).
//!
//! Where the samples pile up at exactly 0 V, each second's level is fitted as a censored normal
//! (Tobit: the samples above the floor by their density, the count at the floor by the probability
//! of reading under it, σ from the recording's noise above the floor), and each sample at the floor
//! is replaced by its expected value given that it lies below: μ − σ·φ(α)/Φ(α), α = (c − μ)/σ, where
//! c is half the ADC's step (a reading of 0 is a value under it; 0 when the readings are not on a
//! grid). The second's mean is then its fitted level. The seconds are counted from each logged
//! change of the load, so that none runs across one. Seconds with fewer than [`MIN_ABOVE`] samples
//! above the floor say nothing about how far below it the level lies; their samples stay as read.

use super::preprocess::diff_sigma;
use super::recording::Recording;

/// A pile at the floor has at least this many samples…
pub const MIN_PILE: usize = 20;
/// …and at least this many times as many as the next value above it (an ADC step: a normal's tail
/// puts fewer samples on its lowest value than on the next; a floor puts the whole tail on it).
pub const PILE_OVER_NEXT: f64 = 2.0;
/// The span (s) over which a level is fitted, at least [`MIN_BLOCK`] samples.
pub const BLOCK_S: f64 = 1.0;
const MIN_BLOCK: usize = 20;
/// A block's level is fitted only with at least this many samples above the floor.
pub const MIN_ABOVE: usize = 3;

/// What was done to one recording's samples at the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct Censored {
    /// Samples that read exactly the floor.
    pub at_floor: usize,
    /// Of those, replaced by their expected value below it.
    pub replaced: usize,
    /// The noise σ (V) the levels were fitted with.
    pub sigma_v: f64,
    /// The value (V) a reading at the floor lies under: half the ADC's step, or 0 off a grid.
    pub cut_v: f64,
}

/// The recording with its samples at the ADC's floor (0 V) replaced by their expected values below
/// it, when they pile up there (None otherwise: another unit, a reading below 0, no pile, or a
/// recording block-averaged to the working rate, whose samples are means over the floor and above
/// it, not readings).
pub fn uncensored(rec: &Recording) -> Option<(Recording, Censored)> {
    if rec.unit != "V" || rec.raw.is_some() || rec.response.iter().any(|&v| v < 0.0) {
        return None;
    }
    let at_floor = rec.response.iter().filter(|&&v| v == 0.0).count();
    let next = rec.response.iter().copied().filter(|&v| v > 0.0).fold(f64::INFINITY, f64::min);
    let at_next = rec.response.iter().filter(|&&v| v == next).count();
    if at_floor < MIN_PILE || (at_floor as f64) < PILE_OVER_NEXT * at_next as f64 {
        return None;
    }
    let sigma = sigma_above(&rec.response)?;
    // a reading of 0 is a value under half the ADC's step (the step's middle: rounded, or
    // truncated and read as the step's foot, which shifts every reading alike)
    let cut = 0.5 * adc_step(rec, next);
    // the median sample interval (a logger's jitter does not change the block's length)
    let dt = Some(rec.dt()).filter(|d| d.is_finite() && *d > 0.0).unwrap_or(BLOCK_S / MIN_BLOCK as f64);
    let block = ((BLOCK_S / dt).round() as usize).max(MIN_BLOCK);
    let mut out = rec.clone();
    let mut replaced = 0;
    for (a, b) in blocks(&rec.protocol, rec.len(), block) {
        let chunk = &mut out.response[a..b];
        let above: Vec<f64> = chunk.iter().copied().filter(|&v| v > 0.0).collect();
        let below = chunk.iter().filter(|&&v| v == 0.0).count();
        if below == 0 || above.len() < MIN_ABOVE {
            continue;
        }
        let mu = tobit_level(&above, below, sigma, cut);
        let expected = mu - sigma * mills((cut - mu) / sigma);
        for v in chunk.iter_mut().filter(|v| **v == 0.0) {
            *v = expected;
        }
        replaced += below;
    }
    Some((out, Censored { at_floor, replaced, sigma_v: sigma, cut_v: cut }))
}

/// The blocks (start, end) a level is fitted over: each stretch between the logged load's changes
/// (`protocol`, one value per sample) cut into about `block` samples each, so that a block does not
/// run across a logged change (one across a step to zero load would fit one level to both; the log
/// may still follow the landing by a fraction of a second). A change less than [`MIN_BLOCK`]
/// samples after the last one kept, or before the end, is not a cut (a logging glitch); a protocol
/// that changes more often than once a block (a load measured as it varies), and a recording
/// without a protocol column, are one stretch.
fn blocks(protocol: &[f64], n: usize, block: usize) -> Vec<(usize, usize)> {
    let mut cuts: Vec<usize> = vec![0];
    let changes: Vec<usize> = if protocol.len() == n { (1..n).filter(|&i| protocol[i] != protocol[i - 1]).collect() } else { vec![] };
    // more changes than blocks: a load measured as it varies, not logged steps
    if changes.len() * block.max(1) <= n {
        for i in changes {
            if i - cuts[cuts.len() - 1] >= MIN_BLOCK && n - i >= MIN_BLOCK {
                cuts.push(i);
            }
        }
    }
    cuts.push(n);
    let mut out = Vec::new();
    for w in cuts.windows(2) {
        let (a, len) = (w[0], w[1] - w[0]);
        let k = (len / block.max(1)).max(1);
        out.extend((0..k).map(|j| (a + j * len / k, a + (j + 1) * len / k)).filter(|(x, y)| y > x));
    }
    out
}

/// The note a report gives for one recording's censored samples.
pub fn note(source: &str, c: &Censored, samples: usize) -> String {
    format!(
        "{source}: {} of {samples} samples read exactly 0 V, the ADC's floor (the noise under it is cut off, so the samples above it alone put a level near zero too high): {} of them, in the seconds that also hold samples above the floor, were replaced by their expected value below it (each second's level fitted as a normal censored at {}, σ {:.3e} V); the rest stay as read",
        c.at_floor,
        c.replaced,
        if c.cut_v > 0.0 { format!("{:.3e} V, half the ADC's step", c.cut_v) } else { "0 V (the readings are not on an ADC's grid)".to_string() },
        c.sigma_v
    )
}

/// The ADC's step (V) near the floor: from the recording's `adc_bits` and `vref_v` when it gives
/// them and the lowest reading above the floor (`next`) is one of its multiples, else `next` when
/// the readings near the floor all sit on its multiples (a recording in volts converted from
/// counts), else 0 (not read on a grid: a gain stage, averaged readings).
fn adc_step(rec: &Recording, next: f64) -> f64 {
    if !(next.is_finite() && next > 0.0) {
        return 0.0;
    }
    if let Some(q) = rec.meta.adc_step_v() {
        let k = (next / q).round();
        if k >= 1.0 && (next / q - k).abs() < 0.01 {
            return q;
        }
    }
    let low: Vec<f64> = rec.response.iter().copied().filter(|&v| v > 0.0 && v < 20.0 * next).collect();
    let on_grid = low.iter().filter(|&&v| ((v / next) - (v / next).round()).abs() < 1e-3).count();
    if !low.is_empty() && on_grid as f64 >= 0.99 * low.len() as f64 && low.iter().any(|&v| v > 1.5 * next) {
        next
    } else {
        0.0
    }
}

/// The noise σ from first differences (`preprocess::diff_sigma`) of samples both above the floor,
/// and then of samples both over 5 of those σ above it (next to the floor the noise is cut, and
/// its spread with it), when there are enough; None when there are too few at all.
fn sigma_above(v: &[f64]) -> Option<f64> {
    let of = |over: f64| -> Option<f64> {
        let d: Vec<f64> = v.windows(2).filter(|w| w[0] > over && w[1] > over).map(|w| w[1] - w[0]).collect();
        if d.len() < MIN_PILE {
            return None;
        }
        let s = diff_sigma(d);
        (s > 0.0 && s.is_finite()).then_some(s)
    };
    let near = of(0.0)?;
    Some(of(5.0 * near).unwrap_or(near))
}

/// φ(a)/Φ(a): the standard normal's density over its distribution function (the inverse Mills
/// ratio), through erfc so that it stays exact in the far tails.
fn mills(a: f64) -> f64 {
    let pdf = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let cdf = 0.5 * libm::erfc(-a / std::f64::consts::SQRT_2);
    if cdf > 1e-300 {
        pdf / cdf
    } else {
        // far in the lower tail φ/Φ → −a
        -a
    }
}

/// The maximum-likelihood level μ of samples `above` the floor and `below` samples at it, from a
/// normal of known σ censored at `cut` (the readings at the floor are the values under it): the
/// root of Σ(u − μ)/σ² − below·φ(α)/(σΦ(α)), α = (cut − μ)/σ, which falls as μ rises (by
/// bisection).
fn tobit_level(above: &[f64], below: usize, sigma: f64, cut: f64) -> f64 {
    let score = |mu: f64| above.iter().map(|u| u - mu).sum::<f64>() / (sigma * sigma) - below as f64 * mills((cut - mu) / sigma) / sigma;
    let top = above.iter().copied().fold(0.0, f64::max);
    let (mut lo, mut hi) = (-10.0 * sigma, top.max(sigma));
    // widen downwards until the score changes sign (a level far under the floor)
    while score(lo) < 0.0 && lo > -1e3 * sigma {
        lo *= 2.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if score(mid) > 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A level of 0.2 σ under noise σ, read by an ADC that cannot go below 0, and a loaded hold at
    /// 1 V: as read (the floor's samples at 0), the level's mean sits about 0.3 σ too high; with the
    /// floor's samples replaced, it is back within a tenth of σ, and the hold is as read. The same
    /// on a time base with a logger's late samples. A recording at 1 V all through is not touched, nor one
    /// that reads below 0.
    #[test]
    fn a_level_read_at_the_floor_is_recovered() {
        let sigma = 3e-3;
        let n = 6000;
        // a deterministic normal sample (Box–Muller on a fixed sequence)
        let mut state = 12345u64;
        let mut unif = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let noise: Vec<f64> = (0..n).map(|_| (-2.0 * unif().ln()).sqrt() * (2.0 * std::f64::consts::PI * unif()).cos()).collect();
        let truth = 0.2 * sigma;
        let level = |i: usize| if i < n / 2 { truth } else { 1.0 };
        let read: Vec<f64> = noise.iter().enumerate().map(|(i, e)| (level(i) + sigma * e).max(0.0)).collect();
        let rec = Recording {
            source: "t.csv".into(),
            meta: Default::default(),
            time_s: (0..n).map(|i| i as f64 * 0.01).collect(),
            response: read.clone(),
            unit: "V",
            response_column: "voltage_v",
            protocol: vec![0.0; n],
            protocol_kind: super::super::recording::ProtocolKind::LoadG,
            ignored_columns: vec![],
            raw: None,
        };
        let mean = |v: &[f64]| v[..n / 2].iter().sum::<f64>() / (n / 2) as f64;
        assert!(mean(&read) - truth > 0.25 * sigma, "as read: {}", (mean(&read) - truth) / sigma);
        let (fixed, c) = uncensored(&rec).expect("a pile at the floor");
        assert!((c.sigma_v / sigma - 1.0).abs() < 0.1, "σ {}", c.sigma_v);
        assert!(c.replaced > n / 6, "{c:?}");
        assert!((mean(&fixed.response) - truth).abs() < 0.1 * sigma, "replaced: {}", (mean(&fixed.response) - truth) / sigma);
        assert_eq!(fixed.response[n / 2..], read[n / 2..]);
        let jittered = Recording { time_s: (0..n).map(|i| i as f64 * 0.01 + if i % 10 == 5 { 0.003 } else { 0.0 }).collect(), ..rec.clone() };
        assert_eq!(uncensored(&jittered).map(|(r, _)| r.response), Some(fixed.response.clone()));
        let high = Recording { response: noise.iter().map(|e| 1.0 + sigma * e).collect(), ..rec.clone() };
        assert!(uncensored(&high).is_none());
        let negative = Recording { response: noise.iter().map(|e| truth + sigma * e).collect(), ..rec.clone() };
        assert!(uncensored(&negative).is_none());
        // on an ADC's grid of half σ (a 10-bit Arduino at 5 V under 10 mV of noise), rounded: a
        // reading of 0 is a value under a quarter σ. Censored at 0 the level came out 0.10 σ low;
        // at half the step, within 0.03 σ, whether the step is given or read off the grid.
        let q = 0.5 * sigma;
        let on_grid: Vec<f64> = noise.iter().enumerate().map(|(i, e)| ((level(i) + sigma * e) / q).round().max(0.0) * q).collect();
        let grid = Recording { response: on_grid.clone(), ..rec.clone() };
        let (fixed, c) = uncensored(&grid).expect("a pile at the floor");
        assert!((c.cut_v - 0.5 * q).abs() < 1e-12, "{c:?}");
        assert!((mean(&fixed.response) - truth).abs() < 0.03 * sigma, "on a grid: {}", (mean(&fixed.response) - truth) / sigma);
        let mut meta = rec.meta.clone();
        (meta.adc_bits, meta.vref_v) = (Some(10), Some(q * 1023.0));
        let given = Recording { meta: meta.clone(), ..grid.clone() };
        assert_eq!(uncensored(&given).map(|(r, _)| r.response), Some(fixed.response.clone()));
        // a step the readings are not on (a gain stage after the ADC): the grid read off the data
        meta.vref_v = Some(0.37 * q * 1023.0);
        let off = Recording { meta, ..grid };
        assert_eq!(uncensored(&off).map(|(r, c)| (r.response, c.cut_v)), Some((fixed.response, 0.5 * q)));
    }

    /// A level's blocks stop at the logged load's changes: a load logged from sample 130 to 370 of
    /// 500, blocks of about 100 samples; changes closer than MIN_BLOCK samples are not cuts.
    #[test]
    fn blocks_do_not_straddle_a_logged_change() {
        let protocol: Vec<f64> = (0..500).map(|i| if (130..370).contains(&i) { 1000.0 } else { 0.0 }).collect();
        let b = blocks(&protocol, 500, 100);
        assert_eq!(b, vec![(0, 130), (130, 250), (250, 370), (370, 500)]);
        assert_eq!(blocks(&[], 250, 100), vec![(0, 125), (125, 250)]);
        assert_eq!(blocks(&[], 50, 100), vec![(0, 50)]);
        // a change one sample in, one before the end, or one every sample is no cut
        let glitch: Vec<f64> = (0..250).map(|i| if i == 0 || i == 249 { 1.0 } else { 0.0 }).collect();
        assert_eq!(blocks(&glitch, 250, 100), vec![(0, 125), (125, 250)]);
        let measured: Vec<f64> = (0..250).map(|i| i as f64).collect();
        assert_eq!(blocks(&measured, 250, 100), vec![(0, 125), (125, 250)]);
    }
}
