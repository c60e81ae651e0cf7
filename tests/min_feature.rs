//! The minimum-feature check on the default parts: it finds the two-sensor fingertip's lip beside
//! the proximal seat and the knife edge on the two-sensor mold core (issue 18, item 5), and nothing
//! on the one-sensor parts or the rig. Until the two-sensor design changes, the build reports them
//! (summary and manifest `printability`) instead of refusing to write.

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
    assert_eq!(flagged, vec!["fingertip-2s", "hand-index", "mold-2s-core"], "{found:?}");
    let narrow = |stem: &str| {
        let opts = Options { params_dir: PathBuf::from("params"), out_dir: PathBuf::from("out"), only: vec![stem.into()], preview: false, slice: false };
        let (loaded, _) = load_all(&opts).unwrap();
        let mesh = build_job(&loaded[0].job).unwrap().parts.remove(0).mesh;
        tipforge::checks::min_feature::narrow_walls(&mesh, tipforge::checks::min_feature::MIN_FEATURE_MM)
    };
    // the two fingertips share body, mount and holes; the 2s alone has the lip beside its proximal seat
    let (one, two) = (narrow("fingertip-1s"), narrow("fingertip-2s"));
    assert!(one.area_mm2 < 0.16 && two.area_mm2 > 1.0, "1s {one:?}, 2s {two:?}");
}
