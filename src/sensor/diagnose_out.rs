//! Writing a diagnosis: diagnosis.json, predictions/<stem>.csv, plots, report.html, and a summary
//! in plain words.

use super::diagnose::{Diagnosis, MIN_DBIC, MIN_TERM_GAIN, MIN_Z};
use crate::export::Staged;
use crate::plot::{self, Chart, Series, PALETTE};
use std::path::Path;

/// Four significant digits (an RMSE in V and one in Ω read alike).
fn sig4(v: f64) -> String {
    crate::sensor::catalogue::sig(v, 4)
}

/// A term's parameters as `name = value` with three significant digits (the JSON keeps every
/// digit).
fn plain_params(params: &serde_json::Value) -> String {
    match params.as_object() {
        Some(m) => m
            .iter()
            .map(|(k, v)| match v.as_f64() {
                Some(x) => format!("{k} = {}", crate::sensor::catalogue::sig3(x)),
                None => format!("{k} = {}", v.as_str().map(str::to_string).unwrap_or_else(|| v.to_string())),
            })
            .collect::<Vec<_>>()
            .join(", "),
        None => params.to_string(),
    }
}

/// The terminal summary: one sentence per finding, then the overall result.
pub fn summary(d: &Diagnosis) -> Vec<String> {
    let u = &d.unit;
    let mut out = Vec::new();
    let which = if d.baseline.model.contains("simulator") { "simulator baseline" } else { "baseline (first-order steps)" };
    out.push(format!("{which}: held-out RMSE {} {u}, fit RMSE {} {u}", sig4(d.baseline.heldout_rmse), sig4(d.baseline.rmse)));
    if d.findings.is_empty() {
        out.push("no physics left out was found: every catalogue term failed to improve held-out prediction".into());
    }
    for f in &d.findings {
        let w = f.windows.first().map(|w| format!(" (e.g. {} {:.1}–{:.1} s)", w.recording, w.start_s, w.end_s)).unwrap_or_default();
        out.push(format!(
            "{} left out [{} confidence]: {}{}{}; term: {}; held-out RMSE {} → {} {u}, ΔBIC {:.0}",
            f.effect,
            f.confidence,
            f.ambiguity.as_ref().map(|a| format!("{a}; ")).unwrap_or_default(),
            f.explanation,
            w,
            plain_params(&f.term.params),
            sig4(f.heldout_rmse_before),
            sig4(f.heldout_rmse_after),
            f.delta_bic
        ));
    }
    if d.unexplained.flag {
        out.push(format!(
            "unexplained structure remains ({} item(s) of evidence in diagnosis.json), e.g. {}",
            d.unexplained.evidence.len(),
            d.unexplained.evidence.first().cloned().unwrap_or_default()
        ));
    }
    for a in &d.advice {
        out.push(format!("advice: {} (protocol: {}; plot: {})", a.sentence, a.protocol_file, a.plot));
    }
    for n in &d.advice_notes {
        out.push(n.clone());
    }
    for n in &d.notes {
        out.push(format!("creep-dominated baseline step: {n}"));
    }
    for n in &d.nuisances {
        out.push(format!(
            "nuisance {} (not a finding): {}; held-out RMSE {} → {} {} (z {:.1})",
            n.name,
            n.explanation,
            sig4(n.heldout_rmse_before),
            sig4(n.heldout_rmse_after),
            d.unit,
            n.z
        ));
    }
    let with: Vec<&str> = d.final_.effects.iter().copied().chain(d.nuisances.iter().map(|n| n.name)).collect();
    let effects = if with.is_empty() { "the baseline alone".to_string() } else { format!("baseline + {}", with.join(" + ")) };
    let change = if d.baseline.heldout_rmse > 0.0 { format!(" ({:+.1} %)", 100.0 * (d.final_.heldout_rmse / d.baseline.heldout_rmse - 1.0)) } else { String::new() };
    let units = if d.final_.effects.is_empty() { String::new() } else { format!(", better on {} of {} held-out units", d.final_.units_better, d.final_.units_scored) };
    out.push(format!("improved model: {effects}; held-out RMSE {} → {} {u}{change}{units}", sig4(d.baseline.heldout_rmse), sig4(d.final_.heldout_rmse)));
    out
}

/// Stages every file of a diagnosis: `diagnosis.json`, the advice's protocols and plots, each
/// recording's predictions and plot, and `report.html`.
pub fn stage(d: &Diagnosis, dir: &Path) -> Staged {
    let mut st = Staged::whole_run();
    let mut json = serde_json::to_string_pretty(d).expect("diagnosis serialises");
    json.push('\n');
    st.add(dir.join("diagnosis.json"), json.into_bytes());
    let advice_html = stage_advice(d, dir, &mut st);
    let imgs = stage_predictions(d, dir, &mut st);
    st.add(dir.join("report.html"), report_html(d, &advice_html, &imgs).into_bytes());
    st
}

