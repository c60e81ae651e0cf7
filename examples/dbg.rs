fn main() {
    let src = tipforge::params::read_source(std::path::Path::new("params/fingertip-2s.toml")).unwrap();
    let p = tipforge::params::fingertip::FingertipParams::from_source(&src, "x").unwrap();
    let part = tipforge::fingertip::build(&p).unwrap();
    for b in part.solid.0.decompose() { println!("body vol {} bbox {:?}", b.volume(), b.bounding_box()); }
}
