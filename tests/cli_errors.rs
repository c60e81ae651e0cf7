//! The CLI on bad input: every problem listed with file:line, path, value and fix; exit code 2;
//! nothing written; never a panic.

use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tipforge-cli-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("params")).unwrap();
    // every part file names the sensor board beside it
    std::fs::copy("params/fsr-8mm.toml", d.join("params/fsr-8mm.toml")).unwrap();
    d
}

fn run(d: &Path) -> (i32, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_tipforge")).args(["build", "--params"]).arg(d.join("params")).arg("--out").arg(d.join("out")).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(!text.contains("panicked"), "{text}");
    (o.status.code().unwrap_or(-1), text)
}

/// Writes `text` as the one part file in `d` and builds: exit code 2, `needle` in the message,
/// nothing written.
fn refused_with(d: &Path, text: &str, needle: &str, case: usize) {
    std::fs::write(d.join("params/f.toml"), text).unwrap();
    let (code, out) = run(d);
    assert_eq!(code, 2, "case {case}: {out}");
    assert!(out.contains(needle), "case {case}: expected {needle:?} in\n{out}");
    assert!(!d.join("out").exists());
}

fn default_text() -> String {
    std::fs::read_to_string("params/fingertip-1s.toml").unwrap()
}

#[test]
fn many_problems_are_reported_at_once_with_lines() {
    let d = dir("many");
    let t = default_text()
        .replace("width_mm = 16.0", "width_mm = -16.0")
        .replace("seat_clearance_mm = 0.2", "seat_clearance_mm = -0.2")
        .replace("chordal_tolerance_mm = 0.01", "chordal_tolerance_mm = 0.5")
        .replace("length_mm = 28.0", "lenght_mm = 28.0");
    std::fs::write(d.join("params/f.toml"), &t).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2, "{text}");
    // unknown key first (reported with its suggestion) — it blocks the typed pass
    assert!(text.contains("body.lenght_mm") && text.contains("did you mean `length_mm`"), "{text}");
    assert!(!d.join("out").exists(), "nothing may be written");
    // with the typo fixed, every semantic problem is listed together
    std::fs::write(d.join("params/f.toml"), t.replace("lenght_mm", "length_mm")).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2);
    for needle in ["body.station[0].width_mm = -16", "sensor[0].seat_clearance_mm = -0.2", "print.chordal_tolerance_mm = 0.5", "between 0.001 and 0.05"] {
        assert!(text.contains(needle), "missing {needle:?} in:\n{text}");
    }
    assert!(text.contains("f.toml:") && text.lines().filter(|l| l.contains("f.toml:")).count() >= 3, "{text}");
    assert!(!d.join("out").exists());
}

#[test]
fn anatomical_body_problems_name_the_station() {
    let cases: Vec<(&str, &str, &str)> = vec![
        // a station inside the rounded end
        ("from_tip_mm = 7.0 ", "from_tip_mm = 5.0 ", "body.station[4].from_tip_mm = 5: stations lie before the rounded end"),
        // out of order
        ("from_tip_mm = 14.0 ", "from_tip_mm = 20.0 ", "body.station[2].from_tip_mm = 20: list the stations from the mount face toward the tip"),
        // a capsule field beside the stations
        ("tip_length_mm = 7.0", "tip_length_mm = 7.0\ntip_radius_mm = 4.5", "body.tip_radius_mm = 4.5: remove it"),
        // a blade of a section
        ("width_mm = 15.2", "width_mm = 60.0", "body.station[3].width_mm = 60"),
        // a corner for a tip: refused before it blows the molds' tessellation up
        ("tip_length_mm = 7.0", "tip_length_mm = 0.5", "body.tip_length_mm = 0.5: below 2 mm"),
        // far beyond the mount face
        ("from_tip_mm = 28.0 ", "from_tip_mm = 40.0 ", "body.station[0].from_tip_mm = 40: more than 10 mm beyond the mount face"),
    ];
    for (i, (from, to, needle)) in cases.iter().enumerate() {
        let d = dir(&format!("anat{i}"));
        let t = default_text();
        assert!(t.contains(from), "fixture lacks {from}");
        refused_with(&d, &t.replacen(from, to, 1), needle, i);
    }
}

