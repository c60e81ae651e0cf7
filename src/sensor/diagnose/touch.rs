//! The hand's touch before each step (part of stage 1, the baseline). When a weight is placed by
//! hand, the load starts to change before the step's onset — the hand lowers it, presses on it,
//! lets go — differently at every placement. No shared term models that, and its misfit, a few
//! tenths of a second per step, can outweigh a whole hold's worth of a 1σ effect in the held-out
//! error (family A's hand-touch tuning cases: 7 % of the samples, two thirds of the squared error).
//!
//! The window the touch takes is measured, not assumed: the baseline's residuals are aligned at
//! every step's onset and pooled over steps and trials in bins of `BIN_S` (each step's residuals
//! less their level over the far half of the bins); the touch is the run of bins just before the
//! onsets whose mean square exceeds `EXCESS` times that of the holds' later part (the bins from
//! `LOOK_S / 2` to `LOOK_S` before the onsets), when the bin next to them exceeds `START_EXCESS`
//! times in its systematic part (what repeats at every loading step, and at every unloading step:
//! a touch's course does, handling spikes of random sign do not) and the run spans `MIN_BINS` (a
//! single bin is the onset's own misfit). When there is a
//! touch before the onsets, its run after them is measured the same way, up to `PRESS_TAUS` of the
//! steps' median time constant (the response still carries the hand's press for a few of them),
//! unless the data reach a clip or a rail: the steps into and out of it take their onsets from the
//! samples right after them (family A's rail + touch + nuisances row: saturation 2/8 → 0/8 with
//! the window after the onsets). Its samples are handling, as spikes are: neither fitted nor
//! scored, by the baseline and the improved model alike. Where the load's ramp is modelled (an actuator's travel) there is no
//! window; where nothing departs (or nothing is left in the holds to compare with), none.

use super::*;

/// A touch starts with a bin next to the onsets whose systematic mean square (the part repeated at
/// every loading step, and at every unloading step) exceeds this many times the holds' mean square
/// (a hand's touch: 50–250 × in all on family A's tuning cases; an onset a sample off, a spike's
/// edge or AR noise: up to 6 ×; handling spikes of either sign, however large, cancel in it).
pub(super) const START_EXCESS: f64 = 16.0;
/// It goes on over the bins whose mean square exceeds this many times the holds' (a bin pooled
/// over 30 steps of AR noise: up to about 2.3 ×).
pub(super) const EXCESS: f64 = 3.0;
/// Width of a bin (s), at least one sample interval.
const BIN_S: f64 = 0.1;
/// How far before the onsets the residuals are looked at (s), at most half the shortest step.
const LOOK_S: f64 = 3.0;
/// A touch spans at least this many bins before the onsets.
const MIN_BINS: usize = 2;
/// After the onsets, the touch's window is at most this many of the steps' median time constant
/// (a press's lagged response falls to e^-3 of its size).
const PRESS_TAUS: f64 = 3.0;
/// Fewer steps than this pooled: no window is measured.
const MIN_STEPS: usize = 4;

