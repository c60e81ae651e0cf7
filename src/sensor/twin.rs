//! The calibrated twin (issue 16, item 3): a sensor file `simulate` reads, written from a
//! diagnosis. It carries the read-out circuit (the recording's metadata), the conductance law and
//! the first-order relaxation (fashion curves through the improved model's levels and refitted
//! time constants: G = g1 (L + preload)^n, τ = τ0 + τ1 L, turned into the simulator's force units), the noise, and the found terms with
//! their fitted parameters in the simulator's forms. What the simulator has no form for (a
//! relaxation spectrum, a second relaxation driven by the size of the change, handling spikes) is
//! written as a comment that says so.

use super::analyze::Report;
use super::diagnose::Diagnosis;
use super::fashion::{self, Readout};
use super::recording::{Divider, Recording};
use std::fmt::Write;

/// Newtons per gram of load.
const N_PER_G: f64 = 9.80665e-3;

/// Whether a twin can be written from these recordings at all (checked before diagnosing): the
/// divider's metadata, a voltage, and a load the simulator can apply. The reason otherwise.
pub fn can_write(rec: &Recording) -> Result<(), String> {
    let m = &rec.meta;
    if m.vcc_v.is_none() || m.r_m_ohm.is_none() || m.divider.is_none() {
        return Err(format!("{} has no divider metadata (# vcc_v=, # r_m_ohm=, # divider=): the twin simulates the divider's voltage", rec.source));
    }
    if rec.unit != "V" {
        return Err(format!("the twin simulates a divider voltage; {} is in {}", rec.source, rec.unit));
    }
    if rec.protocol_kind.grams(1.0).is_none() {
        return Err(format!("the twin applies loads; {} logs a unitless input (log load_g or force_n)", rec.source));
    }
    let mut loads: Vec<f64> = rec.protocol.clone();
    loads.sort_by(f64::total_cmp);
    loads.dedup();
    if loads.len() < 3 {
        return Err(format!("the conductance law needs steps to at least three load levels (the fashion curves); {} has {}: record a staircase of loads", rec.source, loads.len()));
    }
    Ok(())
}

