//! The gate: the paired evidence that a change predicts held-out units better (a paired z, with a
//! signed-rank route one unit cannot veto), over every unit or only those a clip can change, and a
//! finding's confidence.

use super::*;

/// Paired z statistic of the held-out improvement over units (positive: the candidate predicts
/// better). Scale-free, so it does not depend on the noise per sample or the sampling rate.
/// The held-out evidence for `after` over `before`, per unit (squared errors): the paired z of the
/// differences, or, when `after` is at least [`MIN_ROBUST_GAIN`] better in held-out RMSE, the
/// larger of it and the Wilcoxon signed-rank z of the differences. The differences' z is vetoed by
/// one unit (a large change in one step widens their spread as much as a loss would); the ranks
/// weigh every unit alike, so a term that makes most units better passes however unevenly, and the
/// minimum gain keeps a consistent but negligible change out.
pub(super) fn paired_z(before: &[f64], after: &[f64]) -> f64 {
    let z = diff_z(before, after);
    let (sb, sa) = (before.iter().sum::<f64>(), after.iter().sum::<f64>());
    if before.len() == after.len() && sb > 0.0 && 1.0 - (sa / sb).sqrt() >= MIN_ROBUST_GAIN {
        z.max(signed_rank_z(before, after))
    } else {
        z
    }
}

/// The least held-out RMSE gain a model `c` must bring over the one it replaces: the conductance's
/// creep through the read-out, a form chosen after the fact (among up to eight subsets of the slow
/// terms in `through::replace_slow`, or in a named term's place in honest naming), needs the
/// relaxation spectrum's margin; any other, [`MIN_ROBUST_GAIN`]. (With 3 % the through form took a
/// true second time constant's name under an actuator's ramps, family A tuning seed 28 680, and a
/// null's place under the trial nuisances.)
pub(super) fn least_gain(c: &Config) -> f64 {
    if c.creep.through() {
        SPECTRUM_MARGIN
    } else {
        MIN_ROBUST_GAIN
    }
}

/// The paired z over held-out units that separates two explanations of one residual (a one-sided
/// test at about 2.3 % when the units' differences are near normal): honest naming's, and what a
/// hysteresis's fading memory must show against the permanent one.
pub const Z_SEPARATE: f64 = 2.0;

/// Least held-out RMSE gain for the signed-rank route of [`paired_z`].
pub const MIN_ROBUST_GAIN: f64 = 0.03;

/// The Wilcoxon signed-rank statistic of before − after over units, as a z (normal approximation;
/// zero differences left out, tied magnitudes given their mean rank).
pub(super) fn signed_rank_z(before: &[f64], after: &[f64]) -> f64 {
    let mut d: Vec<f64> = before.iter().zip(after).map(|(a, b)| a - b).filter(|x| *x != 0.0).collect();
    let n = d.len();
    if n < 3 {
        return 0.0;
    }
    d.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let mut w = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && d[j + 1].abs() == d[i].abs() {
            j += 1;
        }
        let rank = 0.5 * ((i + 1) + (j + 1)) as f64;
        w += d[i..=j].iter().map(|x| rank * x.signum()).sum::<f64>();
        i = j + 1;
    }
    let nf = n as f64;
    w / (nf * (nf + 1.0) * (2.0 * nf + 1.0) / 6.0).sqrt()
}

/// The paired z of the per-unit differences.
pub(super) fn diff_z(before: &[f64], after: &[f64]) -> f64 {
    if before.len() != after.len() || before.len() < 3 {
        return 0.0;
    }
    let d: Vec<f64> = before.iter().zip(after).map(|(a, b)| a - b).collect();
    let m = d.len() as f64;
    let mean = d.iter().sum::<f64>() / m;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
    if sd <= 0.0 {
        return 0.0;
    }
    mean / (sd / m.sqrt())
}

/// The one-sided normal quantile at half the tail of [`MIN_Z`] (p 0.00135 / 2): the better of two
/// groups of evidence must reach it.
pub(super) const TWO_GROUP_Z: f64 = 3.205;

/// The paired z of a change that adds or removes a clip (`clip`): a clip can only change the units
/// that reach it, so its evidence is tested there, in each group of `clip_units` on its own (the
/// largest z counts, scaled by MIN_Z / [`TWO_GROUP_Z`] when there are two: Bonferroni's correction
/// for the second chance); any other change over every unit.
pub(super) fn change_z(clip: bool, before: &Score, after: &Score, clip_units: &[Vec<(usize, usize)>]) -> f64 {
    if clip {
        let groups: Vec<&Vec<(usize, usize)>> = clip_units.iter().filter(|g| !g.is_empty()).collect();
        if groups.is_empty() {
            return paired_z(&before.units, &after.units);
        }
        let best = groups.iter().map(|g| paired_z_on(before, after, g)).fold(f64::NEG_INFINITY, f64::max);
        // the better of two groups is a second chance: Bonferroni's, the better z must reach the
        // one-sided level of MIN_Z halved (z 3.205 for 3.0), so it is scaled to be judged at MIN_Z
        if groups.len() > 1 {
            best * MIN_Z / TWO_GROUP_Z
        } else {
            best
        }
    } else {
        paired_z(&before.units, &after.units)
    }
}