/// The window the hand's touch takes around the onsets, measured on the residuals of the
/// configuration `cfg` fitted to every sample: none when the bins before the onsets look like the
/// holds (None). After the onsets it is measured only when there is a touch before them (the bins after an
/// onset carry the effects too; those before it carry none), and only when `after_onsets` (not
/// where a clip's steps take their onsets from the samples right after them).
pub(super) fn window(d: &Design, trials: &[Trial], cfg: &Config, hat: &Hat, after_onsets: bool) -> Option<TouchWindow> {
    let steps: usize = trials.iter().map(|tr| tr.segs.len()).sum();
    let shortest = step_spacings_s(trials).into_iter().fold(f64::INFINITY, f64::min);
    let look = LOOK_S.min(0.5 * shortest);
    let bin = trials.iter().map(sample_interval).fold(BIN_S, f64::max);
    let n_bins = (look / bin).floor() as usize;
    if steps < MIN_STEPS || n_bins < 4 {
        return None;
    }
    let x = solve(d, trials, &all_rows(trials), cfg, hat)?;
    let mut buf = Vec::new();
    let residuals: Vec<Vec<f64>> =
        trials.iter().enumerate().map(|(i, tr)| (0..tr.t.len()).map(|j| tr.v[j] - predict(d, i, tr, tr.t[j], &x, cfg, hat, &mut buf)).collect()).collect();
    let before = profile(trials, &residuals, n_bins, |tr, t| next_onset(tr, t).map(|(q, b)| (q, (b / bin) as usize)));
    let after = profile(trials, &residuals, n_bins, |tr, t| last_onset(tr, t).map(|(q, a)| (q, (a / bin) as usize)));
    let holds = before[n_bins / 2..].iter().map(|b| b.ss).sum::<f64>() / before[n_bins / 2..].iter().map(|b| b.n).sum::<usize>().max(1) as f64;
    if holds <= 0.0 {
        return None;
    }
    let starts = |p: &[Bin]| p[0].n > 0 && p[0].systematic_ms() > START_EXCESS * holds;
    let run = |p: &[Bin]| p[..n_bins / 2].iter().take_while(|b| b.n > 0 && b.ms() > EXCESS * holds).count() as f64 * bin;
    // one bin's excess is the onset's own misfit (a large slow relaxation leaves the data right at
    // the edge; a spike's edge; an onset a sample off)
    let before_onset_s = Some(run(&before)).filter(|&w| starts(&before) && w >= MIN_BINS as f64 * bin - 1e-9)?;
    // the response carries the press for a few of its time constants
    let after_onset_s = if after_onsets { run(&after).min(PRESS_TAUS * median_tau(trials)) } else { 0.0 };
    Some(TouchWindow { before_onset_s, after_onset_s })
}

/// One bin of time from the onsets, pooled over steps and trials: the residuals' sum of squares and
/// count, and their sums and counts over loading and over unloading steps.
#[derive(Clone, Copy, Default)]
struct Bin {
    ss: f64,
    n: usize,
    sum: [f64; 2],
    count: [usize; 2],
}

impl Bin {
    fn ms(&self) -> f64 {
        self.ss / self.n.max(1) as f64
    }
    /// The part of the mean square that is the same at every step of a direction (the squared means
    /// of loading and unloading steps, weighted by their counts): a touch's course repeats at every
    /// placement, spikes of either sign cancel.
    fn systematic_ms(&self) -> f64 {
        (0..2).map(|k| self.sum[k].powi(2) / self.count[k].max(1) as f64).sum::<f64>() / self.n.max(1) as f64
    }
    /// One residual `e` of a loading (`dir` 0) or unloading (1) step.
    fn push_residual(&mut self, dir: usize, e: f64) {
        self.ss += e * e;
        self.n += 1;
        self.sum[dir] += e;
        self.count[dir] += 1;
    }
}

/// The residuals (per trial and sample) per bin of time from the onsets (`bin_of`: a sample's step and bin), each step's
/// residuals less their mean over its reference bins (the far half: a level the model misses over a
/// whole hold, a trial's gain, is not the touch), pooled over steps and trials.
fn profile(trials: &[Trial], residuals: &[Vec<f64>], n_bins: usize, bin_of: impl Fn(&Trial, f64) -> Option<(usize, usize)>) -> Vec<Bin> {
    let mut bins = vec![Bin::default(); n_bins];
    for (tr, r) in trials.iter().zip(residuals) {
        let mut per_step: Vec<Vec<(usize, f64)>> = vec![Vec::new(); tr.segs.len()];
        for j in 0..tr.t.len() {
            if let Some((q, b)) = bin_of(tr, tr.t[j]).filter(|&(_, b)| b < n_bins) {
                per_step[q].push((b, r[j]));
            }
        }
        for (q, rs) in per_step.into_iter().enumerate() {
            let reference: Vec<f64> = rs.iter().filter(|(b, _)| *b >= n_bins / 2).map(|(_, e)| *e).collect();
            if reference.len() < 2 {
                continue;
            }
            let level = reference.iter().sum::<f64>() / reference.len() as f64;
            let dir = usize::from(tr.segs[q].load < tr.segs[q].prev);
            for (b, e) in rs {
                bins[b].push_residual(dir, e - level);
            }
        }
    }
    bins
}

