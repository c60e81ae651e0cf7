//! Whether recordings can be pooled: the fit pools each protocol step across the recordings by its
//! place in the protocol (loading step 1, 2, …), so the recordings must repeat one protocol; the
//! diagnosis predicts each recording from the others (or, with one recording, each step from the
//! other steps), so every level it predicts must be seen elsewhere. Checked before any fitting,
//! every problem at once.

use super::preprocess::{self, Phase, Step};
use super::recording::Recording;
use crate::error::Problem;
use std::path::{Path, PathBuf};

fn same(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
}

/// Whether any of the steps reaches or leaves level `l`.
fn seen<'a>(mut steps: impl Iterator<Item = &'a Step>, l: f64) -> bool {
    steps.any(|x| same(x.after, l) || same(x.before, l))
}

fn name(s: &Step) -> String {
    let phase = match s.phase {
        Phase::Loading => "loading",
        Phase::Unloading => "unloading",
    };
    format!("{phase} step {}", s.index + 1)
}

/// Every pooling problem of `recs` given as `paths`: those of a fit, and with `diagnose` those of
/// a diagnosis. The steps are segmented once for both.
pub fn problems(paths: &[PathBuf], recs: &[Recording], pre: &preprocess::Options, diagnose: bool) -> Vec<Problem> {
    let steps = steps(recs, pre);
    let paths: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    let unusable = super::usable::problems(recs, &steps);
    if !unusable.is_empty() {
        return unusable;
    }
    let mut out = fit_problems(&paths, recs, &steps);
    if diagnose {
        let protocol_ok = out.is_empty();
        out.extend(diagnose_problems(recs, &steps, protocol_ok));
    }
    out
}

fn steps(recs: &[Recording], pre: &preprocess::Options) -> Vec<Vec<Step>> {
    recs.iter().map(|r| preprocess::segment(r, pre).0).collect()
}

/// Problems with pooling `recs` in a fit: a file given twice, or steps at the same place of the
/// protocol that change the load between different values.
fn fit_problems(paths: &[&Path], recs: &[Recording], steps: &[Vec<Step>]) -> Vec<Problem> {
    let mut out = Vec::new();
    let canon: Vec<_> = paths.iter().map(|p| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())).collect();
    for (i, c) in canon.iter().enumerate() {
        if let Some(j) = canon[..i].iter().position(|d| d == c) {
            out.push(Problem::new(
                &recs[i].source,
                "(file)",
                "given twice",
                format!("the same recording as argument {} would count as two trials: give each recording once", j + 1),
            ));
        }
    }
    let unit = recs.first().map(|r| r.protocol_kind.column()).unwrap_or("load");
    for (i, si) in steps.iter().enumerate().skip(1) {
        for s in si {
            let first = steps[..i].iter().enumerate().find_map(|(j, sj)| sj.iter().find(|x| x.phase == s.phase && x.index == s.index).map(|x| (j, x)));
            if let Some((j, x)) = first {
                if !(same(x.before, s.before) && same(x.after, s.after)) {
                    out.push(Problem::new(
                        &recs[i].source,
                        format!("{} ({unit})", name(s)),
                        format!("{} → {}", s.before, s.after),
                        format!(
                            "{} goes {} → {} in {}: recordings fitted together must repeat one protocol (their steps are pooled by place); fit them separately",
                            name(x),
                            x.before,
                            x.after,
                            recs[j].source
                        ),
                    ));
                    break;
                }
            }
        }
    }
    out
}

