//! The working rate: a recording sampled far faster than the model's bandwidth is block-averaged
//! to about 100 Hz before anything else (the step model's time constants are ≥ 0.1 s, handling
//! spikes last ≥ 0.1 s: 100 Hz resolves both, and it is the paper's rate). An hour at 1 kHz then
//! costs what an hour at 100 Hz costs. The raw rate, sample count and noise are kept and
//! reported.

use super::preprocess::noise_sigma;
use super::recording::Recording;
use serde::Serialize;

/// Recordings sampled faster than this are block-averaged.
pub const MAX_WORKING_HZ: f64 = 150.0;
/// The rate they are brought to (at most; the block is a whole number of samples).
pub const WORKING_HZ: f64 = 100.0;

/// The recording as it was read, before block averaging.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Raw {
    pub sample_rate_hz: f64,
    pub samples: usize,
    /// Samples per working sample.
    pub block: usize,
    /// Noise σ of the raw samples (first differences, robust).
    pub noise_sigma: f64,
}

/// `rec` at the working rate: unchanged at or below [`MAX_WORKING_HZ`], else block means of
/// time and response over whole blocks of samples, the protocol at each block's last sample.
pub fn to_working_rate(rec: Recording) -> Recording {
    let rate = rec.sample_rate_hz();
    if rate.is_nan() || rate <= MAX_WORKING_HZ || rec.len() < 2 {
        return rec;
    }
    let block = (rate / WORKING_HZ).floor().max(1.0) as usize;
    let raw = Raw { sample_rate_hz: rate, samples: rec.len(), block, noise_sigma: noise_sigma(&rec.response) };
    let mean = |v: &[f64]| v.chunks(block).map(|c| c.iter().sum::<f64>() / c.len() as f64).collect::<Vec<f64>>();
    let time_s = mean(&rec.time_s);
    let response = mean(&rec.response);
    let protocol = rec.protocol.chunks(block).map(|c| c[c.len() - 1]).collect();
    let mut meta = rec.meta;
    meta.sample_rate_hz = meta.sample_rate_hz.map(|r| r / block as f64);
    Recording { meta, time_s, response, protocol, raw: Some(raw), ..rec }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::recording::{Meta, ProtocolKind};

    fn rec(rate: f64, n: usize) -> Recording {
        let t: Vec<f64> = (0..n).map(|i| i as f64 / rate).collect();
        let v: Vec<f64> = t.iter().map(|&x| if x < 1.0 { 0.1 } else { 0.5 }).collect();
        let g: Vec<f64> = t.iter().map(|&x| if x < 1.0 { 0.0 } else { 100.0 }).collect();
        Recording {
            source: "x.csv".into(),
            meta: Meta { sample_rate_hz: Some(rate), ..Meta::default() },
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

    #[test]
    fn a_fast_recording_is_block_averaged_to_the_working_rate() {
        let r = to_working_rate(rec(1000.0, 3000));
        assert_eq!(r.len(), 300);
        assert!((r.sample_rate_hz() - 100.0).abs() < 1e-9);
        assert_eq!(r.raw.as_ref().map(|x| (x.samples, x.block)), Some((3000, 10)));
        assert!((r.time_s[0] - 0.0045).abs() < 1e-12 && (r.response[0] - 0.1).abs() < 1e-12 && (r.response[150] - 0.5).abs() < 1e-12);
        assert_eq!(r.protocol[99], 0.0);
        assert_eq!(r.protocol[100], 100.0);
    }

    #[test]
    fn the_papers_rate_is_left_as_it_is() {
        let r = to_working_rate(rec(100.0, 3000));
        assert_eq!(r.len(), 3000);
        assert!(r.raw.is_none());
    }
}
