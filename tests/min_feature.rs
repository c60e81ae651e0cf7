//! The minimum-feature check on the default parts (issue 18, item 5): it finds what is left on the
//! two-sensor fingertip (0.39 mm² in all: the ridge between the proximal pocket and the tip-side
//! flat's flare, 0.7–0.8 mm wide, and the tip-side pocket's wall toward the rounded end) and nothing
//! on the other fingertips, the hand's other digits, the molds or the rig. The 2s fingertip's old lip
//! beside its proximal seat (its tip-side tail channel 0.3 mm from the pocket) is now
//! refused by the crossing rule; built with the rule bypassed, the check finds it. Until the 2s
//! layout is clean, the build reports (summary and manifest `printability`) instead of refusing.

use std::path::PathBuf;
use tipforge::build::{build_job, load_all, Options};

fn advice_by_part() -> Vec<(String, usize)> {
    let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![], preview: false, slice: false };
    let (loaded, _) = load_all(&opts).unwrap();
    let mut out = Vec::new();
    for l in &loaded {
        for p in build_job(&l.job).unwrap().parts {
            out.push((p.name.clone(), tipforge::checks::advise(&p).len()));
        }
    }
    out
}

#[test]
fn narrow_walls_are_found_where_the_design_has_them_and_nowhere_else() {
    let found = advice_by_part();
    let flagged: Vec<&str> = found.iter().filter(|(_, n)| *n > 0).map(|(p, _)| p.as_str()).collect();
    // hand-index is the 2s fingertip (params/hand.toml)
    assert_eq!(flagged, vec!["fingertip-2s", "hand-index"], "{found:?}");
    let narrow = |stem: &str| {
        let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![stem.into()], preview: false, slice: false };
        let (loaded, _) = load_all(&opts).unwrap();
        let mesh = build_job(&loaded[0].job).unwrap().parts.remove(0).mesh;
        tipforge::checks::min_feature::narrow_walls(&mesh, tipforge::checks::min_feature::MIN_FEATURE_MM)
    };
    // the default 2s has under 0.5 mm² left; with its tip-side tail channel moved to run 0.3 mm
    // beside the proximal pocket (the old layout, which the crossing rule now refuses) the lip adds
    // more than half a square millimetre
    let src = tipforge::params::read_source(std::path::Path::new("params/fingertip-2s.toml")).unwrap();
    let mut p = tipforge::fingertip::load(&src, "t", std::path::Path::new("params")).unwrap();
    let two = narrow("fingertip-2s");
    p.sensors[0].channel_offset_mm = 5.6;
    let lip = tipforge::checks::min_feature::narrow_walls(&tipforge::fingertip::build(&p).unwrap().mesh, tipforge::checks::min_feature::MIN_FEATURE_MM);
    assert!(two.area_mm2 < 0.5 && lip.area_mm2 > two.area_mm2 + 0.5, "2s {two:?}, with the old lip {lip:?}");
}
