//! Property tests: random parameter files. Valid ones build into one closed body of the expected
//! genus that passes every check; invalid ones give input errors naming a path — never a panic.

mod common;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::sync::atomic::Ordering;
use tipforge::error::Error;
use tipforge::params::SourceFile;

#[derive(Debug, Clone)]
struct Gen {
    length: f64,
    width: f64,
    thickness: f64,
    pad_frac: f64,
    r_long: f64,
    tip_frac: f64,
    two: bool,
    pos: [f64; 2],
    lat: f64,
    seat_d: f64,
    #[allow(dead_code)]
    depth: f64,
    flat_extra: f64,
    ch_w: f64,
    ch_d: f64,
    ch_off: f64,
    socket: [f64; 4],
    holes: Vec<[f64; 2]>,
    head: u8,
    tol: f64,
}

fn gen() -> impl Strategy<Value = Gen> {
    (
        (24.0..34.0f64, 14.0..19.0f64, 12.0..17.0f64, 0.33..0.45f64, 25.0..80.0f64, 0.5..0.95f64),
        (any::<bool>(), 6.0..12.0f64, 15.0..20.0f64, -1.0..1.0f64, 7.0..9.5f64, 0.1..0.6f64, 0.2..1.2f64),
        (1.0..3.0f64, 0.2..0.8f64, -0.5..0.5f64),
        (7.0..10.5f64, 3.5..5.0f64, 7.0..11.0f64, 0.0..1.5f64),
        (proptest::collection::vec((4.0..9.0f64, 0.0..1.5f64), 0..3), 0u8..3, 0.005..0.03f64),
    )
        .prop_map(|(b, s, c, m, h)| Gen {
            length: b.0,
            width: b.1,
            thickness: b.2,
            pad_frac: b.3,
            r_long: b.4,
            tip_frac: b.5,
            two: s.0,
            pos: [s.1, s.2],
            lat: s.3,
            seat_d: s.4,
            depth: s.5,
            flat_extra: s.6,
            ch_w: c.0,
            ch_d: c.1,
            ch_off: c.2,
            socket: [m.0, m.1, m.2, m.3],
            holes: h.0.into_iter().map(|(x, z)| [x, z]).collect(),
            head: h.1,
            tol: h.2,
        })
}

fn toml_of(g: &Gen) -> String {
    let pad_depth = g.pad_frac * g.thickness;
    let r_trans = (g.width / 2.0).powi(2) / pad_depth;
    let mut t = format!(
        "kind = \"fingertip\"\nsensor_board = \"fsr-8mm.toml\"\n[body]\nlength_mm = {}\nwidth_mm = {}\nthickness_mm = {}\npad_longitudinal_radius_mm = {}\npad_transverse_radius_mm = {}\ntip_radius_mm = {}\n",
        g.length,
        g.width,
        g.thickness,
        g.r_long,
        r_trans,
        g.tip_frac * pad_depth
    );
    let sensors: Vec<(f64, f64, f64)> =
        if g.two { vec![(g.pos[0], 0.0, g.width * 0.35), (g.pos[1], 0.0, -g.width * 0.35)] } else { vec![(g.pos[0] + 2.0, g.lat, g.lat + g.ch_off)] };
    for (pos, lat, off) in sensors {
        t += &format!(
            "[[sensor]]\nposition_from_tip_mm = {pos}\nlateral_offset_mm = {lat}\nseat_clearance_mm = {}\nflat_diameter_mm = {}\nchannel_clearance_mm = {}\nchannel_depth_mm = {}\nchannel_offset_mm = {off}\n",
            (g.seat_d - 7.0) * 0.2, 8.6 + 2.0 * (g.seat_d - 7.0) * 0.2 + g.flat_extra, if g.two { 0.1 } else { (g.ch_w - 1.4).max(0.0) / 2.0 }, g.ch_d
        );
    }
    let holes: Vec<String> = g.holes.iter().map(|h| format!("[{}, {}]", h[0], h[1])).collect();
    t += &format!(
        "[mount]\nsocket_width_mm = {}\nsocket_height_mm = {}\nsocket_depth_mm = {}\nsocket_center_z_mm = {}\nhole_diameter_mm = 2.4\nholes = [{}]\nhead = \"{}\"\nhead_diameter_mm = 4.0\nhead_depth_mm = 1.0\n",
        g.socket[0], g.socket[1], g.socket[2], g.socket[3], holes.join(", "), ["counterbore", "countersink", "none"][g.head as usize]
    );
    t += &format!("[print]\nmin_wall_mm = 1.2\nchordal_tolerance_mm = {}\n", g.tol);
    t
}

