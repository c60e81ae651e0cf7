//! The hand set: five fingertips from their files with per-finger overrides, and one print plate.

use std::path::{Path, PathBuf};
use std::process::Command;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tipforge-hand-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("params")).unwrap();
    for f in ["fingertip-1s.toml", "fingertip-2s.toml", "fingertip-thumb.toml", "hand.toml", "fsr-8mm.toml"] {
        std::fs::copy(Path::new("params").join(f), d.join("params").join(f)).unwrap();
    }
    d
}

fn build(d: &Path) -> (i32, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_tipforge")).args(["build", "--params"]).arg(d.join("params")).arg("--out").arg(d.join("out")).arg("hand").output().unwrap();
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(!text.contains("panicked"), "{text}");
    (o.status.code().unwrap_or(-1), text)
}

#[test]
fn the_default_hand_builds_five_fingertips_and_a_plate_inside_the_bed() {
    let d = dir("default");
    let (code, text) = build(&d);
    assert_eq!(code, 0, "{text}");
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(d.join("out/manifest.json")).unwrap()).unwrap();
    for f in ["thumb", "index", "middle", "ring", "little"] {
        assert!(m["parts"].get(format!("hand-{f}")).is_some(), "hand-{f}: {}", m["parts"]);
    }
    // the overrides: the ring and little fingertips are shorter (their height on the bed)
    let height = |p: &str| m["parts"][p]["bbox_mm"]["size"][2].as_f64().unwrap();
    assert!((height("hand-middle") - 28.0).abs() < 1e-6 && (height("hand-ring") - 27.0).abs() < 1e-6 && (height("hand-little") - 25.0).abs() < 1e-6);
    // the plate: five printable objects on the build, all inside the bed, none overlapping
    let bytes = std::fs::read(d.join("out/hand-plate.3mf")).unwrap();
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let mut xml = String::new();
    std::io::Read::read_to_string(&mut z.by_name("3D/3dmodel.model").unwrap(), &mut xml).unwrap();
    assert_eq!(xml.matches("<item ").count(), 5);
    assert_eq!(xml.matches("type=\"model\"").count(), 5);
    let bed = m["hands"]["hand"]["bed_mm"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect::<Vec<_>>();
    let mut boxes = Vec::new();
    for obj in xml.split("<object ").skip(1) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in obj.split("<vertex ").skip(1) {
            let num = |k: &str| v.split(&format!("{k}=\"")).nth(1).unwrap().split('"').next().unwrap().parse::<f64>().unwrap();
            let p = [num("x"), num("y"), num("z")];
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        assert!(lo[0] >= 0.0 && lo[1] >= 0.0 && hi[0] <= bed[0] && hi[1] <= bed[1] && lo[2].abs() < 1e-4, "{lo:?} {hi:?} on {bed:?}");
        boxes.push((lo, hi));
    }
    for i in 0..boxes.len() {
        for j in i + 1..boxes.len() {
            let apart = (0..2).any(|k| boxes[i].1[k] <= boxes[j].0[k] || boxes[j].1[k] <= boxes[i].0[k]);
            assert!(apart, "objects {i} and {j} overlap");
        }
    }
}

#[test]
fn overrides_are_checked_by_the_fingertip_rules_and_named_on_the_hand_file() {
    let d = dir("bad");
    let hand = std::fs::read_to_string(d.join("params/hand.toml")).unwrap();
    let bad = hand
        .replace("length_mm = 25.0", "length_mm = -25.0")
        .replace("bed_mm = [250.0, 210.0]", "bed_mm = [60.0, 30.0]")
        .replace("[middle]\nfingertip = \"fingertip-1s.toml\"", "[middle]\nfingertip = \"nowhere.toml\"");
    assert_ne!(bad, hand);
    std::fs::write(d.join("params/hand.toml"), &bad).unwrap();
    let (code, text) = build(&d);
    assert_eq!(code, 2, "{text}");
    let line = bad.lines().position(|l| l.starts_with("length_mm = -25.0")).unwrap() + 1;
    assert!(text.contains(&format!("hand.toml:{line}: little.set.body.length_mm = -25")), "{text}");
    assert!(text.contains("middle.fingertip") && text.contains("nowhere.toml"), "{text}");
    assert!(!d.join("out").exists());
    // with the fingers fixed, the bed is too small: the message says what it needs
    std::fs::write(d.join("params/hand.toml"), hand.replace("bed_mm = [250.0, 210.0]", "bed_mm = [60.0, 30.0]")).unwrap();
    let (code, text) = build(&d);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("bed_mm") && text.contains("need a bed of at least"), "{text}");
}