/// The sensor file as TOML text, or why it cannot be written (a sentence naming what is missing or
/// which fitted value the simulator would refuse). The text is parsed back as the simulator reads
/// it before it is returned.
pub fn sensor_toml(d: &Diagnosis, report: &Report, rec: &Recording) -> Result<String, String> {
    can_write(rec)?;
    let m = &rec.meta;
    let (Some(vcc), Some(rm), Some(div)) = (m.vcc_v, m.r_m_ohm, m.divider) else { return Err("no divider metadata".into()) };
    // the law from the improved model's first-order part (its levels and time constants are not
    // biased by the effects its terms carry), else from the baseline's steps; loads in grams
    let readout = if div == Divider::SensorHigh { Readout::DividerHigh { vcc_v: vcc, r_m_ohm: rm } } else { Readout::DividerLow { vcc_v: vcc, r_m_ohm: rm } };
    let grams = |l: f64| rec.protocol_kind.grams(l).unwrap_or(f64::NAN);
    let from_model = {
        let lv: Vec<(f64, f64)> = d.final_.levels.iter().map(|p| (grams(p[0]), p[1])).collect();
        let ts: Vec<(f64, f64)> = d.final_.taus.iter().map(|p| (grams(p[0]), p[1])).collect();
        fashion::fit(readout, &lv, &ts)
    };
    let from_steps = || {
        let f = report.fashion.as_ref()?;
        let lv: Vec<(f64, f64)> = f.levels.iter().map(|l| (grams(l.0), l.1)).collect();
        let ts: Vec<(f64, f64)> = f.taus.iter().map(|t| (grams(t.0), t.1)).collect();
        fashion::fit(readout, &lv, &ts)
    };
    let Some(f) = from_model.or_else(from_steps) else {
        return Err("the conductance law needs steps to at least three load levels (the fashion curves): record a staircase of loads".into());
    };
    let f = &f;
    let rate = report.recordings.first().map(|r| r.sample_rate_hz).or(m.sample_rate_hz).unwrap_or(100.0);
    let sigma = noise_before_adc(d, report, m.adc_bits, m.vref_v.unwrap_or(vcc));
    // the law in the simulator's units: force in newtons including the preload
    let g_ref = f.g1 / N_PER_G.powf(f.n);
    // τ against the force (N, the preload included); the simulator takes no negative part
    let at_force: Vec<(f64, f64)> = f.taus.iter().map(|t| ((t.0 + f.preload) * N_PER_G, t.1)).collect();
    let (tau0, tau_per_n) = tau_line_nonneg(&at_force).unwrap_or((f.tau0_s - f.tau1_s_per_unit * f.preload, f.tau1_s_per_unit / N_PER_G));
    let mut t = String::new();
    let _ = writeln!(t, "# tipforge twin: written by `tipforge diagnose --write-sensor` from {}", d.recordings.join(", "));
    let _ = writeln!(t, "# The first-order part is the fashion curves of the improved model's levels and time constants; the effects are the diagnosis's");
    let _ = writeln!(t, "# terms with their fitted parameters. Simulate it on the recording's protocol to compare.");
    let _ = writeln!(t, "kind = \"sensor\"\n\n[circuit]");
    let _ = writeln!(t, "vcc_v = {}\nr_m_ohm = {}\ndivider = \"{}\"", fmt(vcc), fmt(rm), if div == Divider::SensorHigh { "sensor_high" } else { "sensor_low" });
    let _ = writeln!(t, "adc_bits = {}\nvref_v = {}\nsample_rate_hz = {}", m.adc_bits.unwrap_or(16), fmt(m.vref_v.unwrap_or(vcc)), fmt(rate));
    let _ = writeln!(t, "\n[conductance]  # fitted: G = {} S · (F / 1 N)^{}, log-G RMS {}", fmt(g_ref), fmt(f.n), fmt(f.k_log_rms));
    let _ = writeln!(t, "g_ref_s = {}\nexponent = {}", fmt(g_ref), fmt(f.n));
    let _ = writeln!(t, "\n[relaxation]  # fitted: τ = τ0 + τ1 · F, RMS {} s", fmt(f.tau_rms_s));
    let _ = writeln!(t, "tau0_s = {}\ntau_per_n_s = {}", fmt(tau0), fmt(tau_per_n));
    let _ = writeln!(t, "\n[noise]\nsigma_v = {}", fmt(sigma));
    let _ = writeln!(t, "\n[rig]\npreload_g = {}", fmt(f.preload));
    // a share of the conductance's gap between two loads, in the simulator's conductance per
    // newton of the force gap: matched over the whole span, from the top load to no load
    // (G = g_ref F^n; exactly the share when n = 1)
    let force = |g: f64| (g + f.preload) * N_PER_G;
    let top_g = f.levels.iter().map(|l| l.0).fold(0.0, f64::max);
    let (f_lo, f_hi) = (force(0.0), force(top_g));
    let per_newton = if f_hi > f_lo { (f_hi.powf(f.n) - f_lo.powf(f.n)) / (f_hi - f_lo) } else { 1.0 };
    effects(&mut t, d, per_newton);
    // what the simulator would refuse is refused here, with the fitted value named
    let src = crate::params::SourceFile::parse("twin", t.clone()).map_err(|e| format!("the fitted sensor is not a valid sensor file: {e}"))?;
    crate::params::sensor::SensorParams::from_source(&src).map_err(|e| format!("a fitted value is outside what the simulator accepts, so no twin is written: {e}"))?;
    Ok(t)
}