#[test]
fn random_parameter_sets_build_valid_meshes_or_clear_errors() {
    let tally = common::Tally::default();
    let cases: u32 = std::env::var("TIPFORGE_PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(800);
    // a fixed seed: the same parameter sets on every machine, so the count of valid sets is stable
    let mut runner = TestRunner::new_with_rng(Config { cases, failure_persistence: None, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    runner.run(&gen(), |g| check_case(&toml_of(&g), &tally)).unwrap();
    tally.assert_enough("fingertips", cases, 800, 200, 100, 10);
}

/// One generated fingertip file: valid ones build one closed body of the expected genus and pass
/// every check (or only the minimum-feature check refuses them); invalid ones name a path.
fn check_case(text: &str, tally: &common::Tally) -> Result<(), TestCaseError> {
    let src = SourceFile::parse("random.toml", text.to_string()).expect("generated TOML parses");
    match tipforge::fingertip::load(&src, "random", std::path::Path::new("params")) {
        Ok(p) => {
            let part = tipforge::fingertip::build(&p).map_err(|e| TestCaseError::fail(format!("valid params failed to build: {e}\n{text}")))?;
            let v = tipforge::checks::run(&part);
            prop_assert_eq!(part.solid.genus(), 2 * p.mount.holes.len() as i32);
            prop_assert!(part.volume_mm3() > 0.0);
            tally.built(&v, text)?;
        }
        Err(Error::Input(problems)) => {
            common::rejected_clearly(&problems)?;
            tally.invalid.fetch_add(1, Ordering::Relaxed);
        }
        Err(e) => return Err(TestCaseError::fail(format!("unexpected error kind: {e}"))),
    }
    Ok(())
}

#[test]
fn corrupted_files_never_panic() {
    let base = std::fs::read_to_string("params/fingertip-2s.toml").unwrap();
    let mut runner = TestRunner::new_with_rng(Config { cases: 300, failure_persistence: None, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    runner
        .run(&(0usize..base.len(), prop::sample::select(vec!["-", "0", "1e9", "nan", "\"x\"", "[", "=", "\n[[sensor]]\n", ""]), 0usize..40), |(at, ins, del)| {
            let mut t = base.clone();
            let at = (0..=at).rev().find(|&i| t.is_char_boundary(i)).unwrap_or(0);
            let end = (at..=(at + del).min(t.len())).rev().find(|&i| t.is_char_boundary(i)).unwrap_or(at);
            t.replace_range(at..end, ins);
            let r = std::panic::catch_unwind(|| match SourceFile::parse("c.toml", t.clone()) {
                Ok(src) => tipforge::fingertip::load(&src, "c", std::path::Path::new("params")).map(|p| tipforge::fingertip::build(&p).map(|_| ())).map(|_| ()),
                Err(e) => Err(e),
            });
            prop_assert!(r.is_ok(), "panicked on:\n{}", t);
            Ok(())
        })
        .unwrap();
}

/// The anatomical form: random stations (3–5, from a little beyond the mount face to the start of a
/// random rounded end; widths, pad depths and nail heights free, so sections taper, bulge or pinch)
/// on the same random seats and mounts. Valid ones build one closed body of the expected genus that
/// passes every check; the rest are input errors naming a path.
#[test]
fn random_anatomical_sets_build_valid_meshes_or_clear_errors() {
    let tally = common::Tally::default();
    let cases: u32 = std::env::var("TIPFORGE_PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(300);
    // one finger's proportions per case, each station within −15 % … +10 % of them
    let stations = (3usize..6, 4.0..9.0f64, 0.0..3.0f64, (14.0..18.5f64, 4.5..7.0f64, 6.0..9.0f64), proptest::collection::vec((0.85..1.1f64, 0.85..1.1f64, 0.85..1.1f64), 5));
    let mut runner = TestRunner::new_with_rng(Config { cases, failure_persistence: None, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    runner
        .run(&(gen(), stations), |(g, (n, tip, beyond, base, secs))| {
            let capsule = toml_of(&g);
            let a = capsule.find("[body]").unwrap();
            let b = capsule.find("[[sensor]]").unwrap();
            let mut body = format!("[body]\nlength_mm = {}\ntip_length_mm = {tip}\n", g.length);
            for (k, (fw, fp, fh)) in secs.iter().take(n).enumerate() {
                let (w, p, h) = (base.0 * fw, base.1 * fp, base.2 * fh);
                // from a little beyond the mount face down to the start of the rounded end
                let from_tip = g.length + beyond - (g.length + beyond - tip) * k as f64 / (n - 1) as f64;
                body += &format!("[[body.station]]\nfrom_tip_mm = {from_tip}\nwidth_mm = {w}\npad_depth_mm = {p}\nnail_height_mm = {h}\n");
            }
            check_case(&format!("{}{}{}", &capsule[..a], body, &capsule[b..]), &tally)
        })
        .unwrap();
    tally.assert_enough("anatomical fingertips", cases, 300, 40, 25, 10);
}
