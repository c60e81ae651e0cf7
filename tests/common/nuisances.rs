//! Family A's trial nuisances (the bench's "trial nuisances" rows and the tests on them), shared by
//! `benches/discovery.rs` and `tests/diagnose.rs` through `#[path]`.

use tipforge::params::sensor::SensorParams;

/// The lab's nuisances per trial: gains ±3 % (1 s.d.), a rest relaxation up to 2σ with τ 100 s, and
/// a quarter of the noise variance AR(1) with ρ 0.95.
pub fn trial_nuisances(s: &mut SensorParams) {
    s.nuisance.gain_jitter = 0.03;
    s.nuisance.rest_v = 2.0 * s.noise_v;
    s.nuisance.rest_tau_s = 100.0;
    s.nuisance.noise_ar_rho = 0.95;
    s.nuisance.noise_ar_share = 0.25;
}
