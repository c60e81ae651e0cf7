//! A held-out error is a prediction of data the fit never saw; it can be worse than the fit
//! error, but not by orders of magnitude, and never worse than predicting a constant inside the
//! signal's range. A number breaking either rule comes from a defect (a column with no training
//! data, a singular fold), not from the data, and is never printed as a result.

use super::diagnose::Diagnosis;
use super::recording::Recording;
use crate::error::{Error, Result};

/// How many times the fit error a held-out error may be before it is a defect.
pub const MAX_HELDOUT_OVER_FIT: f64 = 100.0;

/// Every held-out number of the diagnosis, named as the report names it.
fn heldout_numbers(d: &Diagnosis) -> Vec<(String, f64)> {
    let mut v = vec![("baseline held-out RMSE".to_string(), d.baseline.heldout_rmse), ("final held-out RMSE".to_string(), d.final_.heldout_rmse)];
    for f in &d.findings {
        v.push((format!("{} held-out RMSE before", f.effect), f.heldout_rmse_before));
        v.push((format!("{} held-out RMSE after", f.effect), f.heldout_rmse_after));
    }
    for c in &d.decisions {
        v.push((format!("decision {} ({}) held-out RMSE", c.step, c.candidate), c.heldout_rmse));
    }
    v
}

/// The span of the responses (max − min over every recording).
fn signal_range(recs: &[Recording]) -> f64 {
    let (lo, hi) = recs.iter().flat_map(|r| r.response.iter().copied()).filter(|x| x.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// The rule broken by a held-out number, if any.
fn broken(value: f64, fit_rmse: f64, range: f64, unit: &str) -> Option<String> {
    if !value.is_finite() {
        return Some(format!("{value} is not a number"));
    }
    if value > MAX_HELDOUT_OVER_FIT * fit_rmse && value > 1e-12 * range.max(1.0) {
        return Some(format!("{value:.4e} {unit} is over {MAX_HELDOUT_OVER_FIT} × the fit RMSE {fit_rmse:.4e} {unit}"));
    }
    if value > range {
        return Some(format!("{value:.4e} {unit} is beyond the signal's range {range:.4e} {unit}"));
    }
    None
}

/// Checks every held-out number of `d` against the fit error and the signal's range.
pub fn check(d: &Diagnosis, recs: &[Recording]) -> Result<()> {
    let range = signal_range(recs);
    let fit = d.baseline.rmse.max(d.final_.rmse);
    let bad: Vec<String> = heldout_numbers(d).into_iter().filter_map(|(name, v)| broken(v, fit, range, &d.unit).map(|why| format!("{name}: {why}"))).collect();
    if bad.is_empty() {
        Ok(())
    } else {
        Err(Error::Internal { stage: "diagnose (held-out scoring)", message: bad.join("; ") })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sane_heldout_error_passes() {
        assert_eq!(broken(3750.0, 2927.0, 23000.0, "ohm"), None);
        // worse than the fit, still a prediction
        assert_eq!(broken(0.2, 0.01, 4.6, "V"), None);
    }

    #[test]
    fn the_absurd_numbers_of_issue_17_are_refused() {
        // the shared strip recording without --actuator: 3.8e10 ohm on a 35–58 kohm signal
        let why = broken(38_362_365_289.0, 1776.0, 23_000.0, "ohm").unwrap();
        assert!(why.contains("100 × the fit RMSE"), "{why}");
        assert!(broken(f64::NAN, 1.0, 1.0, "V").unwrap().contains("not a number"));
        assert!(broken(f64::INFINITY, 1.0, 1.0, "V").is_some());
    }

    #[test]
    fn beyond_the_range_is_refused_even_near_the_fit_error() {
        let why = broken(5.0, 0.5, 4.6, "V").unwrap();
        assert!(why.contains("signal's range"), "{why}");
    }
}
