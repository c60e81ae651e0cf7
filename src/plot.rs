//! Small PNG charts for reports (no plotting dependency): panels with axes, ticks, lines, points,
//! shaded windows and a legend, drawn with the preview's canvas and font.

use crate::preview::{text, text_color, Canvas};

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Line,
    Points,
}

#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub color: [u8; 3],
    pub style: Style,
}

#[derive(Debug, Clone, Default)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// x-intervals shaded in the background (e.g. flagged windows).
    pub shade: Vec<(f64, f64)>,
}

pub const PALETTE: [[u8; 3]; 8] = [[31, 119, 180], [214, 39, 40], [44, 160, 44], [255, 127, 14], [148, 103, 189], [140, 86, 75], [227, 119, 194], [23, 190, 207]];

impl Series {
    pub fn line(label: &str, x: Vec<f64>, y: Vec<f64>, color: [u8; 3]) -> Series {
        Series { label: label.into(), x, y, color, style: Style::Line }
    }
    pub fn points(label: &str, x: Vec<f64>, y: Vec<f64>, color: [u8; 3]) -> Series {
        Series { label: label.into(), x, y, color, style: Style::Points }
    }
}

fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| span / s <= n as f64 + 1.0).unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut v = Vec::new();
    while t <= hi + 1e-9 * step {
        v.push(if t.abs() < 1e-12 * step { 0.0 } else { t });
        t += step;
    }
    v
}

fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.1E}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}").trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.4}").trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

fn line(cv: &mut Canvas, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3], clip: (usize, usize, usize, usize)) {
    let n = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).clamp(1, 4000);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        let (x, y) = (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t);
        if x >= clip.0 as f64 && x < clip.2 as f64 && y >= clip.1 as f64 && y < clip.3 as f64 {
            cv.put(x as usize, y as usize, c);
        }
    }
}

/// Rows of a chart's header, from the chart's top: the title (5×7 font at 2 px, 14 px high), the
/// y axis' unit label under it (at 1 px, 7 px high), then the plot area. Each starts below the
/// previous one's last row, so the unit never runs into the title.
const TITLE_Y: usize = 6;
const UNIT_Y: usize = TITLE_Y + 14 + 4;
const PLOT_TOP: usize = UNIT_Y + 7 + 5;