/// A tail channel beside another seat's pocket leaves a wall of two nozzle widths or opens into the
/// pocket's rim off the sensing area; the old 2s layout (a 0.3 mm wall) is refused with both fixes.
#[test]
fn a_channel_beside_a_pocket_leaves_a_printable_wall_or_opens_into_it() {
    let two = std::fs::read_to_string("params/fingertip-2s.toml").unwrap();
    for (offset, ok) in [("5.0", true), ("5.6", false), ("4.6", false), ("6.2", true)] {
        let d = dir(&format!("chan{offset}"));
        let t = two.replacen("channel_offset_mm = 5.0 ", &format!("channel_offset_mm = {offset} "), 1);
        assert!(t.contains(&format!("channel_offset_mm = {offset} ")));
        std::fs::write(d.join("params/f.toml"), t).unwrap();
        let (code, text) = run(&d);
        if ok {
            // clear of the pocket (6.2 runs off the pad instead: another rule) or open into its rim
            assert!(!text.contains("the tail channel comes"), "{offset}: {text}");
            assert_eq!(code == 0, offset == "5.0", "{offset}: {text}");
        } else {
            assert_eq!(code, 2, "{offset}: {text}");
            assert!(
                text.contains(&format!("sensor[0].channel_offset_mm = {offset}: the tail channel comes"))
                    && text.contains("route it beside")
                    && text.contains("open into the pocket's rim"),
                "{offset}: {text}"
            );
        }
    }
}

/// A station that fails on its own is named by its place in the file, and the others are not
/// blamed for it (the checks between stations wait until every station reads).
#[test]
fn a_bad_station_is_named_by_its_place_in_the_file() {
    let d = dir("station-index");
    let t = default_text().replacen("from_tip_mm = 19.0 ", "from_tip_mm = -1.0 ", 1);
    std::fs::write(d.join("params/f.toml"), t).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("body.station[1].from_tip_mm = -1"), "{text}");
    assert!(!text.contains("body.station[2]") && !text.contains("body.station[3]") && !text.contains("body.station[4]"), "{text}");
}

#[test]
fn syntax_error_names_line_and_column() {
    let d = dir("syntax");
    std::fs::write(d.join("params/f.toml"), default_text().replace("width_mm = 16.0", "width_mm = = 16.0")).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2);
    assert!(text.contains("f.toml:") && text.contains("TOML syntax"), "{text}");
}

#[test]
fn geometric_rules_name_the_offending_key() {
    let cases: Vec<(&str, &str, &str)> = vec![
        ("[[sensor]]", "", "1 or 2 sensors"),
        ("position_from_tip_mm = 9.0", "position_from_tip_mm = 27.0", "sensor[0].position_from_tip_mm"),
        ("lateral_offset_mm = 0.0", "lateral_offset_mm = 5.0", "flat region"),
        ("seat_clearance_mm = 0.2", "seat_clearance_mm = 0.9", "the flat region must be at least the seat diameter 10.4 mm (the board's diameter + 2 × seat_clearance_mm)"),
        ("holes = [[5.0, 1.3]]", "holes = [[5.0, 1.3], [7.0, 1.3]]", "too close to hole 0"),
        ("holes = [[5.0, 1.3]]", "holes = [[12.0, 1.3]]", "must pass through the socket"),
        ("socket_width_mm = 10.0", "socket_width_mm = 15.0", "mount.socket_width_mm"),
        ("head_sink_mm = 0.1", "head_sink_mm = 1.5", "mount.screw = \"ISO 7045 M2\": hole 0: the head recess leaves"),
        ("ISO 7045 M2", "DIN 912 M2", "mount.screw = \"DIN 912 M2\": hole 0: the head recess leaves 0.80 mm"),
        ("ISO 7045 M2", "ISO 7045 M7", "no size \"M7\" in the table of ISO 7045"),
        ("screw = ", "hole_diameter_mm = 2.4\nscrew = ", "remove it: `mount.screw"),
        ("channel_offset_mm = 0.0", "channel_offset_mm = 7.0", "runs off the pad"),
    ];
    for (i, (from, to, needle)) in cases.iter().enumerate() {
        let d = dir(&format!("geo{i}"));
        let mut t = default_text();
        if to.is_empty() {
            // remove the sensor table entirely
            let a = t.find("[[sensor]]").unwrap();
            let b = t.find("\n[mount]").unwrap();
            t.replace_range(a..b, "");
        } else {
            assert!(t.contains(from), "fixture lacks {from}");
            t = t.replacen(from, to, 1);
        }
        refused_with(&d, &t, needle, i);
    }
}

