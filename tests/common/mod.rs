//! Helpers shared by the property tests.

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;
use tipforge::error::Problems;

/// A rejected parameter file must say what is wrong: at least one problem, each with its TOML
/// path and a message.
pub fn rejected_clearly(problems: &Problems) -> Result<(), TestCaseError> {
    prop_assert!(!problems.0.is_empty());
    for pr in &problems.0 {
        prop_assert!(!pr.path.is_empty() && !pr.message.is_empty());
    }
    Ok(())
}

/// The generator must produce enough of both kinds to mean something (checked at full size).
pub fn enough_of_both(what: &str, valid: usize, invalid: usize, cases: u32, full: u32, min_valid: usize, min_invalid: usize) {
    println!("random {what}: {valid} valid built and checked, {invalid} rejected with input errors");
    assert!(valid >= min_valid || cases < full, "only {valid} valid random {what} of {cases}; widen the generator");
    assert!(invalid >= min_invalid || cases < full, "the generator must also produce invalid {what} ({invalid})");
}

/// A part refused only by the minimum-feature check: valid parameters whose geometry leaves a wall
/// under two nozzle widths. The build stops there with the check's message (nothing written): a
/// clear refusal, counted apart.
pub fn only_sub_nozzle(v: &[tipforge::checks::Violation]) -> bool {
    !v.is_empty() && v.iter().all(|x| x.rule == tipforge::checks::min_feature::RULE)
}

/// Counts of a property test's cases: built and wholly clean, refused by the minimum-feature check
/// only (built, every other check passed), rejected with input errors.
#[derive(Default)]
pub struct Tally {
    pub valid: std::sync::atomic::AtomicUsize,
    pub narrow: std::sync::atomic::AtomicUsize,
    pub invalid: std::sync::atomic::AtomicUsize,
}

impl Tally {
    /// A built part's check results: counted clean or refused-narrow; any other violation fails.
    pub fn built(&self, v: &[tipforge::checks::Violation], what: &str) -> Result<(), TestCaseError> {
        use std::sync::atomic::Ordering::Relaxed;
        if only_sub_nozzle(v) {
            self.narrow.fetch_add(1, Relaxed);
        } else {
            prop_assert!(v.is_empty(), "checks failed: {:?}\n{}", v, what);
            self.valid.fetch_add(1, Relaxed);
        }
        Ok(())
    }

    /// At full size: enough built (clean or refused-narrow: both passed every other check), enough
    /// wholly clean (the minimum-feature check is not refusing everything), and enough invalid.
    pub fn assert_enough(&self, what: &str, cases: u32, full: u32, min_built: usize, min_clean: usize, min_invalid: usize) {
        use std::sync::atomic::Ordering::Relaxed;
        let (valid, narrow, invalid) = (self.valid.load(Relaxed), self.narrow.load(Relaxed), self.invalid.load(Relaxed));
        println!("random {what} refused by the minimum-feature check: {narrow}");
        assert!(valid >= min_clean || cases < full, "only {valid} wholly clean random {what}");
        enough_of_both(what, valid + narrow, invalid, cases, full, min_built, min_invalid);
    }
}
