//! Issue 16, item 5: one output folder holds one run (a run manifest lists what it wrote; the
//! previous run's outputs it does not write are removed, nothing else is), and `fit --actuator`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tipforge-run-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn tipforge(args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_tipforge")).args(args).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert_eq!(o.status.code(), Some(0), "{args:?}: {text}");
    text
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn listed(out: &Path) -> Vec<String> {
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("tipforge-run.json")).unwrap()).unwrap();
    j["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap().to_string()).collect()
}

#[test]
fn a_fit_or_diagnosis_folder_holds_one_run() {
    let d = dir("one");
    let (a, b) = (d.join("a.csv"), d.join("b.csv"));
    tipforge(&["simulate", "--protocol", "params/protocol-200g.toml", "--seed", "3", "-o", s(&a)]);
    tipforge(&["simulate", "--protocol", "params/protocol-200g.toml", "--seed", "4", "-o", s(&b)]);
    let fit = d.join("fit");
    tipforge(&["fit", s(&a), "--method", "both", "--out", s(&fit)]);
    std::fs::write(fit.join("notes-by-hand.txt"), "mine").unwrap();
    assert!(fit.join("table-paper.md").exists());
    tipforge(&["fit", s(&a), "--method", "lsq", "--out", s(&fit)]);
    assert!(!fit.join("table-paper.md").exists() && !fit.join("table-paper.csv").exists());
    assert!(fit.join("table-lsq.md").exists() && fit.join("notes-by-hand.txt").exists());
    let files = listed(&fit);
    assert!(files.contains(&"table-lsq.md".to_string()) && !files.iter().any(|f| f.contains("paper") || f.contains("by-hand")), "{files:?}");
    for f in &files {
        assert!(fit.join(f).exists(), "{f} listed but absent");
    }

    let diag = d.join("diag");
    tipforge(&["diagnose", s(&a), "--out", s(&diag)]);
    assert!(diag.join("plots").join("a.png").exists() && diag.join("predictions").join("a.csv").exists());
    tipforge(&["diagnose", s(&b), "--out", s(&diag)]);
    assert!(!diag.join("plots").join("a.png").exists() && !diag.join("predictions").join("a.csv").exists());
    assert!(diag.join("plots").join("b.png").exists() && diag.join("predictions").join("b.csv").exists());
    assert!(listed(&diag).contains(&"predictions/b.csv".to_string()));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn fit_with_actuator_excludes_no_handling_spikes() {
    let real = Path::new("../shared/data/real/cbsilicone_v10_Ro.csv");
    if !real.exists() {
        eprintln!("skipped: {} is absent", real.display());
        return;
    }
    let d = dir("actuator");
    let by_hand = tipforge(&["fit", s(real), "--out", s(&d.join("a"))]);
    let machine = tipforge(&["fit", s(real), "--actuator", "--out", s(&d.join("b"))]);
    assert!(!by_hand.contains(" 0 handling spike(s) excluded"), "{by_hand}");
    assert!(machine.contains(" 0 handling spike(s) excluded"), "{machine}");
    // every step of the strip goes 0 → 12: no k or τ against the load to plot (a fashion plot of
    // one load was drawn before, its points on the axis)
    assert!(!d.join("b/plots/fashion.png").exists() && d.join("b/plots/steps-loading.png").exists());
    assert!(!listed(&d.join("b")).iter().any(|f| f.contains("fashion")));
    let _ = std::fs::remove_dir_all(&d);
}