#[test]
fn failed_build_leaves_previous_output_untouched() {
    let d = dir("keep");
    std::fs::write(d.join("params/f.toml"), default_text()).unwrap();
    let (code, _) = run(&d);
    assert_eq!(code, 0);
    let before = std::fs::read(d.join("out/f.stl")).unwrap();
    std::fs::write(d.join("params/f.toml"), default_text().replace("width_mm = 16.0", "width_mm = 0")).unwrap();
    let (code, _) = run(&d);
    assert_eq!(code, 2);
    assert_eq!(std::fs::read(d.join("out/f.stl")).unwrap(), before);
}

#[test]
fn missing_kind_and_unknown_kind_are_input_errors() {
    let d = dir("kind");
    std::fs::write(d.join("params/a.toml"), default_text().replace("kind = \"fingertip\"", "")).unwrap();
    std::fs::write(d.join("params/b.toml"), default_text().replace("kind = \"fingertip\"", "kind = \"fingertop\"")).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2);
    assert!(text.contains("a.toml") && text.contains("add a top-level `kind"), "{text}");
    assert!(text.contains("b.toml") && text.contains("unknown kind"), "{text}");
}

#[test]
fn rig_rules_name_the_offending_key() {
    let base = std::fs::read_to_string("params/rig.toml").unwrap();
    let cases = [
        ("frustum_top_diameter_mm = 14.0", "face_diameter_mm = 9.0\nfrustum_top_diameter_mm = 14.0", "plunger.face_diameter_mm"),
        ("\nclearance_mm = 0.3", "\nclearance_mm = 0.05", "does not print reliably"),
        ("plate_diameter_mm = 60.0", "plate_diameter_mm = 30.0", "must carry the weights"),
        ("stem_length_mm = 24.0", "stem_length_mm = 2.0", "cannot hold the plunger vertical"),
        ("max_load_g = 1000.0 ", "stop_gap_mm = 1.5\nmax_load_g = 1000.0 ", "overtravel stop"),
        (
            "height_mm = 8.0",
            "height_mm = 8.1",
            "base.height_mm = 8.1: is not a whole number of 0.2 mm layers (print.layer_height_mm), so it would print as 8 or 8.2 mm: use 8 or 8.2",
        ),
    ];
    // all at once: every problem in one run
    let d = dir("rig-all");
    let mut all = base.clone();
    for (from, to, _) in &cases {
        assert!(all.contains(from), "fixture lacks {from}");
        all = all.replacen(from, to, 1);
    }
    std::fs::write(d.join("params/rig.toml"), all).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2, "{text}");
    for (_, _, needle) in &cases {
        assert!(text.contains(needle), "expected {needle:?} in\n{text}");
    }
    assert!(!d.join("out").exists());
}