/// Problems with diagnosing `recs`, beyond [`fit_problems`] (when those are found, the levels
/// are not looked at: a mismatched protocol explains them): two recordings whose predictions
/// would share a file name, and levels no other data shows — held out, they could only be
/// guessed (leave one recording out: the level in no other recording; one recording: the level
/// in no other step, neither reached nor left). One problem per recording, its levels listed.
fn diagnose_problems(recs: &[Recording], steps: &[Vec<Step>], protocol_ok: bool) -> Vec<Problem> {
    let mut out = Vec::new();
    let stems: Vec<String> = recs.iter().map(|r| Path::new(&r.source).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()).collect();
    for (i, s) in stems.iter().enumerate() {
        if let Some(j) = stems[..i].iter().position(|t| t == s) {
            out.push(Problem::new(
                &recs[i].source,
                "(file name)",
                s,
                format!("{} has the same name: both predictions would be written to predictions/{s}.csv; rename one", recs[j].source),
            ));
        }
    }
    if !protocol_ok {
        return out;
    }
    let unit = recs.first().map(|r| r.protocol_kind.column()).unwrap_or("load");
    for (i, si) in steps.iter().enumerate() {
        let mut unseen: Vec<f64> = Vec::new();
        for (k, s) in si.iter().enumerate() {
            let elsewhere = if recs.len() > 1 {
                seen(steps.iter().enumerate().filter(|(j, _)| *j != i).flat_map(|(_, sj)| sj.iter()), s.after)
            } else {
                seen(si.iter().enumerate().filter(|(q, _)| *q != k).map(|(_, x)| x), s.after)
            };
            if !elsewhere && !unseen.iter().any(|&u| same(u, s.after)) {
                unseen.push(s.after);
            }
        }
        if !unseen.is_empty() {
            let how = if recs.len() > 1 {
                "the diagnosis predicts each recording from the others (leave one out), and no other recording reaches these levels: give recordings that repeat the protocol"
            } else {
                "with one recording the diagnosis predicts each step from the other steps, and no other step reaches or leaves these levels: record the unloading too, or give more recordings of the protocol"
            };
            let list = unseen.iter().map(|l| l.to_string()).collect::<Vec<_>>().join(", ");
            out.push(Problem::new(&recs[i].source, format!("levels ({unit})"), list, how));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor::recording::{Meta, ProtocolKind};

    fn rec(name: &str, levels: &[f64]) -> Recording {
        let n = levels.len() * 1000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let g: Vec<f64> = (0..n).map(|i| levels[i / 1000]).collect();
        Recording {
            source: name.into(),
            meta: Meta::default(),
            time_s: t,
            response: vec![0.0; n],
            unit: "V",
            response_column: "voltage_v",
            protocol: g,
            protocol_kind: ProtocolKind::LoadG,
            ignored_columns: vec![],
            raw: None,
        }
    }

    fn fit_problems(paths: &[&Path], recs: &[Recording], pre: &preprocess::Options) -> Vec<Problem> {
        super::fit_problems(paths, recs, &steps(recs, pre))
    }

    fn diagnose_problems(recs: &[Recording], pre: &preprocess::Options, protocol_ok: bool) -> Vec<Problem> {
        super::diagnose_problems(recs, &steps(recs, pre), protocol_ok)
    }

    fn p<'a>(rs: &[&'a Recording]) -> Vec<&'a Path> {
        rs.iter().map(|r| Path::new(r.source.as_str())).collect()
    }

    #[test]
    fn recordings_of_one_protocol_pool_and_others_do_not() {
        let pre = preprocess::Options::default();
        let a = rec("a/r-1.csv", &[0.0, 200.0, 400.0, 200.0, 0.0]);
        let b = rec("a/r-2.csv", &[0.0, 200.0, 400.0, 200.0, 0.0]);
        let c = rec("a/r-3.csv", &[0.0, 40.0, 80.0, 40.0, 0.0]);
        assert!(fit_problems(&p(&[&a, &b]), &[a.clone(), b.clone()], &pre).is_empty());
        assert!(diagnose_problems(&[a.clone(), b.clone()], &pre, true).is_empty());
        let found = fit_problems(&p(&[&a, &c]), &[a.clone(), c.clone()], &pre);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(found[0].file == "a/r-3.csv" && found[0].path.starts_with("loading step 1") && found[0].message.contains("0 → 200"), "{found:?}");
        // the same file twice would count as two trials
        let found = fit_problems(&p(&[&a, &a]), &[a.clone(), a.clone()], &pre);
        assert!(found.len() == 1 && found[0].value == "given twice", "{found:?}");
        // a shorter recording of the same protocol pools
        let short = rec("a/r-4.csv", &[0.0, 200.0]);
        assert!(fit_problems(&p(&[&a, &short]), &[a.clone(), short.clone()], &pre).is_empty());
        // the same name twice: predictions would collide
        let again = rec("b/r-1.csv", &[0.0, 200.0, 400.0, 200.0, 0.0]);
        let found = diagnose_problems(&[a.clone(), again], &pre, true);
        assert!(found.len() == 1 && found[0].message.contains("predictions/r-1.csv"), "{found:?}");
    }

    #[test]
    fn a_level_no_other_data_shows_cannot_be_held_out() {
        let pre = preprocess::Options::default();
        // one recording: 400 g is reached and left, so every step has data elsewhere
        assert!(diagnose_problems(&[rec("r.csv", &[0.0, 200.0, 400.0, 200.0, 0.0])], &pre, true).is_empty());
        // one step up and the recording ends: the level is seen nowhere else
        let found = diagnose_problems(&[rec("r.csv", &[0.0, 100.0])], &pre, true);
        assert!(found.len() == 1 && found[0].value == "100" && found[0].message.contains("record the unloading"), "{found:?}");
        // several recordings: a level only one of them reaches
        let found = diagnose_problems(&[rec("r-1.csv", &[0.0, 200.0, 0.0]), rec("r-2.csv", &[0.0, 200.0, 600.0, 800.0, 0.0])], &pre, true);
        assert!(found.len() == 1 && found[0].file == "r-2.csv" && found[0].value == "600, 800", "{found:?}");
        // with a mismatched protocol already reported, levels are not listed again
        assert!(diagnose_problems(&[rec("r-1.csv", &[0.0, 200.0, 0.0]), rec("r-2.csv", &[0.0, 600.0, 0.0])], &pre, false).is_empty());
    }
}
