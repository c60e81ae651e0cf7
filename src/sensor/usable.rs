//! Whether a recording can be fitted at all: it must change its load at least once and its
//! response must move. A recording that cannot is the user's input problem, named before any
//! fitting, so no table ever shows a NaN or a k of 0 ± NaN.

use super::preprocess::Step;
use super::recording::Recording;
use crate::error::Problem;

/// Fewest samples a recording needs: a step needs samples before and after it.
pub const MIN_SAMPLES: usize = 10;

/// The problems of each recording that make it unusable; `steps[i]` are recording i's steps.
pub fn problems(recs: &[Recording], steps: &[Vec<Step>]) -> Vec<Problem> {
    let mut out = Vec::new();
    for (r, s) in recs.iter().zip(steps) {
        if r.len() < MIN_SAMPLES {
            out.push(Problem::new(
                &r.source,
                "(rows)",
                r.len(),
                format!("a recording needs at least {MIN_SAMPLES} samples, with the load changed at least once; record the whole trial"),
            ));
            continue;
        }
        if s.is_empty() {
            let col = r.protocol_kind.column();
            out.push(Problem::new(
                &r.source,
                col,
                format!("{} throughout", r.protocol[0]),
                format!("the {col} column never changes: a fit needs at least one step of the load; check that the column logs the load"),
            ));
        }
        let (lo, hi) = r.response.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
            out.push(Problem::new(
                &r.source,
                r.response_column,
                format!("{lo} throughout"),
                "the response never changes: the sensor was not read (check the wiring and that the column is the sensor's reading)",
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::preprocess::{segment, Options};
    use crate::sensor::recording::parse;

    fn check(csv: &str) -> Vec<Problem> {
        let r = parse("r.csv", csv.as_bytes()).unwrap();
        let steps = vec![segment(&r, &Options::default()).0];
        problems(&[r], &steps)
    }

    fn series(f: impl Fn(usize) -> (f64, f64)) -> String {
        let mut s = String::from("time_s,voltage_v,load_g\n");
        for i in 0..400 {
            let (v, g) = f(i);
            s += &format!("{},{v},{g}\n", i as f64 * 0.01);
        }
        s
    }

    #[test]
    fn one_row_no_step_and_a_flat_response_are_named() {
        let p = check("time_s,voltage_v,load_g\n0,0.1,0\n");
        assert!(p.len() == 1 && p[0].message.contains("at least 10 samples"), "{p:?}");
        let p = check(&series(|i| (0.1 + 0.001 * (i % 3) as f64, 0.0)));
        assert!(p.len() == 1 && p[0].message.contains("never changes: a fit needs at least one step"), "{p:?}");
        let p = check(&series(|i| (1.0, if i > 200 { 100.0 } else { 0.0 })));
        assert!(p.len() == 1 && p[0].message.contains("the response never changes"), "{p:?}");
        let p = check(&series(|i| (if i > 200 { 1.0 } else { 0.5 }, if i > 200 { 100.0 } else { 0.0 })));
        assert!(p.is_empty(), "{p:?}");
    }
}
