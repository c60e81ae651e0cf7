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
    if robust_gain(before, after) {
        z.max(signed_rank_z(before, after))
    } else {
        z
    }
}

/// Whether `after`'s units sum to a held-out RMSE at least [`MIN_ROBUST_GAIN`] below `before`'s
/// (the condition of the robust routes).
fn robust_gain(before: &[f64], after: &[f64]) -> bool {
    let (sb, sa) = (before.iter().sum::<f64>(), after.iter().sum::<f64>());
    before.len() == after.len() && sb > 0.0 && 1.0 - (sa / sb).sqrt() >= MIN_ROBUST_GAIN
}

/// The z of a sample's mean against zero (mean over its standard error); none with fewer than three
/// values or no spread.
fn mean_z(d: &[f64]) -> Option<f64> {
    if d.len() < 3 {
        return None;
    }
    let m = d.len() as f64;
    let mean = d.iter().sum::<f64>() / m;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt();
    (sd > 0.0).then(|| mean / (sd / m.sqrt()))
}

/// [`paired_z`] of `after` over `before`, their held-out units paired by (trial, segment): two
/// models may list the same units in another order. Two models scored on different units are not
/// compared (0), as unequal lists were not.
///
/// One recording scored by blocks of its holds (`Score::blocks`) has units of unlike scale: a hold
/// under load and a recovery at zero, where a term may change the error a hundredfold in one and
/// leave the other as it was. There the ratio route of [`paired_z_by_ratio`] is taken as well.
pub(super) fn z_over(before: &Score, after: &Score) -> f64 {
    let by_route = |b: &[f64], a: &[f64]| if before.blocks > 0 { paired_z_by_ratio(b, a) } else { paired_z(b, a) };
    if before.unit_keys == after.unit_keys {
        return by_route(&before.units, &after.units);
    }
    let (b, a) = units_on(before, after, &before.unit_keys);
    if b.len() != before.units.len() || a.len() != after.units.len() {
        return 0.0;
    }
    by_route(&b, &a)
}

/// [`paired_z`], or, when `after` is at least [`MIN_ROBUST_GAIN`] better in held-out RMSE, the
/// larger of it and the z of the per-unit log ratios ln(before / after) (the issue's "z on
/// per-unit log error ratios"): every unit says by what factor its error changed, whatever its
/// scale, so units a term leaves alone weigh as little as they change, and a hundredfold gain in
/// half of them is not vetoed by the spread it brings to the differences (an FSR402-like single
/// step whose recovery a conductance's creep predicts 100 times better: differences' z 2.65,
/// signed ranks' 2.48, the ratios' 4.5).
pub(super) fn paired_z_by_ratio(before: &[f64], after: &[f64]) -> f64 {
    let z = paired_z(before, after);
    if !robust_gain(before, after) {
        return z;
    }
    let r: Vec<f64> = before.iter().zip(after).filter(|(b, a)| **b > 0.0 && **a > 0.0).map(|(b, a)| (b / a).ln()).collect();
    mean_z(&r).map_or(z, |zr| z.max(zr))
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

/// Least held-out RMSE gain of a term of the catalogue in the forward step (issue 15, item 5: the
/// paired test together with a minimum gain). The value sits between two measured cases and is
/// not derived: the 3 % cost a 1σ creep under a hand's touch and the trials' nuisances its
/// name (held out 1.3–2.7 %, where the trials' rest states dominate the error:
/// `a_hands_touch_is_handling_and_hides_no_creep`); 1 % kept out the second τ (+0.64 %) through
/// which a conductance's creep read at the floor reaches its name (a warm-up drift and that second
/// τ merge into creep) and left a drift named; with no minimum, once a jump's columns stopped
/// being 10⁴² before its onset (stop 46), a hysteresis of +0.43 % (z 3.01) entered there too and
/// the creep lost its name (`a_conductance_creep_read_at_the_floor_is_named_creep`).
pub const MIN_TERM_GAIN: f64 = 0.005;

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
    if before.len() != after.len() {
        return 0.0;
    }
    let d: Vec<f64> = before.iter().zip(after).map(|(a, b)| a - b).collect();
    mean_z(&d).unwrap_or(0.0)
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
            return z_over(before, after);
        }
        // a group where every unit halves its error passes at the level the groups are judged at
        let passing = if groups.len() > 1 { TWO_GROUP_Z } else { MIN_Z };
        let best = groups.iter().map(|g| paired_z_on(before, after, g, passing)).fold(f64::NEG_INFINITY, f64::max);
        // the better of two groups is a second chance: Bonferroni's, the better z must reach the
        // one-sided level of MIN_Z halved (z 3.205 for 3.0), so it is scaled to be judged at MIN_Z
        if groups.len() > 1 {
            best * MIN_Z / TWO_GROUP_Z
        } else {
            best
        }
    } else {
        z_over(before, after)
    }
}