/// The stop gap follows from the dome's stiffness and the top load: computed with a margin, or, when
/// given, refused below the dome's compression (the stop would carry load) or at the dome's height.
#[test]
fn the_stop_gap_follows_from_stiffness_and_top_load() {
    let base = std::fs::read_to_string("params/rig.toml").unwrap();
    let cases = [
        ("max_load_g = 1000.0 ", "max_load_g = 5000.0 ", "the dome is too soft for this load"),
        ("max_load_g = 1000.0 ", "stop_gap_mm = 0.3\nmax_load_g = 1000.0 ", "the stop would carry part of the load; use at least 0.50 mm"),
        ("dome_stiffness_n_per_mm = 20.0", "dome_stiffness_n_per_mm = 8.0", "the dome is too soft for this load"),
    ];
    let board = std::fs::read_to_string("params/fsr-8mm.toml").unwrap();
    for (i, (from, to, needle)) in cases.iter().enumerate() {
        let d = dir(&format!("stop{i}"));
        // the stiffness is the sensor board's
        let (file, text) = if from.starts_with("dome_stiffness") { ("params/fsr-8mm.toml", &board) } else { ("params/rig.toml", &base) };
        assert!(text.contains(from), "fixture lacks {from}");
        std::fs::write(d.join("params/rig.toml"), &base).unwrap();
        std::fs::write(d.join(file), text.replacen(from, to, 1)).unwrap();
        let (code, text) = run(&d);
        assert_eq!(code, 2, "{text}");
        assert!(text.contains(needle) && text.contains("plunger.stop_gap_mm"), "case {i}: expected {needle:?} in\n{text}");
    }
    // the default: the top load's compression (10.0 N at 20 N/mm = 0.50 mm) plus the 0.2 mm margin
    let d = dir("stop-default");
    std::fs::write(d.join("params/rig.toml"), &base).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 0, "{text}");
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("out/manifest.json")).unwrap()).unwrap();
    let r = &m["rigs"]["rig"];
    let (gap, comp, n) = (r["stop_gap_mm"].as_f64().unwrap(), r["dome_compression_at_top_load_mm"].as_f64().unwrap(), r["top_load_n"].as_f64().unwrap());
    assert!((n - 10.01).abs() < 0.02 && (comp - n / 20.0).abs() < 1e-9 && (gap - comp - 0.2).abs() < 1e-9, "{r}");
}

fn tipforge(args: &[&str]) -> (i32, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_tipforge")).args(args).output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(!text.contains("panicked"), "{text}");
    (o.status.code().unwrap_or(-1), text)
}

