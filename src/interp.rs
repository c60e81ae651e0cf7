//! Monotone interpolation through stations (used by the anatomical fingertip's body and its
//! parameters' envelope): a monotone piecewise-cubic Hermite curve
//! (Fritsch–Butland slopes) through the station values. It is C¹, never overshoots the stations
//! (a pulp given as the deepest station stays the deepest point, with a level tangent there), and
//! holds the end values with zero slope before the first and after the last station.

#[derive(Debug, Clone)]
pub struct Monotone {
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
}

impl Monotone {
    /// Through the points (x strictly increasing, at least one).
    pub fn new(x: &[f64], y: &[f64]) -> Monotone {
        let n = x.len();
        let d: Vec<f64> = (0..n.saturating_sub(1)).map(|i| (y[i + 1] - y[i]) / (x[i + 1] - x[i])).collect();
        let mut m = vec![0.0; n];
        for i in 1..n.saturating_sub(1) {
            let (h0, h1) = (x[i] - x[i - 1], x[i + 1] - x[i]);
            let (d0, d1) = (d[i - 1], d[i]);
            if d0 * d1 > 0.0 {
                m[i] = 3.0 * (h0 + h1) / ((2.0 * h1 + h0) / d0 + (h1 + 2.0 * h0) / d1);
            }
        }
        Monotone { x: x.to_vec(), y: y.to_vec(), m }
    }

    fn piece(&self, t: f64) -> Option<(usize, f64, f64)> {
        let n = self.x.len();
        if n < 2 || t <= self.x[0] || t >= self.x[n - 1] {
            return None;
        }
        let i = self.x.partition_point(|&v| v <= t) - 1;
        let h = self.x[i + 1] - self.x[i];
        Some((i, h, (t - self.x[i]) / h))
    }

    /// Value at t.
    pub fn at(&self, t: f64) -> f64 {
        match self.piece(t) {
            None => {
                if t <= self.x[0] {
                    self.y[0]
                } else {
                    self.y[self.y.len() - 1]
                }
            }
            Some((i, h, s)) => {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * self.y[i] + (s3 - 2.0 * s2 + s) * h * self.m[i] + (-2.0 * s3 + 3.0 * s2) * self.y[i + 1] + (s3 - s2) * h * self.m[i + 1]
            }
        }
    }

    /// Slope at t.
    pub fn slope(&self, t: f64) -> f64 {
        match self.piece(t) {
            None => 0.0,
            Some((i, h, s)) => {
                let s2 = s * s;
                ((6.0 * s2 - 6.0 * s) * self.y[i] + (-6.0 * s2 + 6.0 * s) * self.y[i + 1]) / h + (3.0 * s2 - 4.0 * s + 1.0) * self.m[i] + (3.0 * s2 - 2.0 * s) * self.m[i + 1]
            }
        }
    }

    /// The station positions (the pieces' ends).
    pub fn knots(&self) -> &[f64] {
        &self.x
    }

    /// Largest |second derivative| on piece i (at its ends, where a cubic's is largest).
    pub fn piece_curvature(&self, i: usize) -> f64 {
        let h = self.x[i + 1] - self.x[i];
        let (y0, y1, m0, m1) = (self.y[i], self.y[i + 1], self.m[i], self.m[i + 1]);
        let a = (6.0 * (y1 - y0) / h - 4.0 * m0 - 2.0 * m1) / h;
        let b = (-6.0 * (y1 - y0) / h + 2.0 * m0 + 4.0 * m1) / h;
        a.abs().max(b.abs())
    }

    /// Largest |second derivative| anywhere (0 outside the stations, where the value is held).
    pub fn max_curvature(&self) -> f64 {
        (0..self.x.len().saturating_sub(1)).map(|i| self.piece_curvature(i)).fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_through_the_stations_without_overshoot() {
        let (x, y) = ([0.0, 6.0, 13.0, 21.0], [5.0, 6.4, 6.8, 5.9]);
        let s = Monotone::new(&x, &y);
        for (a, b) in x.iter().zip(y) {
            assert!((s.at(*a) - b).abs() < 1e-12);
        }
        // the deepest station is the deepest point, with a level tangent
        let mut worst = f64::NEG_INFINITY;
        for i in 0..=2100 {
            worst = worst.max(s.at(i as f64 * 0.01));
        }
        assert!((worst - 6.8).abs() < 1e-9, "overshoot: {worst}");
        assert!(s.slope(13.0).abs() < 1e-12);
        // between monotone stations it is monotone
        for i in 0..600 {
            assert!(s.at(i as f64 * 0.01 + 0.01) >= s.at(i as f64 * 0.01) - 1e-12);
        }
    }

    #[test]
    fn slope_is_the_derivative_and_continuous() {
        let s = Monotone::new(&[0.0, 5.0, 9.0, 20.0], &[8.0, 7.6, 7.0, 6.9]);
        for i in 1..200 {
            let t = i as f64 * 0.1;
            let h = 1e-6;
            let fd = (s.at(t + h) - s.at(t - h)) / (2.0 * h);
            assert!((fd - s.slope(t)).abs() < 1e-5, "at {t}: {fd} vs {}", s.slope(t));
        }
        // the second derivative is linear on a piece, so its largest size is at an end: compare
        // with finite differences just inside each piece's ends
        for i in 0..3 {
            let (a, b) = ([0.0, 5.0, 9.0, 20.0][i], [0.0, 5.0, 9.0, 20.0][i + 1]);
            let h = 1e-4;
            let second = |t: f64| (s.slope(t + h) - s.slope(t - h)) / (2.0 * h);
            let fd = second(a + 2.0 * h).abs().max(second(b - 2.0 * h).abs());
            assert!((fd - s.piece_curvature(i)).abs() < 1e-3 * (1.0 + fd), "piece {i}: {fd} vs {}", s.piece_curvature(i));
        }
        assert!(s.max_curvature() > 0.0);
        // beyond the ends: held, level
        assert_eq!(s.at(-1.0), 8.0);
        assert_eq!(s.at(25.0), 6.9);
        assert_eq!(s.slope(25.0), 0.0);
    }
}