/// The `[effects.*]` tables: every physics finding in the simulator's form, or a comment.
/// `per_newton` turns a share of the conductance's gap into the simulator's conductance per
/// newton of the force gap (over g_ref).
fn effects(t: &mut String, d: &Diagnosis, per_newton: f64) {
    let num = |p: &serde_json::Value, k: &str| p.get(k).and_then(|v| v.as_f64());
    let _ = writeln!(t, "\n# effects found by the diagnosis (all others off)");
    for f in &d.findings {
        let p = &f.term.params;
        if f.term.name == "relaxation_spectrum" {
            let _ = writeln!(t, "# {}: a relaxation spectrum over every change; the simulator has no form for it (not written)", f.effect);
            continue;
        }
        match f.effect {
            "creep" => {
                if let Some(v) = num(p, "per_decade_fraction") {
                    // restarting at every step, or superposed over the load history
                    let superposed = p.get("superposed").and_then(|b| b.as_bool()).unwrap_or(false);
                    let in_conductance = p.get("in_conductance").and_then(|b| b.as_bool()).unwrap_or(false);
                    let _ = writeln!(
                        t,
                        "[effects.creep]\nper_decade = {}\ntime_s = {}\nsuperposed = {superposed}\nin_conductance = {in_conductance}",
                        fmt(v),
                        fmt(num(p, "time_s").unwrap_or(1.0))
                    );
                }
            }
            "hysteresis" => {
                // in the response, or in the conductance (a share of its gap, written per newton)
                let in_conductance = p.get("in_conductance").and_then(|b| b.as_bool()).unwrap_or(false);
                let share = if in_conductance { num(p, "conductance_fraction").map(|a| a * per_newton) } else { num(p, "fraction") };
                if let Some(v) = share {
                    let _ = writeln!(t, "[effects.hysteresis]\nfraction = {}\nin_conductance = {in_conductance}", fmt(v));
                    // a fading memory: the remembered load fades toward the present one, in
                    // the diagnosis as in the simulator
                    if let Some(m) = num(p, "memory_s") {
                        let _ = writeln!(t, "memory_s = {}", fmt(m));
                    }
                }
            }
            "second_time_constant" => match (num(p, "fraction"), num(p, "tau2_s")) {
                (Some(v), Some(tau)) => {
                    let in_conductance = p.get("in_conductance").and_then(|b| b.as_bool()).unwrap_or(false);
                    let _ = writeln!(t, "[effects.second_time_constant]\nfraction = {}\ntau_s = {}\nin_conductance = {in_conductance}", fmt(v), fmt(tau));
                }
                _ => {
                    let _ = writeln!(t, "# second_time_constant driven by the size of the change: the simulator's is a fraction of each step (not written)");
                }
            },
            "baseline_drift" => match (num(p, "rate_per_s"), num(p, "initial_rate_per_s"), num(p, "warmup_tau_s")) {
                (Some(r), _, _) => {
                    let _ = writeln!(t, "[effects.baseline_drift]\nrate_v_per_s = {}", fmt(r));
                }
                (None, Some(r), Some(tau)) => {
                    let _ = writeln!(t, "[effects.baseline_drift]\nrate_v_per_s = {}\nwarmup_tau_s = {}", fmt(r), fmt(tau));
                }
                _ => {}
            },
            "saturation" => {
                if let Some(v) = num(p, "level") {
                    // an amplifier's rail clips before the noise, an ADC's reference after it
                    let before = p.get("before_noise").and_then(|b| b.as_bool()).unwrap_or(false);
                    let _ = writeln!(t, "[effects.saturation]\nlevel_v = {}\nbefore_noise = {before}", fmt(v));
                }
            }
            other => {
                let _ = writeln!(t, "# {other}: not sensor physics, or no simulator form (not written)");
            }
        }
    }
}