/// Paired z over the units listed in `only` (all units when it is empty). With fewer than three
/// such units a z cannot be formed: every one of them must then at least halve its error, which
/// counts as passing (MIN_Z), else 0.
pub(super) fn paired_z_on(before: &Score, after: &Score, only: &[(usize, usize)]) -> f64 {
    if only.is_empty() {
        return paired_z(&before.units, &after.units);
    }
    let pick = |s: &Score| -> Vec<f64> { s.unit_keys.iter().zip(&s.units).filter(|(k, _)| only.contains(k)).map(|(_, v)| *v).collect() };
    let (b, a) = (pick(before), pick(after));
    if b.len() < 3 {
        return if !b.is_empty() && b.iter().zip(&a).all(|(x, y)| *y <= 0.5 * x) { MIN_Z } else { 0.0 };
    }
    paired_z(&b, &a)
}

/// Whether effect `e`'s fitted term in the model `c` (solution `x`) has its physics' sign: creep
/// grows the response in the direction of each change (a fraction per decade ≥ 0) and the
/// unloading branch of a hysteresis stays toward the peak's level (a fraction ≥ 0). A term of the
/// other sign is not that effect, however well it fits the residual (on family A's trial-nuisance
/// nulls a hysteresis of −0.17 % took a rest state's misfit at z 3.15; a twin cannot carry one).
/// The other terms take either sign: a second relaxation may take part of a step back (a
/// cover's), a drift may fall.
pub(super) fn of_its_sign(d: &Design, c: &Config, x: &[f64], e: Effect) -> bool {
    match e {
        Effect::Creep | Effect::Hysteresis => x.get(term_col(d, c, e)).is_none_or(|&a| a >= 0.0),
        _ => true,
    }
}

/// A finding's confidence from its held-out gain and its ΔBIC.
pub(super) fn confidence(dbic: f64, gain: f64) -> &'static str {
    if dbic < -100.0 && gain > 0.05 {
        "high"
    } else if dbic < -30.0 {
        "medium"
    } else {
        "low"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hysteresis mirrored (the unloading branch pushed away from the peak's level by what a 1 %
    /// hysteresis pulls it toward it, on the same noise) fits a negative fraction and is not a
    /// hysteresis; the true one is; creep likewise on a creep and its mirror.
    #[test]
    fn a_creep_or_a_hysteresis_of_the_other_sign_is_not_that_effect() {
        let cases: [(Effect, &dyn Fn(&mut crate::params::sensor::SensorParams)); 2] =
            [(Effect::Hysteresis, &|s| s.effects.hysteresis = 0.01), (Effect::Creep, &|s| s.effects.creep_per_decade = 0.01)];
        for (k, (e, f)) in cases.into_iter().enumerate() {
            let seed = 76_000 + 10 * k as u64;
            let (plain, with) = (fixture::recs(seed, |_| {}), fixture::recs(seed, f));
            let mut mirrored = plain.clone();
            for (m, (p, w)) in mirrored.iter_mut().zip(plain.iter().zip(&with)) {
                m.response = p.response.iter().zip(&w.response).map(|(a, b)| 2.0 * a - b).collect();
            }
            for (recs, want) in [(with, true), (mirrored, false)] {
                let b = fixture::built(&recs);
                let steps = ClipSteps::of(&b.trials, None, false);
                let c = candidate(e, &b.base_cfg, &fixture::ctx(&b, &steps, &b.hat)).unwrap();
                let (_, x) = score(&b.d, &b.trials, &c, &b.hat).unwrap();
                assert_eq!(of_its_sign(&b.d, &c, &x, e), want, "{e:?}: coefficient {}", x[term_col(&b.d, &c, e)]);
            }
        }
    }

    /// One unit that improves a lot does not veto a term that makes every unit better (issue 15,
    /// item 5): the differences' z falls under MIN_Z, the log ratios' does not; a change that
    /// makes no unit better passes neither way, nor does a consistent change under 3 %.
    #[test]
    fn one_unit_does_not_veto_a_term_that_helps_every_unit() {
        let before: Vec<f64> = (0..30).map(|k| 1.0 + 0.1 * (k % 7) as f64).collect();
        let mut after: Vec<f64> = before.iter().enumerate().map(|(k, b)| b * (0.8 + 0.05 * (k % 3) as f64)).collect();
        let mut b2 = before.clone();
        b2[29] = 40.0;
        after[29] = 1.0;
        assert!(diff_z(&b2, &after) < MIN_Z, "{}", diff_z(&b2, &after));
        assert!(paired_z(&b2, &after) >= MIN_Z, "{}", paired_z(&b2, &after));
        let worse: Vec<f64> = before.iter().map(|b| b * 1.05).collect();
        assert!(paired_z(&before, &worse) < 0.0);
        let tiny: Vec<f64> = before.iter().map(|b| b * 0.99).collect();
        assert_eq!(paired_z(&before, &tiny), diff_z(&before, &tiny));
    }
}