#[test]
fn fit_reports_every_bad_file_with_line_and_exit_2() {
    let d = dir("fitbad");
    let a = d.join("a.csv");
    let b = d.join("b.csv");
    std::fs::write(&a, "time_s,voltage_v,load_g\n0,0.1,0\n0.01,x,0\n").unwrap();
    std::fs::write(&b, "time_s,voltage_v\n0,0.1\n").unwrap();
    let out = d.join("fit");
    let (code, text) = tipforge(&["fit", a.to_str().unwrap(), b.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("a.csv:3: voltage_v = \"x\": not a number"), "{text}");
    assert!(text.contains("b.csv:1:") && text.contains("protocol column"), "{text}");
    assert!(!out.exists());
    let (code, text) = tipforge(&["fit", d.join("missing.csv").to_str().unwrap()]);
    assert_eq!(code, 2, "{text}");
    let (code, _) = tipforge(&["fit", a.to_str().unwrap(), "--method", "magic"]);
    assert_eq!(code, 2);
}

#[test]
fn simulate_then_fit_end_to_end() {
    let d = dir("simfit");
    let rec = d.join("rec.csv");
    let (code, text) = tipforge(&["simulate", "--trials", "2", "--seed", "5", "-o", rec.to_str().unwrap()]);
    assert_eq!(code, 0, "{text}");
    for f in ["rec-1.csv", "rec-2.csv", "truth/rec-1.json", "truth/rec-2.csv"] {
        assert!(d.join(f).exists(), "{f}");
    }
    // same seed, same bytes
    let again = d.join("again.csv");
    tipforge(&["simulate", "--trials", "2", "--seed", "5", "-o", again.to_str().unwrap()]);
    let strip = |p: &Path| std::fs::read_to_string(p).unwrap().lines().skip(1).collect::<Vec<_>>().join("\n");
    assert_eq!(strip(&d.join("rec-1.csv")), strip(&d.join("again-1.csv")));
    let out = d.join("fit");
    let (code, text) = tipforge(&["fit", d.join("rec-1.csv").to_str().unwrap(), d.join("rec-2.csv").to_str().unwrap(), "--method", "both", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{text}");
    for f in ["report.json", "table-lsq.csv", "table-lsq.md", "table-paper.md", "plots/steps-loading.png", "plots/steps-unloading.png", "plots/fashion.png"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["steps"].as_array().unwrap().len(), 10);
    assert!(text.contains("fashion: conductance"), "{text}");
    // bad simulator parameters: every problem, exit 2
    let bad = d.join("bad.toml");
    std::fs::write(&bad, "kind = \"sensor\"\n[noise]\nsigma_v = -1\n[conductance]\nexponnent = 1\n").unwrap();
    let (code, text) = tipforge(&["simulate", "--sensor", bad.to_str().unwrap(), "-o", d.join("x.csv").to_str().unwrap()]);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("conductance.exponnent") && text.contains("did you mean `exponent`"), "{text}");
}

#[test]
fn shared_real_recording_fits() {
    let path = Path::new("../shared/data/real/cbsilicone_v10_Ro.csv");
    if !path.exists() {
        eprintln!("skipped: {} is absent", path.display());
        return;
    }
    let d = dir("real");
    let out = d.join("fit");
    let (code, text) = tipforge(&["fit", path.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("protocol glitch") || text.contains("note:"), "{text}");
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    assert!(report["steps"].as_array().unwrap().len() >= 8, "{text}");
}

#[test]
fn a_part_name_cannot_leave_the_output_folder() {
    for (file, base) in [("r.toml", "params/rig.toml"), ("f.toml", "params/fingertip-1s.toml")] {
        let d = dir(&format!("name-{file}"));
        let text = std::fs::read_to_string(base).unwrap().replacen("\n[", "\nname = \"../escaped\"\n[", 1);
        std::fs::write(d.join("params").join(file), text).unwrap();
        let (code, out) = run(&d);
        assert_eq!(code, 2, "{out}");
        assert!(out.contains("name = \"../escaped\""), "{out}");
        assert!(!d.join("escaped.stl").exists() && !d.join("out").exists());
    }
}

/// Paths given on the command line that cannot be used are input problems (exit 2) naming the
/// option and the fix, found before any work; nothing is written.
#[test]
fn unusable_paths_on_the_command_line_are_input_errors() {
    let d = dir("paths");
    let file = d.join("afile");
    std::fs::write(&file, "x").unwrap();
    let (f, sub) = (file.to_str().unwrap().to_string(), file.join("sub").to_str().unwrap().to_string());
    let missing = d.join("missing.toml").to_str().unwrap().to_string();
    let rec = d.join("rec.csv");
    let rec_s = rec.to_str().unwrap().to_string();
    let (code, text) = tipforge(&["simulate", "--seed", "3", "-o", &rec_s]);
    assert_eq!(code, 0, "{text}");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["build", "--out", &f], "--out"),
        (vec!["build", "--out", &sub], "is a file"),
        (vec!["diagnose", &rec_s, "--out", &f], "give --out a folder"),
        (vec!["fit", &rec_s, "--out", &sub], "--out"),
        (vec!["simulate", "-o", &sub], "give -o a file name"),
        (vec!["simulate", "-o", d.to_str().unwrap()], "is a folder"),
        (vec!["simulate", "--sensor", &missing, "-o", "x.csv"], "check the path given to --sensor"),
        (vec!["simulate", "--cover", &missing, "-o", "x.csv"], "check the path given to --cover"),
        (vec!["simulate", "--rig", &missing, "-o", "x.csv"], "check the path given to --rig"),
        (vec!["diagnose", &rec_s, "--sensor", &missing, "--out", &sub], "--sensor"),
        (vec!["diagnose", &rec_s, "--sensor", &missing, "--out", &sub], "2 problem(s)"),
        (vec!["simulate", "--sensor", &missing, "-o", &sub], "2 problem(s)"),
        (vec!["build", "fingertip-1x", "--out", &f], "2 problem(s)"),
        (vec!["build", "--params", &missing], "give --params the folder"),
        (vec!["build", "fingertip-1x"], "did you mean `fingertip-1s`?"),
        (vec!["build", "sensor"], "not a part file"),
        (vec!["simulate", "--trials", "0", "-o", "x.csv"], "--trials = 0"),
        (vec!["diagnose", &rec_s, "--rig", &missing], "--sensor"),
    ];
    for (args, needle) in cases {
        let (code, text) = tipforge(&args);
        assert_eq!(code, 2, "{args:?}: {text}");
        assert!(text.contains(needle), "{args:?}: missing {needle:?} in:\n{text}");
        assert!(!text.contains("os error 2): No such file"), "{args:?}: the I/O message is repeated:\n{text}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    assert!(!Path::new("x.csv").exists());
}

/// Building some parts keeps the other parts' manifest entries, byte for byte.
#[test]
fn building_some_parts_keeps_the_manifest_of_the_others() {
    let d = dir("subset");
    for f in ["fingertip-1s", "rig", "sensor"] {
        std::fs::copy(format!("params/{f}.toml"), d.join(format!("params/{f}.toml"))).unwrap();
    }
    let (p, o) = (d.join("params"), d.join("out"));
    let (p, o) = (p.to_str().unwrap(), o.to_str().unwrap());
    let (code, text) = tipforge(&["build", "--params", p, "--out", o]);
    assert_eq!(code, 0, "{text}");
    let full = std::fs::read(d.join("out/manifest.json")).unwrap();
    let (code, text) = tipforge(&["build", "--params", p, "--out", o, "fingertip-1s"]);
    assert_eq!(code, 0, "{text}");
    let after = std::fs::read(d.join("out/manifest.json")).unwrap();
    assert!(full == after, "the manifest changed:\n{}", String::from_utf8_lossy(&after));
    let v: serde_json::Value = serde_json::from_slice(&after).unwrap();
    assert!(v["parts"].get("rig-plunger").is_some() && v["rigs"].as_object().is_some_and(|r| !r.is_empty()), "{v}");
}

/// Recordings that cannot be pooled or held out: input errors before any fitting, nothing written.
#[test]
fn recordings_that_cannot_be_pooled_are_input_errors() {
    let d = dir("pool");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (a, b) = (d.join("a/r.csv"), d.join("b/r.csv"));
    let c = d.join("p200.csv");
    assert_eq!(tipforge(&["simulate", "--seed", "3", "-o", &s(&a)]).0, 0);
    assert_eq!(tipforge(&["simulate", "--seed", "4", "-o", &s(&b)]).0, 0);
    assert_eq!(tipforge(&["simulate", "--seed", "5", "--protocol", "params/protocol-200g.toml", "-o", &s(&c)]).0, 0);
    let one = d.join("one-step.csv");
    let rows: String = (0..2000)
        .map(|i| format!("{:.2},{:.4},{}\n", i as f64 * 0.01, if i >= 500 { 0.5 } else { 0.0 } + 0.001 * ((i * 37 % 11) as f64 - 5.0), if i >= 500 { 100 } else { 0 }))
        .collect();
    std::fs::write(&one, format!("time_s,voltage_v,load_g\n{rows}")).unwrap();
    let out = s(&d.join("diag"));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["fit".into(), s(&a), s(&c), "--out".into(), out.clone()], "must repeat one protocol"),
        (vec!["diagnose".into(), s(&a), s(&c), "--out".into(), out.clone()], "loading step 1 goes 0 → 200"),
        (vec!["fit".into(), s(&a), s(&a), "--out".into(), out.clone()], "given twice"),
        (vec!["diagnose".into(), s(&a), s(&b), "--out".into(), out.clone()], "predictions/r.csv"),
        (vec!["diagnose".into(), s(&one), "--out".into(), out.clone()], "record the unloading too"),
    ];
    for (args, needle) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, text) = tipforge(&args);
        assert_eq!(code, 2, "{args:?}: {text}");
        assert!(text.contains(needle), "{args:?}: missing {needle:?} in:\n{text}");
        assert!(!d.join("diag").exists(), "{args:?} wrote output");
    }
    // one protocol at a time is fine
    let (code, text) = tipforge(&["diagnose", &s(&a), "--out", &out]);
    assert_eq!(code, 0, "{text}");
    assert!(d.join("diag/predictions/r.csv").exists());
}