/// The last step at or before the time `t` and how long after its onset `t` lies.
fn last_onset(tr: &Trial, t: f64) -> Option<(usize, f64)> {
    tr.segs.iter().enumerate().map(|(q, s)| (q, t - s.t0)).filter(|&(_, a)| a >= 0.0).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The next step after the time `t` and how long before its onset `t` lies (None after the last).
fn next_onset(tr: &Trial, t: f64) -> Option<(usize, f64)> {
    tr.segs.iter().enumerate().map(|(q, s)| (q, s.t0 - t)).filter(|&(_, b)| b > 0.0).min_by(|a, b| a.1.total_cmp(&b.1))
}

/// How long before the next step's onset the time `t` lies (None after the last onset).
fn before_onset(tr: &Trial, t: f64) -> Option<f64> {
    next_onset(tr, t).map(|(_, b)| b)
}

/// The trial without the samples of the touch's window around each onset (as given and as
/// diagnosed).
pub(super) fn without_touch(tr: &Trial, w: TouchWindow) -> Trial {
    let keep = |t: f64| before_onset(tr, t).is_none_or(|b| b > w.before_onset_s) && last_onset(tr, t).is_none_or(|(_, a)| a >= w.after_onset_s);
    let (t, v): (Vec<f64>, Vec<f64>) = tr.t.iter().zip(&tr.v).filter(|(t, _)| keep(**t)).map(|(t, v)| (*t, *v)).unzip();
    let (given_t, given_v): (Vec<f64>, Vec<f64>) = tr.given_t.iter().zip(&tr.given_v).filter(|(t, _)| keep(**t)).map(|(t, v)| (*t, *v)).unzip();
    Trial { t, v, given_t, given_v, ..tr.clone() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand's touch with a press before every logged change (0.25–0.75 s drawn per placement,
    /// the press 6–18 % of the step) takes a window around the onsets; the same trials without the
    /// touch take none, and so keep every sample.
    #[test]
    fn the_touch_window_is_measured_where_the_hand_is() {
        let plain = fixture::recs(91_000, |_| {});
        let b = fixture::built(&plain);
        assert!(b.touch.is_none());
        let touched = fixture::recs_with(
            91_000,
            |_| {},
            |p| {
                p.touch_s = 0.5;
                p.press_fraction = 0.12;
            },
        );
        let bt = fixture::built(&touched);
        let w = bt.touch.expect("a touch window");
        assert!((0.1..=1.0).contains(&w.before_onset_s) && (0.1..=1.5).contains(&w.after_onset_s), "{w:?}");
        // its samples are neither fitted nor scored; the others are all kept
        let before = |tr: &Trial, t: f64| before_onset(tr, t).is_some_and(|x| x <= w.before_onset_s);
        let after = |tr: &Trial, t: f64| last_onset(tr, t).is_some_and(|(_, x)| x < w.after_onset_s);
        assert!(bt.trials.iter().all(|tr| tr.t.iter().all(|&t| !before(tr, t) && !after(tr, t))));
        let whole = fixture::built_with_options(&touched, |o| o.pre.ramp = Some(crate::sensor::preprocess::Ramp { duration_s: 0.5, end_after_log_s: 0.0, smooth: true }));
        assert!(whole.touch.is_none(), "a modelled ramp takes no window");
    }

    /// What repeats at every step of a direction is systematic; spikes of either sign are not.
    #[test]
    fn a_touch_repeats_and_spikes_cancel() {
        let mut touch = Bin::default();
        let mut spikes = Bin::default();
        for k in 0..20 {
            let dir = k % 2;
            touch.push_residual(dir, if dir == 0 { 2.0 } else { -1.0 });
            spikes.push_residual(dir, if (k / 2) % 2 == 0 { 2.0 } else { -2.0 });
        }
        assert!((touch.systematic_ms() - touch.ms()).abs() < 1e-12, "{} {}", touch.systematic_ms(), touch.ms());
        assert!(spikes.systematic_ms() < 0.1 * spikes.ms(), "{} {}", spikes.systematic_ms(), spikes.ms());
    }
}
