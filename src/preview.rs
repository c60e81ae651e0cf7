//! Shaded previews of parts, drawn in software (no GPU, no browser): two views side by side
//! (from below-front and from above-back), flat Lambert shading, a z-buffer, and a caption with the
//! part name and its size in millimetres, written as PNG.

use crate::mesh::{cross, dot, norm, sub, unit, Mesh, P3};

pub const WIDTH: u32 = 960;
pub const HEIGHT: u32 = 480;

pub(crate) struct Canvas {
    pub w: usize,
    pub h: usize,
    pub rgb: Vec<u8>,
    depth: Vec<f64>,
}

impl Canvas {
    pub fn new(w: usize, h: usize) -> Canvas {
        Canvas { w, h, rgb: vec![245; w * h * 3], depth: vec![f64::INFINITY; w * h] }
    }
    pub fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.w && y < self.h {
            let i = (y * self.w + x) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }
    pub fn png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.w as u32, self.h as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut wr = enc.write_header().expect("png header in memory");
            wr.write_image_data(&self.rgb).expect("png data in memory");
        }
        out
    }
}

/// Renders one view of the mesh into the canvas region [x0, x0 + size) × [y0, y0 + size).
fn view(cv: &mut Canvas, mesh: &Mesh, eye_dir: P3, up: P3, x0: usize, y0: usize, wv: usize, hv: usize) {
    let f = unit(eye_dir); // from the object toward the eye
    let r = unit(cross(up, f));
    let u = cross(f, r);
    let (lo, hi) = mesh.bbox();
    let c = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, (lo[2] + hi[2]) / 2.0];
    let radius = norm(sub(hi, lo)) / 2.0;
    let scale = 0.46 * (wv.min(hv) as f64) / radius.max(1e-9);
    let light = unit([0.4 * r[0] + 0.6 * u[0] + f[0], 0.4 * r[1] + 0.6 * u[1] + f[1], 0.4 * r[2] + 0.6 * u[2] + f[2]]);
    let proj = |p: P3| {
        let d = sub(p, c);
        (x0 as f64 + wv as f64 / 2.0 + dot(d, r) * scale, y0 as f64 + hv as f64 / 2.0 - dot(d, u) * scale, -dot(d, f))
    };
    for t in &mesh.triangles {
        let [a, b, cc] = t.map(|i| mesh.vertices[i as usize]);
        let n = cross(sub(b, a), sub(cc, a));
        if norm(n) == 0.0 {
            continue;
        }
        let n = unit(n);
        if dot(n, f) <= 0.0 {
            continue; // back face
        }
        let shade = 0.25 + 0.75 * dot(n, light).max(0.0);
        let col = [(70.0 + 150.0 * shade) as u8, (110.0 + 120.0 * shade) as u8, (150.0 + 100.0 * shade) as u8];
        let (pa, pb, pc) = (proj(a), proj(b), proj(cc));
        let minx = pa.0.min(pb.0).min(pc.0).floor().max(x0 as f64) as usize;
        let maxx = pa.0.max(pb.0).max(pc.0).ceil().min((x0 + wv - 1) as f64) as usize;
        let miny = pa.1.min(pb.1).min(pc.1).floor().max(y0 as f64) as usize;
        let maxy = pa.1.max(pb.1).max(pc.1).ceil().min((y0 + hv - 1) as f64) as usize;
        let area = (pb.0 - pa.0) * (pc.1 - pa.1) - (pb.1 - pa.1) * (pc.0 - pa.0);
        if area.abs() < 1e-12 {
            continue;
        }
        for y in miny..=maxy {
            for x in minx..=maxx {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let w0 = ((pb.0 - px) * (pc.1 - py) - (pb.1 - py) * (pc.0 - px)) / area;
                let w1 = ((pc.0 - px) * (pa.1 - py) - (pc.1 - py) * (pa.0 - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * pa.2 + w1 * pb.2 + w2 * pc.2;
                let i = y * cv.w + x;
                if z < cv.depth[i] {
                    cv.depth[i] = z;
                    cv.put(x, y, col);
                }
            }
        }
    }
}

/// 5×7 glyphs, one u8 per row (low 5 bits, left = bit 4).
fn glyph(ch: char) -> [u8; 7] {
    match ch.to_ascii_uppercase() {
        'A' => [14, 17, 17, 31, 17, 17, 17],
        'B' => [30, 17, 17, 30, 17, 17, 30],
        'C' => [14, 17, 16, 16, 16, 17, 14],
        'D' => [30, 17, 17, 17, 17, 17, 30],
        'E' => [31, 16, 16, 30, 16, 16, 31],
        'F' => [31, 16, 16, 30, 16, 16, 16],
        'G' => [14, 17, 16, 23, 17, 17, 15],
        'H' => [17, 17, 17, 31, 17, 17, 17],
        'I' => [14, 4, 4, 4, 4, 4, 14],
        'J' => [7, 2, 2, 2, 2, 18, 12],
        'K' => [17, 18, 20, 24, 20, 18, 17],
        'L' => [16, 16, 16, 16, 16, 16, 31],
        'M' => [17, 27, 21, 21, 17, 17, 17],
        'N' => [17, 17, 25, 21, 19, 17, 17],
        'O' => [14, 17, 17, 17, 17, 17, 14],
        'P' => [30, 17, 17, 30, 16, 16, 16],
        'Q' => [14, 17, 17, 17, 21, 18, 13],
        'R' => [30, 17, 17, 30, 20, 18, 17],
        'S' => [15, 16, 16, 14, 1, 1, 30],
        'T' => [31, 4, 4, 4, 4, 4, 4],
        'U' => [17, 17, 17, 17, 17, 17, 14],
        'V' => [17, 17, 17, 17, 17, 10, 4],
        'W' => [17, 17, 17, 21, 21, 21, 10],
        'X' => [17, 17, 10, 4, 10, 17, 17],
        'Y' => [17, 17, 10, 4, 4, 4, 4],
        'Z' => [31, 1, 2, 4, 8, 16, 31],
        '0' => [14, 17, 19, 21, 25, 17, 14],
        '1' => [4, 12, 4, 4, 4, 4, 14],
        '2' => [14, 17, 1, 2, 4, 8, 31],
        '3' => [31, 2, 4, 2, 1, 17, 14],
        '4' => [2, 6, 10, 18, 31, 2, 2],
        '5' => [31, 16, 30, 1, 1, 17, 14],
        '6' => [6, 8, 16, 30, 17, 17, 14],
        '7' => [31, 1, 2, 4, 8, 8, 8],
        '8' => [14, 17, 17, 14, 17, 17, 14],
        '9' => [14, 17, 17, 15, 1, 2, 12],
        '-' => [0, 0, 0, 31, 0, 0, 0],
        '.' => [0, 0, 0, 0, 0, 12, 12],
        ':' => [0, 12, 12, 0, 12, 12, 0],
        '(' => [2, 4, 8, 8, 8, 4, 2],
        ')' => [8, 4, 2, 2, 2, 4, 8],
        '/' => [1, 1, 2, 4, 8, 16, 16],
        ',' => [0, 0, 0, 0, 12, 4, 8],
        '_' => [0, 0, 0, 0, 0, 0, 31],
        '=' => [0, 0, 31, 0, 31, 0, 0],
        '%' => [24, 25, 2, 4, 8, 19, 3],
        '+' => [0, 4, 4, 31, 4, 4, 0],
        '>' => [8, 4, 2, 1, 2, 4, 8],
        '<' => [2, 4, 8, 16, 8, 4, 2],
        '[' => [14, 8, 8, 8, 8, 8, 14],
        ']' => [14, 2, 2, 2, 2, 2, 14],
        '*' => [0, 4, 21, 14, 21, 4, 0],
        _ => [0; 7],
    }
}

/// Draws text with the 5×7 font at pixel size `px`.
pub(crate) fn text(cv: &mut Canvas, s: &str, x0: usize, y0: usize, px: usize) {
    text_color(cv, s, x0, y0, px, [30, 30, 30]);
}

pub(crate) fn text_color(cv: &mut Canvas, s: &str, x0: usize, y0: usize, px: usize, color: [u8; 3]) {
    for (k, ch) in s.chars().enumerate() {
        let g = glyph(ch);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits & (1 << (4 - col)) != 0 {
                    for dy in 0..px {
                        for dx in 0..px {
                            let (x, y) = (x0 + (k * 6 + col) * px + dx, y0 + row * px + dy);
                            if x < cv.w && y < cv.h {
                                cv.put(x, y, color);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// A PNG of the part: two views and a caption "NAME  W x D x H MM".
pub fn render(mesh: &Mesh, name: &str) -> Vec<u8> {
    let (w, h) = (WIDTH as usize, HEIGHT as usize);
    let mut cv = Canvas::new(w, h);
    let top = 40;
    let half = w / 2;
    view(&mut cv, mesh, [0.35, -1.0, 0.35], [0.0, 0.0, 1.0], 0, top, half, h - top);
    view(&mut cv, mesh, [1.0, 0.1, 0.2], [0.0, 0.0, 1.0], half, top, half, h - top);
    let (lo, hi) = mesh.bbox();
    let caption = format!("{name}  {:.1} X {:.1} X {:.1} MM", hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    text(&mut cv, &caption, 12, 10, 3);
    cv.png()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Solid;

    #[test]
    fn preview_is_a_png_of_the_stated_size_with_the_part_drawn() {
        let m = Solid::cuboid([0.0; 3], [10.0, 5.0, 3.0]).to_mesh();
        let bytes = render(&m, "cube");
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut rd = dec.read_info().unwrap();
        let mut buf = vec![0; rd.output_buffer_size().unwrap()];
        let info = rd.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (WIDTH, HEIGHT));
        // some pixels are shaded part colour (not background, not text)
        let drawn = buf.chunks(3).filter(|p| p[2] > p[0] + 40).count();
        assert!(drawn > 1000, "{drawn}");
    }
}
