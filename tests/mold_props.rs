//! Property test: random mold parameter files over both fingertips. Each is either rejected with
//! input errors that name their keys, or builds into pieces and a cover that pass every
//! assembled-mold check and every mesh check — never a geometry error, never a panic.

mod common;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::path::Path;
use std::sync::atomic::Ordering;
use tipforge::error::Error;
use tipforge::params::SourceFile;

#[derive(Debug, Clone)]
struct Gen {
    two: bool,
    thickness: f64,
    parting: f64,
    from_tip: f64,
    clearance: f64,
    draft: f64,
    keys: i64,
    key_d: f64,
    key_h: f64,
    vents: i64,
    vent_d: f64,
    sprue_d: f64,
    wall: f64,
    shrink: f64,
    tilt: f64,
}

fn gen() -> impl Strategy<Value = Gen> {
    (
        (any::<bool>(), 0.5f64..3.0, 0.3f64..2.6, 0.0f64..1.0, 0.25f64..1.0, 0.0f64..3.0, 2i64..=4),
        (2.0f64..6.0, 1.0f64..5.0, 1i64..=6, 0.3f64..0.9, 1.0f64..5.0, 1.5f64..5.0, 0.0f64..3.0),
        -6.0f64..6.0,
    )
        .prop_map(|((two, thickness, parting, reach, clearance, draft, keys), (key_d, key_h, vents, vent_d, sprue_d, wall, shrink), tilt)| Gen {
            two,
            thickness,
            parting,
            // covered length: from just enough for the seats to the longest the mount allows
            from_tip: if two { 23.0 + 0.9 * reach } else { 15.0 + 9.0 * reach },
            clearance,
            draft,
            keys,
            key_d,
            key_h,
            vents,
            vent_d,
            sprue_d,
            wall,
            shrink,
            // a tilted opening half the time
            tilt: if tilt.abs() < 3.0 { 0.0 } else { tilt },
        })
}

fn toml_of(g: &Gen) -> String {
    format!(
        "kind = \"mold\"\nfingertip = \"{}\"\n[cover]\nthickness_mm = {}\nfrom_tip_mm = {}\ndome_clearance_mm = {}\nshrinkage_percent = {}\n[mold]\nwall_thickness_mm = {}\nparting_below_midplane_mm = {}\ndemolding_tilt_deg = {}\ndraft_deg = {}\nkey_count = {}\nkey_diameter_mm = {}\nkey_height_mm = {}\nvent_count = {}\nvent_diameter_mm = {}\nsprue_diameter_mm = {}\n",
        if g.two { "fingertip-2s.toml" } else { "fingertip-1s.toml" },
        g.thickness,
        g.from_tip,
        g.clearance,
        g.shrink,
        g.wall,
        g.parting,
        g.tilt,
        g.draft,
        g.keys,
        g.key_d,
        g.key_h,
        g.vents,
        g.vent_d,
        g.sprue_d
    )
}

#[test]
fn random_molds_build_and_pass_every_check_or_are_rejected_clearly() {
    let cases: u32 = std::env::var("TIPFORGE_MOLD_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(80);
    let tally = common::Tally::default();
    let mut runner = TestRunner::new_with_rng(Config { cases, failure_persistence: None, ..Config::default() }, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    runner
        .run(&gen(), |g| {
            let text = toml_of(&g);
            let src = SourceFile::parse("random-mold.toml", text.clone()).expect("generated TOML parses");
            match tipforge::mold::load(&src, "mold-r", Path::new("params")) {
                Ok(p) => {
                    let b = tipforge::mold::build(&p).map_err(|e| TestCaseError::fail(format!("valid mold failed to build: {e}\n{text}")))?;
                    prop_assert!(b.violations.is_empty(), "assembled-mold checks failed: {:?}\n{}", b.violations, text);
                    // the mold's pieces together: refused if any is refused only by the narrow-wall check
                    let v: Vec<_> = b.parts.iter().flat_map(tipforge::checks::run).collect();
                    tally.built(&v, &text)?;
                }
                Err(Error::Input(problems)) => {
                    common::rejected_clearly(&problems)?;
                    tally.invalid.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => return Err(TestCaseError::fail(format!("unexpected error kind: {e}\n{text}"))),
            }
            Ok(())
        })
        .unwrap();
    tally.assert_enough("molds", cases, 80, 20, 10, 5);
}
