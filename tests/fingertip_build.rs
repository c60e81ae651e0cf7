//! Integration: every file in params/ builds into valid parts; rebuilds are byte-identical; the
//! seats are flat and the tessellation is within the chordal tolerance.

use std::path::{Path, PathBuf};
use tipforge::build::{self, Options};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tipforge-test-{}-{}", name, std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn opts(out: &Path) -> Options {
    Options { params_dir: PathBuf::from("params"), out_dir: out.to_path_buf(), only: vec![], preview: false, slice: false }
}

#[test]
fn every_params_file_builds_and_passes_checks() {
    let out = tmp("all");
    let report = build::run(&opts(&out)).expect("default parameters build");
    assert!(report.summaries.iter().any(|s| s.name == "fingertip-1s"));
    assert!(report.summaries.iter().any(|s| s.name == "fingertip-2s"));
    for f in ["fingertip-1s.stl", "fingertip-1s.3mf", "fingertip-2s.stl", "fingertip-2s.3mf", "manifest.json"] {
        let p = out.join(f);
        assert!(p.exists() && std::fs::metadata(&p).unwrap().len() > 100, "{f}");
    }
    let man: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("manifest.json")).unwrap()).unwrap();
    for name in ["fingertip-1s", "fingertip-2s"] {
        let e = &man["parts"][name];
        assert!(e["volume_mm3"].as_f64().unwrap() > 1000.0);
        assert!((e["mass_g"].as_f64().unwrap() - e["volume_mm3"].as_f64().unwrap() * 1.24e-3).abs() < 1e-3);
        assert_eq!(e["source_sha256"].as_str().unwrap().len(), 64);
        assert_eq!(e["genus"].as_i64().unwrap(), 2);
    }
    // no temporaries left behind
    assert!(std::fs::read_dir(&out).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains("tmp-tipforge")));
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn rebuild_is_byte_identical() {
    let (a, b) = (tmp("a"), tmp("b"));
    build::run(&opts(&a)).unwrap();
    build::run(&opts(&b)).unwrap();
    for f in ["fingertip-1s.stl", "fingertip-1s.3mf", "fingertip-2s.stl", "fingertip-2s.3mf", "manifest.json"] {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f} differs between builds");
    }
    let _ = std::fs::remove_dir_all(&a);
    let _ = std::fs::remove_dir_all(&b);
}

#[test]
fn seats_are_flat_planes_at_the_stated_depth() {
    use tipforge::fingertip::{seat, Shape};
    use tipforge::mesh::{dot, sub};
    for file in ["params/fingertip-1s.toml", "params/fingertip-2s.toml"] {
        let src = tipforge::params::read_source(Path::new(file)).unwrap();
        let p = tipforge::fingertip::load(&src, "t", std::path::Path::new("params")).unwrap();
        let part = tipforge::fingertip::build(&p).unwrap();
        let shape = Shape::new(&p.body);
        for s in &p.sensors {
            let st = seat(&shape, s).unwrap();
            // vertices of the part within the flat ring (between pocket and flat rim) lie on the plane
            let n = tipforge::fingertip::to_print(st.normal);
            let c = tipforge::fingertip::to_print(st.flat_center);
            let path = tipforge::fingertip::channel_path(&shape, s);
            let away = tipforge::fingertip::to_print(tipforge::mesh::unit([path[1][0] - path[0][0], path[1][1] - path[0][1], 0.0]));
            let mut on_plane = 0;
            for v in &part.mesh.vertices {
                let d = sub(*v, c);
                let h = dot(d, n);
                let radial = (dot(d, d) - h * h).max(0.0).sqrt();
                if dot(d, away) > 0.2 * radial {
                    continue; // the tail channel leaves the seat this way
                }
                // another sensor's tail channel may open into this seat's rim
                let design = [v[2], v[0], v[1]];
                let in_other_channel = p
                    .sensors
                    .iter()
                    .filter(|o| !std::ptr::eq(*o, s))
                    .any(|o| tipforge::fingertip::path_distance(&tipforge::fingertip::channel_path(&shape, o), [design[0], design[1]]) < o.channel_width_mm / 2.0 + 0.6);
                if in_other_channel {
                    continue;
                }
                if radial > s.seat_diameter_mm / 2.0 * 0.99 && radial < s.flat_diameter_mm / 2.0 * 1.002 {
                    if h.abs() < 1e-6 {
                        on_plane += 1;
                    } else if radial < s.flat_diameter_mm / 2.0 - 0.01 && radial > s.seat_diameter_mm / 2.0 * 1.01 {
                        assert!(h.abs() > 0.1, "{file}: vertex {v:?} is {h} mm off the seat plane inside the flat ring");
                    }
                }
            }
            assert!(on_plane >= 12, "{file}: only {on_plane} vertices on the seat plane");
            // the pocket floor is seat_depth below the plane: some vertex lies there
            let floor = part.mesh.vertices.iter().filter(|v| (dot(sub(**v, c), n) + s.seat_depth_mm).abs() < 1e-6).count();
            assert!(floor >= 3, "{file}: pocket floor not found");
        }
    }
}
