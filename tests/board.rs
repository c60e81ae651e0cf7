//! One sensor definition: fingertips, the rig and (through their fingertip) the molds name one
//! sensor board file and take every sensor size from it, so they cannot disagree (the rig's seat
//! was 12.4 mm while the fingertips' were 9.0 mm).

use std::path::{Path, PathBuf};
use std::process::Command;

fn build(params: &Path, out: &Path) -> (i32, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_tipforge")).args(["build", "--params"]).arg(params).arg("--out").arg(out).args(["fingertip-1s", "rig", "mold-1s"]).output().unwrap();
    (o.status.code().unwrap_or(-1), format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr)))
}

fn copy_params(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tipforge-board-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("params")).unwrap();
    for f in ["fingertip-1s.toml", "rig.toml", "mold-1s.toml", "fsr-8mm.toml"] {
        std::fs::copy(Path::new("params").join(f), d.join("params").join(f)).unwrap();
    }
    d
}

fn sizes(out: &Path) -> (f64, f64, f64, f64, f64) {
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let seat = &m["parts"]["fingertip-1s"]["features"]["seats"][0];
    let rig = &m["parts"]["rig-base"]["features"];
    let dome = &m["molds"]["mold-1s"]["domes_assembled"][0];
    (
        f(&seat["seat_diameter_mm"]),
        f(&rig["seat_diameter_mm"]),
        f(&m["parts"]["rig-plunger"]["features"]["face_diameter_mm"]),
        f(&seat["dome_diameter_mm"]),
        f(&dome["dome_diameter_mm"]),
    )
}

#[test]
fn every_part_takes_the_sensor_from_the_one_board_file() {
    let d = copy_params("one");
    let (code, text) = build(&d.join("params"), &d.join("out"));
    assert_eq!(code, 0, "{text}");
    let (tip_seat, rig_seat, face, tip_dome, mold_dome) = sizes(&d.join("out"));
    // 8.6 mm board + 2 × 0.2 mm clearance in both; the frustum face is the 8 mm sensing area
    assert!((tip_seat - 9.0).abs() < 1e-9 && (rig_seat - 9.0).abs() < 1e-9, "{tip_seat} {rig_seat}");
    assert!((face - 8.0).abs() < 1e-9 && (tip_dome - 8.0).abs() < 1e-9 && (mold_dome - 8.0).abs() < 1e-9);
    // a different sensor: every part follows from the one file
    let board = std::fs::read_to_string(d.join("params/fsr-8mm.toml")).unwrap();
    let other = board
        .replace("board_diameter_mm = 8.6", "board_diameter_mm = 9.2")
        .replace("sensing_diameter_mm = 8.0", "sensing_diameter_mm = 7.0")
        .replace("dome_diameter_mm = 8.0", "dome_diameter_mm = 7.5");
    assert_ne!(other, board);
    std::fs::write(d.join("params/fsr-8mm.toml"), other).unwrap();
    let out2 = d.join("out2");
    let (code, text) = build(&d.join("params"), &out2);
    assert_eq!(code, 0, "{text}");
    let (tip_seat, rig_seat, face, tip_dome, mold_dome) = sizes(&out2);
    assert!((tip_seat - 9.6).abs() < 1e-9 && (rig_seat - 9.6).abs() < 1e-9, "{tip_seat} {rig_seat}");
    assert!((face - 7.0).abs() < 1e-9 && (tip_dome - 7.5).abs() < 1e-9 && (mold_dome - 7.5).abs() < 1e-9);
}

#[test]
fn a_part_without_its_board_or_with_the_old_sizes_is_refused() {
    let d = copy_params("missing");
    let tip = std::fs::read_to_string(d.join("params/fingertip-1s.toml")).unwrap();
    let no_board: String = tip.lines().filter(|l| !l.starts_with("sensor_board")).map(|l| format!("{l}\n")).collect();
    std::fs::write(d.join("params/fingertip-1s.toml"), no_board).unwrap();
    // a seat sized by hand is the old, duplicated definition: not a key any more
    let rig = std::fs::read_to_string(d.join("params/rig.toml")).unwrap();
    std::fs::write(d.join("params/rig.toml"), rig.replace("[base]\n", "[base]\ndisc_diameter_mm = 12.0\n")).unwrap();
    let (code, text) = build(&d.join("params"), &d.join("out"));
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("fingertip-1s.toml") && text.contains("sensor_board = missing") && text.contains("kind = \"sensor_board\""), "{text}");
    assert!(text.contains("base.disc_diameter_mm"), "{text}");
    assert!(!d.join("out").exists());
}