/// Whether a signed-rank test over `n` units can reach the level `z` at all: its largest z, with
/// every unit better, is n(n+1)/2 over its standard deviation (2.93 for 11 units, 3.06 for 12,
/// 3.18 for 13 and 3.29 for 14).
fn rank_can_reach(n: usize, z: f64) -> bool {
    let nf = n as f64;
    0.5 * nf * (nf + 1.0) / (nf * (nf + 1.0) * (2.0 * nf + 1.0) / 6.0).sqrt() >= z
}

/// Paired z over the units listed in `only` (all units when it is empty). Where the signed-rank
/// test cannot reach the level the group is judged at (`passing`: fewer than 12 units at
/// [`MIN_Z`], 14 at [`TWO_GROUP_Z`]) and every unit at least halves its held-out squared error
/// (its RMS falls by at least 29 %), that counts as passing: a few units whose errors differ by orders of magnitude (a rail's
/// rises into it, one per trial, cut 60×, 170× and 2.4× on family A's rail with the trials' gains)
/// leave the z of their differences low, and no rank test over them can pass (with fewer than three
/// units no z can be formed at all). Where they do not all halve, the evidence inside the trials
/// decides ([`within_trials_z`]: a trial's top barely reaching the rail changes a few of its
/// samples, and its unit as a whole by little).
pub(super) fn paired_z_on(before: &Score, after: &Score, only: &[(usize, usize)], passing: f64) -> f64 {
    if only.is_empty() {
        return z_over(before, after);
    }
    let (b, a) = units_on(before, after, only);
    let halves = !b.is_empty() && b.iter().zip(&a).all(|(x, y)| *x > 0.0 && *y <= 0.5 * x);
    let z = if b.len() < 3 { 0.0 } else { paired_z(&b, &a) };
    if rank_can_reach(b.len(), passing) {
        z
    } else if halves {
        z.max(passing)
    } else {
        within_trials_z(before, after, only).map_or(z, |w| z.max(w))
    }
}

/// The least blocks of a trial's units for its own test in [`within_trials_z`].
const WITHIN_LEAST_BLOCKS: usize = 6;

/// The held-out evidence inside the trials, for a group of units too small for any test over units
/// (a rail's rises into it: one per trial): each held-out trial's units cut into blocks of
/// [`heldout::WITHIN_BLOCK_S`], the blocks' signed-rank z per trial (a trial with fewer than
/// [`WITHIN_LEAST_BLOCKS`] counts 0), combined over the trials by Stouffer's sum over √(trials).
/// The blocks of one trial are not replicates: the two models' difference there is one curve,
/// fitted once without that trial, with the trial's own offset shared by every block. A trial's z
/// measures how consistently the change helps over its time, and grows with the hold's length (20
/// blocks: at most 3.92; 36: 5.23). So each trial's z counts at most [`MIN_Z`] (one passing
/// trial's worth), and the group must span two trials or more: one trial alone, however
/// consistent and long, gives at most MIN_Z/√2 — a term shared by the trials must help in most of
/// them. None (no evidence inside the trials) when there are no blocks (one recording), when the
/// group lies in one trial, or when its held-out RMS falls by less than [`MIN_ROBUST_GAIN`].
pub(super) fn within_trials_z(before: &Score, after: &Score, only: &[(usize, usize)]) -> Option<f64> {
    let (b, a) = units_on(before, after, only);
    let trials: std::collections::BTreeSet<usize> = only.iter().map(|u| u.0).collect();
    if before.within.is_empty() || trials.len() < 2 || !robust_gain(&b, &a) {
        return None;
    }
    // `within` is sorted by its key (it comes from an ordered map)
    let after_block = |key: &(usize, usize, u64)| after.within.binary_search_by(|(x, _)| x.cmp(key)).ok().map(|j| after.within[j].1);
    let trial_z = |k: usize| {
        let (bk, ak): (Vec<f64>, Vec<f64>) =
            before.within.iter().filter(|((t, s, _), _)| *t == k && only.contains(&(*t, *s))).filter_map(|(key, e)| after_block(key).map(|f| (*e, f))).unzip();
        if bk.len() < WITHIN_LEAST_BLOCKS {
            0.0
        } else {
            signed_rank_z(&bk, &ak).min(MIN_Z)
        }
    };
    Some(trials.iter().map(|&k| trial_z(k)).sum::<f64>() / (trials.len() as f64).sqrt())
}

