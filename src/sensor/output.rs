//! Writing a fit: JSON report, the paper-layout tables, and PNG plots (each step's data with the
//! model, as the paper's Figures 3–5; k and τ against weight, as Figure 6).

use super::analyze::{table, Method, Prepared, Report};
use super::preprocess::Phase;
use crate::export::Staged;
use crate::plot::{self, Chart, Series, PALETTE};
use std::path::Path;

fn phase_name(p: Phase) -> &'static str {
    if p == Phase::Loading {
        "loading"
    } else {
        "unloading"
    }
}

/// Step panels for one phase: every trial's data (points) and its fitted curve (line), against
/// time since the logged step.
pub fn step_charts(report: &Report, prep: &Prepared, phase: Phase) -> Vec<Chart> {
    let mut charts = Vec::new();
    for (g, s) in prep.groups.iter().zip(&report.steps) {
        if s.phase != phase {
            continue;
        }
        let mut series = Vec::new();
        for (i, tr) in g.trials.iter().enumerate() {
            let c = PALETTE[i % PALETTE.len()];
            let x: Vec<f64> = tr.t.iter().map(|t| t - tr.t_log).collect();
            series.push(Series::points(if i == 0 { "data" } else { "" }, x.clone(), tr.v.clone(), c));
            if let Some(f) = &s.lsq {
                let y: Vec<f64> = tr.t.iter().map(|&t| f.model(i, t)).collect();
                series.push(Series::line(if i == 0 { "lsq model" } else { "" }, x, y, [20, 20, 20]));
            }
        }
        if let (Some(p), Some(tr0)) = (&s.paper, g.trials.first()) {
            let st = tr0.t.iter().position(|&t| t >= tr0.t_log).unwrap_or(0);
            let (vi, ti) = (tr0.v[st], tr0.t[st]);
            let x: Vec<f64> = tr0.t[st..].iter().map(|t| t - tr0.t_log).collect();
            let y: Vec<f64> = tr0.t[st..].iter().map(|&t| vi + p.k * p.weight * (1.0 - (-(t - ti) / p.tau_s).exp())).collect();
            series.push(Series::line("paper model", x, y, [214, 39, 40]));
        }
        let title = match &s.lsq {
            Some(f) => format!("{} {}: {} TO {}  K {:.3} TAU {:.2} S", phase_name(phase), s.index + 1, s.before, s.after, f.k, f.tau_s),
            None => format!("{} {}: {} TO {}", phase_name(phase), s.index + 1, s.before, s.after),
        };
        charts.push(Chart { title, x_label: "TIME SINCE LOGGED STEP S".into(), y_label: report.unit.clone(), series, shade: vec![] });
    }
    charts
}

/// k and τ against the load, with the fashion curves (Figure 6).
pub fn fashion_charts(report: &Report) -> Vec<Chart> {
    let load: Vec<_> = report.steps.iter().filter(|s| s.phase == Phase::Loading).collect();
    let w: Vec<f64> = load.iter().map(|s| s.after).collect();
    let mut k_series = vec![Series::points("lsq", w.clone(), load.iter().map(|s| s.lsq.as_ref().map(|f| f.k).unwrap_or(f64::NAN)).collect(), PALETTE[0])];
    let mut t_series = vec![Series::points("lsq", w.clone(), load.iter().map(|s| s.lsq.as_ref().map(|f| f.tau_s).unwrap_or(f64::NAN)).collect(), PALETTE[0])];
    if load.iter().any(|s| s.paper.is_some()) {
        k_series.push(Series::points("paper", w.clone(), load.iter().map(|s| s.paper.as_ref().map(|p| p.k * p.weight).unwrap_or(f64::NAN)).collect(), PALETTE[1]));
        t_series.push(Series::points("paper", w.clone(), load.iter().map(|s| s.paper.as_ref().map(|p| p.tau_s).unwrap_or(f64::NAN)).collect(), PALETTE[1]));
    }
    if let Some(f) = &report.fashion {
        let lo = load.first().map(|s| s.before).unwrap_or(0.0);
        let hi = w.iter().cloned().fold(0.0, f64::max);
        let step = load.first().map(|s| s.after - s.before).unwrap_or(1.0);
        let xs: Vec<f64> = (0..=100).map(|i| lo + step + (hi - lo - step) * i as f64 / 100.0).collect();
        k_series.push(Series::line("power-law fit", xs.clone(), xs.iter().map(|&x| f.k(x - step, x)).collect(), [40, 40, 40]));
        t_series.push(Series::line("linear fit", xs.clone(), xs.iter().map(|&x| f.tau(x)).collect(), [40, 40, 40]));
    }
    vec![
        Chart { title: "STEP GAIN K AGAINST LOAD".into(), x_label: format!("LOAD ({})", report.protocol), y_label: report.unit.clone(), series: k_series, shade: vec![] },
        Chart { title: "TIME CONSTANT AGAINST LOAD".into(), x_label: format!("LOAD ({})", report.protocol), y_label: "S".into(), series: t_series, shade: vec![] },
    ]
}

/// Stages every output of `tipforge fit` under `dir`.
pub fn stage(report: &Report, prep: &Prepared, method: Method, dir: &Path) -> Staged {
    let mut st = Staged::whole_run();
    let mut json = serde_json::to_string_pretty(report).expect("report serialises");
    json.push('\n');
    st.add(dir.join("report.json"), json.into_bytes());
    for (paper, name) in [(false, "lsq"), (true, "paper")] {
        if (paper && method == Method::Lsq) || (!paper && method == Method::Paper) {
            continue;
        }
        let (csv, md) = table(report, paper);
        st.add(dir.join(format!("table-{name}.csv")), csv.into_bytes());
        st.add(dir.join(format!("table-{name}.md")), md.into_bytes());
    }
    for phase in [Phase::Loading, Phase::Unloading] {
        let charts = step_charts(report, prep, phase);
        if !charts.is_empty() {
            st.add(dir.join(format!("plots/steps-{}.png", phase_name(phase))), plot::render(&charts, 3, 520, 340));
        }
    }
    // k and τ against the load need steps to at least two loads (a recording that repeats one
    // step, as a strip on an actuator does, has nothing to plot against the load)
    let mut loads: Vec<f64> = report.steps.iter().filter(|s| s.phase == Phase::Loading).map(|s| s.after).collect();
    loads.sort_by(f64::total_cmp);
    loads.dedup();
    if loads.len() >= 2 {
        st.add(dir.join("plots/fashion.png"), plot::render(&fashion_charts(report), 2, 620, 400));
    }
    st
}