fn draw(cv: &mut Canvas, ch: &Chart, ox: usize, oy: usize, w: usize, h: usize) {
    let (l, r, t, b) = (ox + 78, ox + w - 12, oy + PLOT_TOP, oy + h - 40);
    // a title wider than its panel at 2 px is drawn at 1 px (it ran into the next panel's)
    let title_px = if 10 + ch.title.chars().count() * 12 <= w { 2 } else { 1 };
    text(cv, &ch.title, ox + 10, oy + TITLE_Y, title_px);
    let pts = ch.series.iter().flat_map(|s| s.x.iter().zip(&s.y)).filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (x, y) in pts {
        xmin = xmin.min(*x);
        xmax = xmax.max(*x);
        ymin = ymin.min(*y);
        ymax = ymax.max(*y);
    }
    if !xmin.is_finite() {
        return;
    }
    if xmax - xmin < 1e-12 {
        xmax = xmin + 1.0;
    }
    let pad = (ymax - ymin).max(1e-9) * 0.06;
    let (ymin, ymax) = (ymin - pad, ymax + pad);
    let sx = |x: f64| l as f64 + (x - xmin) / (xmax - xmin) * (r - l) as f64;
    let sy = |y: f64| b as f64 - (y - ymin) / (ymax - ymin) * (b - t) as f64;
    for &(a, z) in &ch.shade {
        let (xa, xz) = (sx(a.max(xmin)).max(l as f64) as usize, sx(z.min(xmax)).min(r as f64) as usize);
        for x in xa..xz.max(xa) {
            for y in t..b {
                cv.put(x, y, [255, 226, 200]);
            }
        }
    }
    let clip = (l, t, r + 1, b + 1);
    for tx in nice_ticks(xmin, xmax, 6) {
        let x = sx(tx);
        line(cv, (x, t as f64), (x, b as f64), [228, 228, 228], clip);
        let s = fmt_tick(tx);
        text(cv, &s, (x as usize).saturating_sub(s.len() * 6 / 2), b + 6, 1);
    }
    for ty in nice_ticks(ymin, ymax, 5) {
        let y = sy(ty);
        line(cv, (l as f64, y), (r as f64, y), [228, 228, 228], clip);
        let s = fmt_tick(ty);
        text(cv, &s, l.saturating_sub(s.len() * 6 + 4), (y as usize).saturating_sub(3), 1);
    }
    for (a, z) in [((l, t), (r, t)), ((l, b), (r, b)), ((l, t), (l, b)), ((r, t), (r, b))] {
        line(cv, (a.0 as f64, a.1 as f64), (z.0 as f64, z.1 as f64), [60, 60, 60], (0, 0, usize::MAX, usize::MAX));
    }
    text(cv, &ch.x_label, (l + r) / 2 - ch.x_label.len() * 6, b + 20, 2);
    text(cv, &ch.y_label, ox + 4, oy + UNIT_Y, 1);
    for s in &ch.series {
        match s.style {
            Style::Line => {
                for i in 1..s.x.len() {
                    if [s.x[i - 1], s.y[i - 1], s.x[i], s.y[i]].iter().all(|v| v.is_finite()) {
                        line(cv, (sx(s.x[i - 1]), sy(s.y[i - 1])), (sx(s.x[i]), sy(s.y[i])), s.color, clip);
                    }
                }
            }
            Style::Points => {
                for (x, y) in s.x.iter().zip(&s.y) {
                    if x.is_finite() && y.is_finite() {
                        let (px, py) = (sx(*x) as i64, sy(*y) as i64);
                        for dx in -1..=1 {
                            for dy in -1..=1 {
                                let (qx, qy) = (px + dx, py + dy);
                                if qx >= l as i64 && qx <= r as i64 && qy >= t as i64 && qy <= b as i64 {
                                    cv.put(qx as usize, qy as usize, s.color);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    // legend
    let mut ly = t + 6;
    for s in ch.series.iter().filter(|s| !s.label.is_empty()).take(8) {
        for x in r.saturating_sub(150)..r.saturating_sub(136) {
            for y in ly + 2..ly + 5 {
                cv.put(x, y, s.color);
            }
        }
        text_color(cv, &s.label, r.saturating_sub(132), ly, 1, [40, 40, 40]);
        ly += 11;
    }
}

/// Renders panels in a grid of `cols` columns, each `pw` × `ph` pixels.
pub fn render(charts: &[Chart], cols: usize, pw: usize, ph: usize) -> Vec<u8> {
    let cols = cols.max(1);
    let rows = charts.len().div_ceil(cols).max(1);
    let mut cv = Canvas::new(cols * pw, rows * ph);
    for (i, ch) in charts.iter().enumerate() {
        draw(&mut cv, ch, (i % cols) * pw, (i / cols) * ph, pw, ph);
    }
    cv.png()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 16, item 4: the unit label sat over the title ("ᵥLOADING 1"). Title, unit and plot
    /// area are stacked without overlap.
    #[test]
    fn the_unit_label_does_not_overlap_the_title() {
        let (title_end, unit_end) = (TITLE_Y + 7 * 2, UNIT_Y + 7);
        assert!(title_end < UNIT_Y && unit_end < PLOT_TOP, "title ends {title_end}, unit {UNIT_Y}..{unit_end}, plot {PLOT_TOP}");
    }

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let t = nice_ticks(0.13, 2.9, 5);
        assert!(t.first().unwrap() >= &0.13 && t.last().unwrap() <= &2.9);
        assert!(t.len() >= 3 && t.len() <= 7);
        assert!(t.iter().all(|v| ((v / 0.5).round() * 0.5 - v).abs() < 1e-9));
    }

    #[test]
    fn chart_renders_a_png_with_data_drawn() {
        let ch = Chart {
            title: "t".into(),
            x_label: "time s".into(),
            y_label: "V".into(),
            series: vec![Series::line("a", vec![0.0, 1.0, 2.0], vec![0.0, 1.0, 0.5], PALETTE[1])],
            shade: vec![(0.5, 0.8)],
        };
        let png = render(&[ch], 1, 400, 300);
        let dec = png::Decoder::new(std::io::Cursor::new(png));
        let mut rd = dec.read_info().unwrap();
        let mut buf = vec![0; rd.output_buffer_size().unwrap()];
        let info = rd.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (400, 300));
        let red = buf.chunks(3).filter(|p| p[0] > 200 && p[1] < 80 && p[2] < 80).count();
        assert!(red > 100, "{red}");
    }
}
