//! The minimum-feature check (issue 18, item 5) on the default parts: every printed part passes it
//! (it is one of the checks a part must pass before anything is written). It catches what it was
//! made for: the two-sensor fingertip's old lip beside its proximal seat (its tip-side tail channel
//! 0.3 mm from the pocket, which the crossing rule now refuses; built past the rule, the check
//! refuses the part), and a build with such a part stops with the check's message.

use std::path::PathBuf;
use tipforge::build::{build_job, load_all, Options};

fn advice_by_part() -> Vec<(String, usize)> {
    let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![], preview: false, slice: false };
    let (loaded, _) = load_all(&opts).unwrap();
    let mut out = Vec::new();
    for l in &loaded {
        for p in build_job(&l.job).unwrap().parts {
            out.push((p.name.clone(), tipforge::checks::run(&p).iter().filter(|v| v.rule == tipforge::checks::min_feature::RULE).count()));
        }
    }
    out
}

#[test]
fn narrow_walls_are_found_where_the_design_has_them_and_nowhere_else() {
    let found = advice_by_part();
    let flagged: Vec<&str> = found.iter().filter(|(_, n)| *n > 0).map(|(p, _)| p.as_str()).collect();
    assert!(flagged.is_empty(), "{found:?}");
    assert!(found.len() >= 18, "every default part looked at: {found:?}");
    let narrow = |stem: &str| {
        let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![stem.into()], preview: false, slice: false };
        let (loaded, _) = load_all(&opts).unwrap();
        let mesh = build_job(&loaded[0].job).unwrap().parts.remove(0).mesh;
        tipforge::checks::min_feature::narrow_walls(&mesh, tipforge::checks::min_feature::MIN_FEATURE_MM)
    };
    // the default 2s has no narrow wall; with its tip-side tail channel moved to run 0.3 mm beside
    // the proximal pocket (the old layout, which the crossing rule now refuses) the lip is found and
    // the part refused
    let src = tipforge::params::read_source(std::path::Path::new("params/fingertip-2s.toml")).unwrap();
    let mut p = tipforge::fingertip::load(&src, "t", std::path::Path::new("params")).unwrap();
    let two = narrow("fingertip-2s");
    p.sensors[0].channel_offset_mm = 5.6;
    let part = tipforge::fingertip::build(&p).unwrap();
    let lip = tipforge::checks::min_feature::narrow_walls(&part.mesh, tipforge::checks::min_feature::MIN_FEATURE_MM);
    assert!(two.area_mm2 < 0.16 && lip.area_mm2 > 0.5, "2s {two:?}, with the old lip {lip:?}");
    // it points at the lip (beside the proximal pocket, on the pad), not at a sliver elsewhere
    // (print frame: y, z, x of the design frame)
    assert!(lip.at[0] > 3.5 && lip.at[0] < 6.5 && lip.at[1] < -2.0 && lip.at[2] > 8.0 && lip.at[2] < 18.0, "{lip:?}");
    let refused = tipforge::checks::run(&part);
    assert!(refused.iter().any(|v| v.rule == tipforge::checks::min_feature::RULE && v.measured.contains("narrower than 0.8 mm")), "{refused:?}");
}