/// The advised protocols and their plots; returns the report's advice section.
fn stage_advice(d: &Diagnosis, dir: &Path, st: &mut Staged) -> String {
    let mut advice_html = String::new();
    for a in &d.advice {
        st.add(dir.join(&a.protocol_file), a.protocol_toml.clone().into_bytes());
        st.add(dir.join(&a.plot), plot::render(&advice_charts(d, a), 1, 1100, 360));
        advice_html += &format!("<h3>{} or {}</h3>\n<p>{} (<a href=\"{}\">{}</a>).</p>\n<table><tr><th>protocol change</th><th>length (s)</th><th>separation (noise σ)</th><th>RMS difference</th></tr>\n", a.effect, a.alternative, a.sentence, a.protocol_file, a.protocol_file);
        for c in &a.candidates {
            advice_html += &format!("<tr><td>{}</td><td>{:.0}</td><td>{:.2}</td><td>{}</td></tr>\n", c.change, c.duration_s, c.separation_sigma, sig4(c.rms_difference));
        }
        advice_html += &format!("</table>\n<p><img src=\"{}\" width=\"1100\"></p>\n", a.plot);
    }
    advice_html
}

/// Each recording's predictions (CSV) and plot; returns the plots' paths.
fn stage_predictions(d: &Diagnosis, dir: &Path, st: &mut Staged) -> Vec<String> {
    let mut imgs = Vec::new();
    for p in &d.predictions {
        let mut csv = String::with_capacity(p.time_s.len() * 40);
        if p.stride > 1 {
            csv.push_str(&format!("# every {}-th sample of the recording (at most {} rows)\n", p.stride, super::diagnose::MAX_PREDICTION_ROWS));
        }
        csv.push_str("time_s,measured,baseline,improved\n");
        for i in 0..p.time_s.len() {
            csv.push_str(&format!("{:.4},{:.6},{:.6},{:.6}\n", p.time_s[i], p.measured[i], p.baseline[i], p.improved[i]));
        }
        st.add(dir.join("predictions").join(format!("{}.csv", p.stem)), csv.into_bytes());
        let t = p.time_s.clone();
        let r0: Vec<f64> = p.measured.iter().zip(&p.baseline).map(|(a, b)| a - b).collect();
        let r1: Vec<f64> = p.measured.iter().zip(&p.improved).map(|(a, b)| a - b).collect();
        let charts = vec![
            Chart {
                title: format!("{}: RECORDING AND MODELS", p.stem),
                x_label: "TIME S".into(),
                y_label: d.unit.clone(),
                series: vec![
                    Series::points("measured", t.clone(), p.measured.clone(), [150, 150, 150]),
                    Series::line("baseline", t.clone(), p.baseline.clone(), PALETTE[1]),
                    Series::line("improved", t.clone(), p.improved.clone(), PALETTE[0]),
                ],
                shade: p.windows.clone(),
            },
            Chart {
                title: "RESIDUALS BEFORE (RED) AND AFTER (BLUE)".into(),
                x_label: "TIME S".into(),
                y_label: d.unit.clone(),
                series: vec![Series::line("baseline", t.clone(), r0, PALETTE[1]), Series::line("improved", t, r1, PALETTE[0])],
                shade: p.windows.clone(),
            },
        ];
        let mut charts = charts;
        if !p.contributions.is_empty() {
            let series = p
                .contributions
                .iter()
                .enumerate()
                .map(|(j, (name, c))| Series::line(&contribution_label(d, name), p.time_s.clone(), c.clone(), PALETTE[(j + 2) % PALETTE.len()]))
                .collect();
            charts.push(Chart {
                title: "CONTRIBUTION OF EACH TERM TO THE IMPROVED MODEL".into(),
                x_label: "TIME S".into(),
                y_label: d.unit.clone(),
                series,
                shade: p.windows.clone(),
            });
        }
        let name = format!("plots/{}.png", p.stem);
        st.add(dir.join(&name), plot::render(&charts, 1, 1100, 360));
        imgs.push(name);
    }
    imgs
}