/// A number as TOML reads it back exactly (shortest round-trip form, always with a decimal point
/// or exponent so it stays a float).
fn fmt(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The noise the simulator adds before its ADC: the robust spread (1.4826 × MAD) of the raw
/// samples about the improved model, median over the recordings, less the ADC's quantisation
/// (LSB² / 12) when the recording states its bits; the analysis's raw estimate without predictions.
fn noise_before_adc(d: &Diagnosis, report: &Report, bits: Option<u32>, vref: f64) -> f64 {
    use super::preprocess::median;
    let mut per: Vec<f64> = d
        .predictions
        .iter()
        .filter(|p| p.stride == 1 && p.measured.len() > 100)
        .map(|p| {
            let mut r: Vec<f64> = p.measured.iter().zip(&p.improved).map(|(a, b)| a - b).collect();
            let mid = median(&mut r.clone());
            let mut dev: Vec<f64> = r.iter_mut().map(|x| (*x - mid).abs()).collect();
            1.4826 * median(&mut dev)
        })
        .collect();
    let measured = if per.is_empty() { median(&mut report.recordings.iter().map(|r| r.noise_sigma_raw).collect::<Vec<f64>>()) } else { median(&mut per) };
    let q2 = bits.map(|b| (vref / (1u64 << b.min(62)) as f64).powi(2) / 12.0).unwrap_or(0.0);
    (measured * measured - q2).max(0.0).sqrt()
}

/// How many times the median step τ a step's τ may be and still enter the twin's τ line.
const TAU_OUTLIER: f64 = 10.0;

/// The least-squares line τ = τ0 + τ1·F through (force, τ) points with τ0, τ1 ≥ 0 (the simulator's
/// law): the free line when both come out non-negative, else the better of the line through the
/// origin and the constant (a τ that falls with the force, or a line that would cross zero above
/// no force, is held at the nearest law the simulator can run). A step's τ more than
/// [`TAU_OUTLIER`] times the median of them is left out: it is not the first-order rise the law
/// describes (family B's drift case b21: one unloading step's fitted τ of 472 000 s among 0.2–0.5 s
/// made τ1 50 000 s/N, which the simulator refuses, so no twin was written). None without points.
fn tau_line_nonneg(pts: &[(f64, f64)]) -> Option<(f64, f64)> {
    if pts.is_empty() {
        return None;
    }
    let mut taus: Vec<f64> = pts.iter().map(|p| p.1).filter(|t| t.is_finite()).collect();
    let med = crate::sensor::preprocess::median(&mut taus);
    let kept: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1 <= TAU_OUTLIER * med).collect();
    let pts = if kept.len() >= 2 { kept.as_slice() } else { pts };
    let (x, y): (Vec<f64>, Vec<f64>) = pts.iter().copied().unzip();
    let (b, a, _) = fashion::line(&x, &y);
    if a >= 0.0 && b >= 0.0 {
        return Some((a, b));
    }
    let n = pts.len() as f64;
    let (sy, sxx, sxy) = (y.iter().sum::<f64>(), x.iter().map(|v| v * v).sum::<f64>(), x.iter().zip(&y).map(|(u, v)| u * v).sum::<f64>());
    let rss = |a: f64, b: f64| pts.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum::<f64>();
    let constant = ((sy / n).max(0.0), 0.0);
    let through_origin = (0.0, if sxx > 0.0 { (sxy / sxx).max(0.0) } else { 0.0 });
    Some(if rss(through_origin.0, through_origin.1) < rss(constant.0, constant.1) { through_origin } else { constant })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The free line where it is the simulator's law; a τ that falls with the force is held
    /// constant at its mean, and a line that would cross zero above no force goes through the
    /// origin.
    #[test]
    fn the_time_constants_line_keeps_the_simulators_signs() {
        let (a, b) = tau_line_nonneg(&[(1.0, 0.4), (2.0, 0.6), (3.0, 0.8)]).unwrap();
        assert!((a - 0.2).abs() < 1e-12 && (b - 0.2).abs() < 1e-12, "{a} {b}");
        let (a, b) = tau_line_nonneg(&[(1.0, 0.8), (2.0, 0.6), (3.0, 0.4)]).unwrap();
        assert!((a - 0.6).abs() < 1e-12 && b == 0.0, "{a} {b}");
        let (a, b) = tau_line_nonneg(&[(1.0, 0.05), (2.0, 0.6), (3.0, 1.1)]).unwrap();
        assert!(a == 0.0 && b > 0.0 && (b - (0.05 + 1.2 + 3.3) / 14.0).abs() < 1e-12, "{a} {b}");
        assert_eq!(tau_line_nonneg(&[]), None);
        // a step whose fitted τ is not a first-order rise (far above the others) is left out
        let (a, b) = tau_line_nonneg(&[(1.0, 0.4), (2.0, 0.6), (1.5, 4.7e5), (3.0, 0.8)]).unwrap();
        assert!((a - 0.2).abs() < 1e-12 && (b - 0.2).abs() < 1e-12, "{a} {b}");
    }
}
