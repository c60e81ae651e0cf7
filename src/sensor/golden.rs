//! Golden-section search for the minimum of a function of one variable in a bracket (the step
//! fits' τ, the second relaxation's τ2, an actuator's ramp duration per step).

/// The bracket a search ends with: its ends `a`, `b` and its two inner points with their values.
#[derive(Debug, Clone, Copy)]
pub struct Bracket {
    pub a: f64,
    pub b: f64,
    pub x1: f64,
    pub f1: f64,
    pub x2: f64,
    pub f2: f64,
}

impl Bracket {
    /// The better of the two inner points, and its value.
    pub fn best(&self) -> (f64, f64) {
        if self.f1 < self.f2 {
            (self.x1, self.f1)
        } else {
            (self.x2, self.f2)
        }
    }
}

/// Golden-section search of `f` on [a, b]: at most `steps` steps, fewer once the bracket is
/// narrower than `tol`; one evaluation of `f` per step.
pub fn golden(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, steps: usize, tol: f64) -> Bracket {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (a, b);
    let (mut x1, mut x2) = (b - g * (b - a), a + g * (b - a));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..steps {
        if (b - a).abs() < tol {
            break;
        }
        if f1 < f2 {
            b = x2;
            (x2, f2) = (x1, f1);
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            (x1, f1) = (x2, f2);
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
    }
    Bracket { a, b, x1, f1, x2, f2 }
}

#[cfg(test)]
mod tests {
    /// A parabola's minimum is found inside the bracket, to the bracket's width; a tolerance stops
    /// the search early.
    #[test]
    fn finds_a_parabolas_minimum() {
        let br = super::golden(|x| (x - 0.3).powi(2), -1.0, 2.0, 40, 0.0);
        assert!((0.5 * (br.a + br.b) - 0.3).abs() < 1e-6 && br.b - br.a < 1e-6);
        let mut n = 0;
        let early = super::golden(
            |x| {
                n += 1;
                (x - 0.3).powi(2)
            },
            -1.0,
            2.0,
            40,
            0.1,
        );
        assert!(early.b - early.a < 0.1 && n < 12, "{n}");
        assert!((early.best().0 - 0.3).abs() < 0.1);
    }
}