/// `report.html`: the summary, the names the recording cannot separate, the advice, where the
/// baseline fails, the decisions and the plots.
fn report_html(d: &Diagnosis, advice_html: &str, imgs: &[String]) -> String {
    let esc = |s: &str| s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
    let mut html = String::from("<!doctype html><html><head><meta charset=\"utf-8\"><title>tipforge diagnosis</title><style>body{font-family:sans-serif;max-width:1150px;margin:2em auto}td,th{border:1px solid #ccc;padding:4px 8px}table{border-collapse:collapse}</style></head><body>\n<h1>Diagnosis</h1>\n");
    html += &format!("<p>Recordings: {}</p>\n<ul>\n", esc(&d.recordings.join(", ")));
    for l in summary(d) {
        html += &format!("<li>{}</li>\n", esc(&l));
    }
    html += "</ul>\n";
    if d.findings.iter().any(|f| !f.alternatives.is_empty()) {
        html += "<h2>Names the recording cannot separate</h2>\n<p>Each finding's term was dropped and every other catalogue effect put in its place. An alternative explains the same residual held out, and the named model does not predict the held-out units better than it by a paired z of 2. One that predicts them better (a negative z) does so by a gain too small to take the name.</p>\n<table><tr><th>finding</th><th>its held-out RMSE</th><th>alternative</th><th>held-out RMSE in its place</th><th>paired z, named over it</th><th>its gain over the named</th></tr>\n";
        for f in &d.findings {
            for a in &f.alternatives {
                html += &format!(
                    "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.1} %</td></tr>\n",
                    f.effect,
                    sig4(f.heldout_rmse_after),
                    a.effect,
                    sig4(a.heldout_rmse),
                    a.z_named_over_this,
                    100.0 * a.gain_over_named
                );
            }
        }
        html += "</table>\n";
    }
    if !advice_html.is_empty() || !d.advice_notes.is_empty() {
        html += "<h2>What to record next</h2>\n<p>Both names were simulated with the recording's twin (the named term, or the alternative fitted in its place), noise-free, on the recording's own protocol and on protocol changes; the separation is the paired z the held-out test between the two names is expected to reach (each unit's noise as this recording showed it between them, at least the white-noise floor), scaled to the z the recording itself reached.</p>\n";
        html += advice_html;
        for n in &d.advice_notes {
            html += &format!("<p>{}</p>\n", esc(n));
        }
    }
    html += "<h2>Where the baseline fails</h2>\n<p>Each catalogue effect's signature and the whiteness test on the baseline's residuals, before any term is chosen.</p>\n<table><tr><th>test</th><th>recording</th><th>window (s)</th><th>statistic</th></tr>\n";
    for w in &d.located {
        html += &format!("<tr><td>{}</td><td>{}</td><td>{:.1}–{:.1}</td><td>{}</td></tr>\n", w.test, esc(&w.recording), w.start_s, w.end_s, esc(&w.statistic));
    }
    // the rule's numbers from the gate's own constants, so the page cannot drift from the code
    html += &format!("</table>\n<h2>Decisions</h2>\n<p>A term enters when its held-out improvement is more than {} % with a paired z ≥ {MIN_Z} over units and it lowers BIC by at least {}; of those that pass in a round, the one that predicts held-out data best. A kept term leaves (backward) when, given the others, it no longer passes and the others pass without it; the forward rounds then run once more.</p>\n<table><tr><th>step</th><th>stage</th><th>candidate</th><th>held-out RMSE</th><th>gain</th><th>paired z</th><th>ΔBIC</th><th>accepted</th></tr>\n", 100.0 * MIN_TERM_GAIN, -MIN_DBIC);
    for dc in &d.decisions {
        html += &format!(
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+.3}</td><td>{:.2}</td><td>{:.1}</td><td>{}</td></tr>\n",
            dc.step,
            dc.stage,
            dc.candidate,
            sig4(dc.heldout_rmse),
            dc.gain,
            dc.z,
            dc.delta_bic,
            dc.accepted
        );
    }
    html += "</table>\n<h2>Recordings, models and residuals</h2>\n<p>Shaded: windows where the model failed or a finding applies.</p>\n";
    for i in imgs {
        html += &format!("<p><img src=\"{i}\" width=\"1100\"></p>\n");
    }
    html += "</body></html>\n";
    html
}

/// The advice's plot: both names' predictions on the advised protocol, and their difference.
fn advice_charts(d: &Diagnosis, a: &super::advice::Advice) -> Vec<Chart> {
    let [t, _load, va, vb] = &a.curves;
    // at most about 4000 points a line
    let step = (t.len() / 4000).max(1);
    let pick = |v: &[f64]| v.iter().step_by(step).copied().collect::<Vec<f64>>();
    let tt = pick(t);
    let diff: Vec<f64> = va.iter().zip(vb).map(|(x, y)| x - y).collect();
    vec![
        Chart {
            title: format!("ADVISED: {}", a.change.to_uppercase()),
            x_label: "TIME S".into(),
            y_label: d.unit.clone(),
            series: vec![Series::line(a.effect, tt.clone(), pick(va), PALETTE[0]), Series::line(a.alternative, tt.clone(), pick(vb), PALETTE[1])],
            shade: vec![],
        },
        Chart {
            title: format!("DIFFERENCE (EXPECTED PAIRED Z {:.1})", a.separation_sigma),
            x_label: "TIME S".into(),
            y_label: d.unit.clone(),
            series: vec![Series::line("difference", tt, pick(&diff), PALETTE[2])],
            shade: vec![],
        },
    ]
}

/// A term's legend: the finding's name (the spectrum's is the name its shape or closest exact form
/// gives it).
fn contribution_label(d: &Diagnosis, term: &str) -> String {
    if term == "relaxation" {
        let named = d.findings.iter().find(|f| f.term.name == "relaxation_spectrum" || f.term.name == "relaxation_term").map(|f| f.effect).unwrap_or("relaxation");
        format!("{named} (spectrum)")
    } else {
        term.to_string()
    }
}
