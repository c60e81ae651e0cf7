//! The anatomical body against its stations (`<part>-sections.png` with `build --preview`): the
//! built mesh sliced square to the finger, compared with the widths, depths and heights the file
//! gives. A person checks the loft with it; the seats' flats show as a shallower pad where they are.

use super::shape::Shape;
use crate::mesh::Mesh;
use crate::params::fingertip::{FingertipParams, Form};
use crate::plot::{self, Chart, Series, PALETTE};

/// Where the mesh crosses the plane x = x0 (design frame): the crossing segments' end points (y, z).
pub fn slice(mesh: &Mesh, x0: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.vertices[i as usize]);
        for k in 0..3 {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            if (a[0] - x0) * (b[0] - x0) < 0.0 {
                let f = (x0 - a[0]) / (b[0] - a[0]);
                out.push([a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f]);
            }
        }
    }
    out
}

/// The plot, for a fingertip whose body is lofted through stations; `mesh` is the printed part (print
/// frame: design (x, y, z) is printed as (y, z, x)).
pub fn render(p: &FingertipParams, mesh: &Mesh) -> Option<Vec<u8>> {
    let Form::Stations { stations, .. } = &p.body.form else { return None };
    let shape = Shape::new(&p.body);
    let design = mesh.map(|q| [q[2], q[0], q[1]]);
    let l = shape.length;
    let xs: Vec<f64> = (0..=280).map(|i| l * i as f64 / 280.0).collect();
    let at: Vec<(f64, &crate::params::fingertip::Station)> = stations.iter().map(|s| (l - s.from_tip_mm, s)).filter(|(x, _)| *x >= 0.0).collect();
    // the mesh, sliced every 0.5 mm: width and the pad's and nail's extremes
    let cuts: Vec<(f64, Vec<[f64; 2]>)> = (1..(2.0 * l) as usize).map(|i| i as f64 * 0.5).map(|x| (x, slice(&design, x + 1e-4))).filter(|(_, s)| !s.is_empty()).collect();
    let ext = |f: &dyn Fn(&[f64; 2]) -> f64, s: &[[f64; 2]], max: bool| {
        s.iter().map(f).fold(if max { f64::NEG_INFINITY } else { f64::INFINITY }, |a, b| if max { a.max(b) } else { a.min(b) })
    };
    let top = Chart {
        title: "Top view: width along the finger".into(),
        x_label: "x from the mount face (mm)".into(),
        y_label: "width (mm)".into(),
        series: vec![
            Series::line("exact body", xs.clone(), xs.iter().map(|&x| 2.0 * shape.half_width(x)).collect(), PALETTE[0]),
            Series::points("built mesh", cuts.iter().map(|c| c.0).collect(), cuts.iter().map(|c| ext(&|q| q[0], &c.1, true) - ext(&|q| q[0], &c.1, false)).collect(), PALETTE[2]),
            Series::points("stations", at.iter().map(|a| a.0).collect(), at.iter().map(|a| a.1.width_mm).collect(), PALETTE[1]),
        ],
        shade: vec![],
    };
    let side = Chart {
        title: "Side view: nail height (above 0) and pad depth (below)".into(),
        x_label: "x from the mount face (mm)".into(),
        y_label: "z (mm)".into(),
        series: vec![
            Series::line("exact nail side", xs.clone(), xs.iter().map(|&x| shape.dorsal_height_at(x)).collect(), PALETTE[0]),
            Series::line("exact pad", xs.clone(), xs.iter().map(|&x| -shape.pad_depth_at(x)).collect(), PALETTE[4]),
            Series::points(
                "built mesh",
                cuts.iter().flat_map(|c| [c.0, c.0]).collect(),
                cuts.iter().flat_map(|c| [ext(&|q| q[1], &c.1, true), ext(&|q| q[1], &c.1, false)]).collect(),
                PALETTE[2],
            ),
            Series::points("stations", at.iter().flat_map(|a| [a.0, a.0]).collect(), at.iter().flat_map(|a| [a.1.nail_height_mm, -a.1.pad_depth_mm]).collect(), PALETTE[1]),
        ],
        shade: vec![],
    };
    let mut sections = Chart {
        title: "Sections at the stations: built mesh (points) and the station's half-ellipses (lines)".into(),
        x_label: "y (mm)".into(),
        y_label: "z (mm)".into(),
        series: vec![],
        shade: vec![],
    };
    for (k, (x, s)) in at.iter().enumerate() {
        let c = PALETTE[(k + 3) % PALETTE.len()];
        let cut = slice(&design, *x + 1e-4);
        let phis: Vec<f64> = (0..=120).map(|i| 2.0 * std::f64::consts::PI * i as f64 / 120.0).collect();
        let ell: Vec<[f64; 2]> = phis.iter().map(|f| [s.width_mm / 2.0 * f.cos(), f.sin() * if f.sin() >= 0.0 { s.nail_height_mm } else { s.pad_depth_mm }]).collect();
        sections.series.push(Series::line(&format!("{:.0} mm from the tip", s.from_tip_mm), ell.iter().map(|q| q[0]).collect(), ell.iter().map(|q| q[1]).collect(), c));
        sections.series.push(Series::points("", cut.iter().map(|q| q[0]).collect(), cut.iter().map(|q| q[1]).collect(), c));
    }
    Some(plot::render(&[top, side, sections], 3, 620, 460))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slice_of_a_box_is_its_section() {
        let m = crate::mesh::Solid::cuboid([0.0, -2.0, -1.0], [4.0, 2.0, 3.0]).to_mesh();
        let s = slice(&m, 1.5);
        assert!(!s.is_empty());
        let (ylo, yhi) = s.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, q| (a.0.min(q[0]), a.1.max(q[0])));
        let (zlo, zhi) = s.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, q| (a.0.min(q[1]), a.1.max(q[1])));
        assert!((ylo + 2.0).abs() < 1e-9 && (yhi - 2.0).abs() < 1e-9 && (zlo + 1.0).abs() < 1e-9 && (zhi - 3.0).abs() < 1e-9);
        assert!(slice(&m, 5.0).is_empty());
    }
}