#[test]
fn a_reader_that_stops_early_is_no_panic() {
    // `tipforge build | head -1`: the summary is printed after the files are written; a closed
    // pipe used to panic in println! (exit 101). The read end is closed before the child has
    // done its work, so its first line meets a closed pipe.
    let d = dir("pipe");
    std::fs::write(d.join("params/fingertip-1s.toml"), default_text()).unwrap();
    let mut c = Command::new(env!("CARGO_BIN_EXE_tipforge"))
        .args(["build", "--params"])
        .arg(d.join("params"))
        .arg("--out")
        .arg(d.join("out"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(c.stdout.take());
    let o = c.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(d.join("out/fingertip-1s.stl").exists());
}

/// `build` takes paths as well as stems; a mold's fingertip is read from the mold file's folder.
#[test]
fn build_takes_paths_as_well_as_stems() {
    let d = dir("paths");
    let lab = d.join("lab");
    std::fs::create_dir_all(&lab).unwrap();
    std::fs::copy("params/fingertip-1s.toml", lab.join("my-finger.toml")).unwrap();
    std::fs::copy("params/fsr-8mm.toml", lab.join("fsr-8mm.toml")).unwrap();
    std::fs::write(lab.join("my-mold.toml"), std::fs::read_to_string("params/mold-1s.toml").unwrap().replace("fingertip-1s.toml", "my-finger.toml")).unwrap();
    let o = d.join("out");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (code, text) = tipforge(&["build", "--out", &s(&o), "params/rig.toml", &s(&lab.join("my-finger.toml")), &s(&lab.join("my-mold.toml"))]);
    assert_eq!(code, 0, "{text}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(o.join("manifest.json")).unwrap()).unwrap();
    for part in ["rig-base", "my-finger", "my-mold-core", "my-mold-shell", "my-mold-cover"] {
        assert!(v["parts"].get(part).is_some(), "{part} missing: {}", v["parts"]);
    }
    // a stem and a path that do not exist: both named, exit 2, nothing written
    let o2 = d.join("out2");
    let (code, text) = tipforge(&["build", "--out", &s(&o2), "fingertip-1z", "../nowhere/f.toml"]);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("did you mean `fingertip-1s`") && text.contains("no such file: ../nowhere/f.toml"), "{text}");
    assert!(!o2.exists());
}

/// A cover that runs over the screws' head recesses is refused by the mold's rules, with the way out.
#[test]
fn a_cover_over_a_screw_recess_is_refused() {
    let d = dir("recess");
    let ft = std::fs::read_to_string("params/fingertip-2s.toml").unwrap();
    assert!(ft.contains("holes = [[5.0, 1.3]]"), "fixture: fingertip-2s hole at z = 1.3");
    std::fs::write(d.join("params/fingertip-2s.toml"), ft.replace("holes = [[5.0, 1.3]]", "holes = [[5.0, 1.0]]")).unwrap();
    // the cover's edge 1 mm below the mid-plane (the default is 2 mm, below the recesses)
    let mold = std::fs::read_to_string("params/mold-2s.toml").unwrap();
    assert!(mold.contains("parting_below_midplane_mm = 2.0 "), "fixture: mold-2s parting at 2.0");
    std::fs::write(d.join("params/mold-2s.toml"), mold.replace("parting_below_midplane_mm = 2.0 ", "parting_below_midplane_mm = 1.0 ")).unwrap();
    let (code, text) = run(&d);
    assert_eq!(code, 2, "{text}");
    let line = 1 + mold.lines().position(|l| l.starts_with("from_tip_mm")).unwrap();
    assert!(
        text.contains(&format!("mold-2s.toml:{line}: cover.from_tip_mm"))
            && text.contains("runs over the head recess of the fingertip's hole 0")
            && text.contains("raise the hole to z ≥ 1.30"),
        "{text}"
    );
}