/// Two scores' held-out units (squared errors) whose (trial, segment) is among `only`, paired by
/// that key (in `before`'s order; a key only one of them scored is left out): two models may not
/// list their units in the same order, nor score the same ones.
pub(super) fn units_on(before: &Score, after: &Score, only: &[(usize, usize)]) -> (Vec<f64>, Vec<f64>) {
    before
        .unit_keys
        .iter()
        .zip(&before.units)
        .filter(|(k, _)| only.contains(k))
        .filter_map(|(k, b)| after.unit_keys.iter().position(|x| x == k).map(|j| (*b, after.units[j])))
        .unzip()
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

    /// Units are paired by their (trial, segment), not by their place in the lists: a model that
    /// lists its units in another order, or scored one more, is compared unit by unit over a
    /// group of them (`units_on`); over every unit (`z_over`), the same units in another order are,
    /// and two models scored on different units are not compared.
    #[test]
    fn units_are_paired_by_their_keys() {
        let sc = |keys: &[(usize, usize)], units: &[f64]| Score { unit_keys: keys.to_vec(), units: units.to_vec(), unit_n: vec![1; keys.len()], ..Default::default() };
        let before = sc(&[(0, 1), (0, 2), (1, 1)], &[1.0, 2.0, 3.0]);
        let after = sc(&[(1, 1), (9, 9), (0, 2), (0, 1)], &[30.0, 99.0, 20.0, 10.0]);
        assert_eq!(units_on(&before, &after, &[(0, 1), (1, 1), (0, 2)]), (vec![1.0, 2.0, 3.0], vec![10.0, 20.0, 30.0]));
        assert_eq!(units_on(&before, &after, &[(0, 2), (5, 5)]), (vec![2.0], vec![20.0]));
        // the paired z over every unit pairs them by key too: the same as over the lists aligned;
        // two models scored on different units are not compared
        let (aligned, shuffled) = (sc(&[(0, 1), (0, 2), (1, 1)], &[10.0, 20.0, 30.0]), sc(&[(1, 1), (0, 2), (0, 1)], &[30.0, 20.0, 10.0]));
        assert_eq!(z_over(&before, &shuffled), paired_z(&before.units, &aligned.units));
        assert_ne!(z_over(&before, &shuffled), paired_z(&before.units, &shuffled.units));
        assert_eq!(z_over(&before, &after), 0.0);
    }

    /// A rail's rises into it, one per trial (family A's tuning seed 26 890 under family B's forms:
    /// 0.130 → 0.055, 0.262 → 0.026 and 0.030 → 0.027): no test over three units can pass, and the
    /// third does not halve; inside the trials, 20 blocks each (one of trial 0's not scored by the
    /// rail's model, and left out), every trial's blocks improve, and the trials' combined z
    /// passes — as their sum over √3, each capped at MIN_Z (a mean would not exceed MIN_Z). Blocks
    /// of units outside the group (3 × worse) are left out. One trial whose blocks all improve, however many, while the others'
    /// go up and down by 3 %, cannot pass alone; nor can a group within one trial, a change under
    /// 3 % however consistent, or scores without blocks (one recording's).
    #[test]
    fn a_rail_passes_on_the_blocks_inside_every_trial_not_one_trials() {
        // `n` blocks per trial in the group's unit (segment 4) and in segment 5, outside it; `f(k, j)`
        // is block j's share of trial k's error after (segment 5: 3 × worse)
        let score = |f: &dyn Fn(usize, usize) -> f64, before: &[f64], n: usize| {
            let mut within: Vec<((usize, usize, u64), f64)> = (0..3)
                .flat_map(|k| (0..n).map(move |j| (k, j)))
                .flat_map(|(k, j)| {
                    let e = before[k] / n as f64 * (1.0 + 0.3 * ((7 * j + k) % 5) as f64 / 5.0);
                    [((k, 4, j as u64), e * f(k, j)), ((k, 5, j as u64), e * if f(k, j) < 1.0 { 3.0 } else { 1.0 })]
                })
                .collect();
            within.sort_by(|a, b| a.0.cmp(&b.0));
            let unit = |k: usize, s: usize| within.iter().filter(|((t, q, _), _)| *t == k && *q == s).map(|(_, e)| e).sum::<f64>();
            let (unit_keys, units): (Vec<(usize, usize)>, Vec<f64>) = (0..3).flat_map(|k| [((k, 4), unit(k, 4)), ((k, 5), unit(k, 5))]).unzip();
            Score { unit_n: vec![2000; units.len()], unit_keys, units, within, ..Default::default() }
        };
        let before_units = [0.130, 0.262, 0.030];
        let keys = [(0, 4), (1, 4), (2, 4)];
        let before = score(&|_, _| 1.0, &before_units, 20);
        let rail = |k: usize, j: usize| [0.42, 0.10, 0.90][k] * if j % 4 == 0 { 1.05 } else { 1.0 };
        let mut after = score(&rail, &before_units, 20);
        // a block the rail's model did not score
        after.within.retain(|(key, _)| *key != (0, 4, 7));
        let (b, a) = units_on(&before, &after, &keys);
        assert!(paired_z(&b, &a) < MIN_Z);
        let z = within_trials_z(&before, &after, &keys).expect("evidence inside the trials");
        assert!(z > 4.0, "{z}");
        assert!(paired_z_on(&before, &after, &keys, MIN_Z) >= MIN_Z);
        // one trial alone: all its blocks better (40 of them: a rank z of 5.5 uncapped), the others'
        // up and down
        let one = score(
            &|k, j| {
                if k == 1 {
                    0.2
                } else if (j + k) % 2 == 0 {
                    0.97
                } else {
                    1.03
                }
            },
            &before_units,
            40,
        );
        let before40 = score(&|_, _| 1.0, &before_units, 40);
        let z1 = within_trials_z(&before40, &one, &keys).expect("evidence inside the trials");
        assert!(z1 < MIN_Z, "{z1}");
        // the group within one trial
        assert_eq!(within_trials_z(&before, &after, &[(1, 4)]), None);
        // every block 1 % better: consistent, but under the least gain
        let tiny = score(&|_, _| 0.98, &before_units, 20);
        assert_eq!(within_trials_z(&before, &tiny, &keys), None);
        // without blocks (one recording's score), nothing
        let bare = |sc: &Score| Score { within: vec![], ..sc.clone() };
        assert_eq!(within_trials_z(&bare(&before), &bare(&after), &keys), None);
    }

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

    /// A clip's group of a few units passes when every unit at least halves its error, however
    /// different their sizes (family A's rail with the trials' gains, tuning seed 24 800: the three
    /// rises into it went 0.102 → 0.0017, 0.129 → 0.0008 and 0.0017 → 0.0007, z of the differences
    /// 1.98); one unit that does not halve leaves it to the z; with 12 units the rank test decides.
    #[test]
    fn a_few_units_that_all_halve_pass_a_clips_group() {
        let score = |units: Vec<f64>| Score {
            rmse: 0.0,
            heldout_rmse: 0.0,
            bic: 0.0,
            params: 0,
            n: 0,
            unit_keys: (0..units.len()).map(|k| (k, 4)).collect(),
            unit_n: vec![100; units.len()],
            units,
            blocks: 0,
            within: vec![],
        };
        let (before, after) = (score(vec![0.102, 0.129, 0.0017]), score(vec![0.0017, 0.0008, 0.0007]));
        let keys = before.unit_keys.clone();
        assert!(paired_z(&before.units, &after.units) < MIN_Z);
        assert_eq!(paired_z_on(&before, &after, &keys, MIN_Z), MIN_Z);
        let one_holds = score(vec![0.0017, 0.0008, 0.0012]);
        assert!(paired_z_on(&before, &one_holds, &keys, MIN_Z) < MIN_Z);
        // two groups (the rises, and falls that do not change): the rises' passing value survives
        // Bonferroni's scaling
        let six = |u: [f64; 6]| Score { unit_keys: vec![(0, 4), (1, 4), (2, 4), (0, 7), (1, 7), (2, 7)], ..score(u.to_vec()) };
        let (b6, a6) = (six([0.102, 0.129, 0.0017, 0.018, 0.005, 0.0008]), six([0.0017, 0.0008, 0.0007, 0.019, 0.0038, 0.0007]));
        let groups = vec![keys.clone(), vec![(0, 7), (1, 7), (2, 7)]];
        assert!(change_z(true, &b6, &a6, &groups) >= MIN_Z, "{}", change_z(true, &b6, &a6, &groups));
        assert!(!rank_can_reach(11, MIN_Z) && rank_can_reach(12, MIN_Z));
        assert!(!rank_can_reach(13, TWO_GROUP_Z) && rank_can_reach(14, TWO_GROUP_Z));
        // units without any error before cannot halve it
        let (zero, still) = (score(vec![0.0, 0.0, 0.0]), score(vec![0.0, 0.0, 0.0]));
        assert!(paired_z_on(&zero, &still, &keys, MIN_Z) < MIN_Z);
        // 12 units that all halve but whose differences vary: the rank test passes on its own
        let (b12, a12) = (score((0..12).map(|k| 0.01 * (1 + k) as f64).collect()), score((0..12).map(|k| 0.004 * (1 + k % 3) as f64).collect()));
        let k12 = b12.unit_keys.clone();
        assert!(paired_z_on(&b12, &a12, &k12, MIN_Z) >= MIN_Z);
    }

    /// One recording's blocks: eleven of a hold under load, which a term leaves within a few per
    /// cent (eight a little worse), and eleven of a recovery whose error it divides by 9–370 (the
    /// FSR402-like step that was named nothing). The differences' z and the signed ranks stay
    /// under MIN_Z; the log ratios pass. Below the least gain the ratios are not taken, and ratios
    /// of either sign (a gain of 8 % in the sum) do not pass.
    #[test]
    fn one_recordings_blocks_of_unlike_scale_are_judged_by_their_ratios() {
        let hold: Vec<f64> = (0..11).map(|k| 3e-4 * (1.0 + 0.05 * (k % 4) as f64)).collect();
        let hold_after: Vec<f64> = hold.iter().enumerate().map(|(k, b)| b * if k % 4 == 0 { 0.97 } else { 1.03 }).collect();
        let rec: Vec<f64> = (0..11).map(|k| 0.11 * 0.7f64.powi(k)).collect();
        let rec_after: Vec<f64> = (0..11).map(|k| 3e-4 * (1.0 + 0.1 * (k % 3) as f64)).collect();
        let (before, after) = ([hold.clone(), rec].concat(), [hold_after, rec_after].concat());
        assert!(paired_z(&before, &after) < MIN_Z, "{}", paired_z(&before, &after));
        assert!(paired_z_by_ratio(&before, &after) >= MIN_Z, "{}", paired_z_by_ratio(&before, &after));
        // a consistent gain under MIN_ROBUST_GAIN (1 %): the differences' z as it is
        let slightly: Vec<f64> = hold.iter().map(|b| 0.98 * b).collect();
        assert!(!robust_gain(&hold, &slightly));
        assert_eq!(paired_z_by_ratio(&hold, &slightly), paired_z(&hold, &slightly));
        // ratios of either sign: a fifth of the error in half the units, half as much again in the
        // rest (8 % better in the sum, so the ratio route is taken, and its z is under MIN_Z)
        let ones = vec![1.0; 22];
        let mixed: Vec<f64> = (0..22).map(|k| if k % 2 == 0 { 0.2 } else { 1.5 }).collect();
        assert!(robust_gain(&ones, &mixed));
        assert!(paired_z_by_ratio(&ones, &mixed) < MIN_Z, "{}", paired_z_by_ratio(&ones, &mixed));
    }
}
