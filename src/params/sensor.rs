//! Sensor-model and protocol parameter files for the simulator.

use super::{Collector, Schema, SourceFile};
use crate::error::Result;
use serde::Deserialize;
use std::collections::BTreeMap;

type Table = BTreeMap<String, toml::Value>;

#[derive(Debug, Clone, PartialEq)]
pub struct Circuit {
    pub vcc_v: f64,
    pub r_m_ohm: f64,
    pub sensor_high: bool,
    pub adc_bits: u32,
    pub vref_v: f64,
    pub sample_rate_hz: f64,
}

/// Switchable effects; a magnitude of 0 turns an effect off.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Effects {
    /// Fraction of the equilibrium voltage added per decade of time under constant load.
    pub creep_per_decade: f64,
    pub creep_time_s: f64,
    /// Creep superposed over the load history (each change adds its own log-time creep, which
    /// keeps going after later changes: Boltzmann superposition), instead of restarting at every
    /// step with the previous creep relaxing away at the first-order τ.
    pub creep_superposed: bool,
    /// Creep of the sensor's conductance, seen through the read-out (a divider compresses it at
    /// its top and shows it in full at its bottom), instead of creep of the response itself.
    pub creep_in_conductance: bool,
    /// Creep as a Prony spectrum (family B's form) when it has terms (0: the log-time form): with
    /// `creep_superposed`, every change of level drives Σ_k w_k · (1 − e^(−t/τ_k)), with
    /// `creep_spectrum_terms` time constants τ_k log-spaced from `creep_spectrum_min_s` to
    /// `creep_spectrum_max_s` and weights w_k ∝ (τ_k/τ_min)^`creep_spectrum_tilt` (0: flat in log τ,
    /// above 0: rising toward the slow end, below 0: toward the fast end) scaled so that Σ w_k is the span in decades (at least
    /// one): a change's creep then reaches `creep_per_decade` × the decades spanned, as a log-time
    /// creep over the same span would, but stops growing past τ_max.
    pub creep_spectrum_terms: usize,
    pub creep_spectrum_min_s: f64,
    pub creep_spectrum_max_s: f64,
    pub creep_spectrum_tilt: f64,
    /// Fraction of (V_eq(F_max) − V_eq(F)) kept on the unloading branch; with
    /// `hysteresis_in_conductance`, the conductance gained per newton of the peak's force gap, in
    /// units of g_ref.
    pub hysteresis: f64,
    /// The hysteresis of the sensor's conductance, seen through the read-out (family B's form): on
    /// the unloading branch the conductance gains `hysteresis` · (F_max − F) / 1 N · g_ref, instead of
    /// the response keeping the fraction `hysteresis` of (V_eq(F_max) − V_eq(F)).
    pub hysteresis_in_conductance: bool,
    /// The peak's memory time (s): with it (> 0) the remembered peak force fades toward the present
    /// force, dP/dt = −(P − F)/T while F < P (the gap closes over minutes); 0: kept for good.
    pub hysteresis_memory_s: f64,
    /// Fraction of each step in a second, slower relaxation, and its time constant.
    pub second_fraction: f64,
    pub second_tau_s: f64,
    /// The second relaxation is the sensor's conductance's, seen through the read-out (family B's
    /// form): the conductance is the mix (1 − fraction) · G(v_fast) + fraction · G_slow, where
    /// G(v_fast) is the conductance the divider shows at the fast part's response (relaxing in the
    /// response at the first-order τ) and G_slow relaxes toward the present target's conductance
    /// with `second_tau_s`; instead of the response being the mix of two relaxations.
    pub second_in_conductance: bool,
    /// Baseline drift: linear rate and a slow sinusoidal wander.
    pub drift_v_per_s: f64,
    /// With a time constant (> 0): the drift is an exponential warm-up from each trial's start,
    /// rate · τ · (1 − e^(−t/τ)), with the same initial rate; 0: linear.
    pub drift_warmup_tau_s: f64,
    pub wander_v: f64,
    pub wander_period_s: f64,
    /// Output clipped at this voltage (0 = off).
    pub saturation_v: f64,
    /// The clip acts on the signal before the noise is added (an amplifier's rail: the plateau is
    /// the rail ± noise), not on the recorded samples (the ADC's reference: they pile up at one value).
    pub saturation_before_noise: bool,
    /// Handling spike at each placement/removal: amplitude and duration.
    pub spike_v: f64,
    pub spike_s: f64,
    /// Handling spikes as presses of force (family B's form; 0 = off): at about half of the
    /// placements and removals, a sin² press of about this many times the weight changed (each
    /// drawn 0.3–1.7 × it), 0.03–0.15 s long (no longer than the touch), within the hand's touch
    /// (from the landing without one), seen through the sensor's response (its conductance law and
    /// first-order relaxation), not added to the output. In addition to `spike_v`'s spikes;
    /// `spike_s` does not apply to them.
    pub spike_force_share: f64,
}

/// What differs between the trials of one data set and is not sensor physics (all 0 = off): the
/// sensor's gain (temperature, the hand), a relaxation left from before the trial (how long the
/// sensor rested), and noise with memory (an AR(1) part of the noise variance).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Nuisance {
    /// Standard deviation of the trial's conductance gain (a fraction; 0.03 = ±3 %).
    pub gain_jitter: f64,
    /// Largest amplitude of the rest relaxation (V; sign and size drawn per trial) and its time constant.
    pub rest_v: f64,
    pub rest_tau_s: f64,
    /// Every trial starts raised (the sensor still recovering from the loads before it, as a
    /// sensor rested the same way before each trial is): the rest's size is drawn per trial, its
    /// sign is not. False: sign and size drawn per trial.
    pub rest_raised: bool,
    /// AR(1) coefficient of the correlated part of the noise and that part's share of the variance.
    pub noise_ar_rho: f64,
    pub noise_ar_share: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct SensorParams {
    pub circuit: Circuit,
    /// Conductance G = g_ref_s · (F / 1 N)^exponent.
    pub g_ref_s: f64,
    pub exponent: f64,
    /// τ(F) = tau0_s + tau_per_n_s · F.
    pub tau0_s: f64,
    pub tau_per_n_s: f64,
    pub noise_v: f64,
    /// Load on the sensor at zero weight when no rig manifest is given.
    pub preload_g: f64,
    /// Dome stiffness for the cover model (N/mm) and the cover's own relaxation.
    pub dome_stiffness_n_per_mm: f64,
    pub contact_diameter_mm: f64,
    pub cover_relax_fraction: f64,
    pub cover_tau_s: f64,
    pub effects: Effects,
    pub nuisance: Nuisance,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ProtocolParams {
    /// Weights stacked one by one, then removed in reverse order.
    pub weights_g: Vec<f64>,
    pub hold_s: f64,
    pub baseline_s: f64,
    pub logging_offset_s: f64,
    pub logging_jitter_s: f64,
    /// A hand's touch: the weight's force arrives (or leaves) over about this long, ending where
    /// it lands (each placement draws 0.5–1.5 × it); 0 = at once.
    pub touch_s: f64,
    /// The hand's extra press during the touch, as a fraction of the weight (each placement draws
    /// 0.5–1.5 × it; a sin² bump over the touch).
    pub press_fraction: f64,
    /// The hold at the top load (after the last weight is placed); default `hold_s`.
    pub top_hold_s: f64,
    /// The rest at zero load after the last removal; default `baseline_s`.
    pub final_rest_s: f64,
    /// Load–unload cycles, with `baseline_s` at zero load between them; default 1.
    pub cycles: usize,
}

#[derive(Debug, Clone, Default, Deserialize)]
struct RawSensorFile {
    kind: Option<String>,
    circuit: Option<Table>,
    conductance: Option<Table>,
    relaxation: Option<Table>,
    noise: Option<Table>,
    rig: Option<Table>,
    cover: Option<Table>,
    effects: Option<BTreeMap<String, Table>>,
    nuisance: Option<Table>,
}

static CIRCUIT: Schema = Schema { fields: || &["vcc_v", "r_m_ohm", "divider", "adc_bits", "vref_v", "sample_rate_hz"], tables: &[] };
static CONDUCTANCE: Schema = Schema { fields: || &["g_ref_s", "exponent"], tables: &[] };
static RELAX: Schema = Schema { fields: || &["tau0_s", "tau_per_n_s"], tables: &[] };
static NOISE: Schema = Schema { fields: || &["sigma_v"], tables: &[] };
static RIG: Schema = Schema { fields: || &["preload_g"], tables: &[] };
static COVER: Schema = Schema { fields: || &["dome_stiffness_n_per_mm", "contact_diameter_mm", "relax_fraction", "tau_s"], tables: &[] };
static CREEP: Schema =
    Schema { fields: || &["per_decade", "time_s", "superposed", "in_conductance", "spectrum_terms", "spectrum_min_s", "spectrum_max_s", "spectrum_tilt"], tables: &[] };
static HYST: Schema = Schema { fields: || &["fraction", "memory_s", "in_conductance"], tables: &[] };
static SECOND: Schema = Schema { fields: || &["fraction", "tau_s", "in_conductance"], tables: &[] };
static DRIFT: Schema = Schema { fields: || &["rate_v_per_s", "wander_v", "period_s", "warmup_tau_s"], tables: &[] };
static SAT: Schema = Schema { fields: || &["level_v", "before_noise"], tables: &[] };
static NUISANCE: Schema = Schema { fields: || &["gain_jitter", "rest_v", "rest_tau_s", "rest_raised", "noise_ar_rho", "noise_ar_share"], tables: &[] };
static SPIKES: Schema = Schema { fields: || &["amplitude_v", "duration_s", "force_share"], tables: &[] };
static EFFECTS: Schema = Schema {
    fields: || &[],
    tables: &[
        ("creep", false, &CREEP),
        ("hysteresis", false, &HYST),
        ("second_time_constant", false, &SECOND),
        ("baseline_drift", false, &DRIFT),
        ("saturation", false, &SAT),
        ("handling_spikes", false, &SPIKES),
    ],
};
pub static SENSOR_SCHEMA: Schema = Schema {
    fields: || &["kind"],
    tables: &[
        ("circuit", false, &CIRCUIT),
        ("conductance", false, &CONDUCTANCE),
        ("relaxation", false, &RELAX),
        ("noise", false, &NOISE),
        ("rig", false, &RIG),
        ("cover", false, &COVER),
        ("effects", false, &EFFECTS),
        ("nuisance", false, &NUISANCE),
    ],
};
/// A placement's touch lasts 0.5–1.5 × `touch_s` (the simulator's draw): at most this many times it.
pub const TOUCH_DRAW_MAX: f64 = 1.5;

/// Whether touches of `touch_s` end inside holds and rests of at least `shortest_s`.
pub fn touch_fits(touch_s: f64, shortest_s: f64) -> bool {
    TOUCH_DRAW_MAX * touch_s < shortest_s
}

pub static PROTOCOL_SCHEMA: Schema = Schema {
    fields: || &["kind", "weights_g", "hold_s", "baseline_s", "logging_offset_s", "logging_jitter_s", "touch_s", "press_fraction", "top_hold_s", "final_rest_s", "cycles"],
    tables: &[],
};

fn num(c: &mut Collector, t: &Option<Table>, table: &str, key: &str, default: f64, lo: f64, hi: f64) -> Option<f64> {
    let path = format!("{table}.{key}");
    let v = match t.as_ref().and_then(|t| t.get(key)) {
        None => Some(default),
        Some(toml::Value::Float(f)) => Some(*f),
        Some(toml::Value::Integer(i)) => Some(*i as f64),
        Some(other) => {
            c.push(&path, other, "must be a number");
            return None;
        }
    };
    c.or_within(v, default, &path, lo, hi)
}

/// `effects.creep`'s Prony spectrum: (terms, τ_min, τ_max, tilt); 0 terms (the default) is the
/// log-time form. A spectrum needs τ_min < τ_max and the superposed form (each change's creep runs
/// on after later changes); every problem is reported with its path.
fn creep_spectrum(c: &mut Collector, t: &Option<Table>, superposed: bool) -> (usize, f64, f64, f64) {
    let terms = num(c, t, "effects.creep", "spectrum_terms", 0.0, 0.0, 64.0);
    let lo = num(c, t, "effects.creep", "spectrum_min_s", 2.0, 1e-3, 1e6);
    let hi = num(c, t, "effects.creep", "spectrum_max_s", 3600.0, 1e-3, 1e6);
    let tilt = num(c, t, "effects.creep", "spectrum_tilt", 0.0, -2.0, 2.0);
    let (Some(n), Some(lo), Some(hi), Some(tilt)) = (terms, lo, hi, tilt) else { return (0, 2.0, 3600.0, 0.0) };
    if n.fract() != 0.0 {
        c.push("effects.creep.spectrum_terms", n, "must be a whole number (0: the log-time form)");
        return (0, lo, hi, tilt);
    }
    if n == 1.0 {
        c.push("effects.creep.spectrum_terms", n, "use 2 or more terms, log-spaced from spectrum_min_s to spectrum_max_s (0: the log-time form)");
    }
    if n >= 1.0 && lo >= hi {
        c.push("effects.creep.spectrum_min_s", lo, &format!("must be below spectrum_max_s ({hi})"));
    }
    if n >= 1.0 && !superposed {
        c.push("effects.creep.spectrum_terms", n, "a spectrum needs superposed = true (each change's creep runs on after later changes)");
    }
    (n as usize, lo, hi, tilt)
}

/// A switch `table.key`: absent is false; anything but a boolean is a problem, with `fix`.
fn flag(c: &mut Collector, t: &Option<Table>, table: &str, key: &str, fix: &str) -> bool {
    match t.as_ref().and_then(|t| t.get(key)) {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(v) => {
            c.push(&format!("{table}.{key}"), v, fix);
            false
        }
    }
}

impl SensorParams {
    pub fn from_source(src: &SourceFile) -> Result<SensorParams> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&SENSOR_SCHEMA));
        if !c.problems.is_empty() {
            return super::finish(None, c.problems);
        }
        let mut problems = Vec::new();
        let raw: Option<RawSensorFile> = src.table("", &mut problems);
        c.problems.extend(problems);
        let Some(r) = raw else { return super::finish(None, c.problems) };
        let _ = &r.kind;
        let divider = match r.circuit.as_ref().and_then(|t| t.get("divider")) {
            None => Some(true),
            Some(toml::Value::String(s)) if s == "sensor_high" => Some(true),
            Some(toml::Value::String(s)) if s == "sensor_low" => Some(false),
            Some(v) => {
                c.push("circuit.divider", v, "use \"sensor_high\" or \"sensor_low\"");
                None
            }
        };
        let vcc = num(&mut c, &r.circuit, "circuit", "vcc_v", 3.3, 0.1, 48.0);
        let rm = num(&mut c, &r.circuit, "circuit", "r_m_ohm", 1000.0, 1.0, 1e9);
        let bits = num(&mut c, &r.circuit, "circuit", "adc_bits", 12.0, 1.0, 32.0);
        let vref = num(&mut c, &r.circuit, "circuit", "vref_v", 3.3, 0.1, 48.0);
        let fs = num(&mut c, &r.circuit, "circuit", "sample_rate_hz", 100.0, 1.0, 100000.0);
        let g = num(&mut c, &r.conductance, "conductance", "g_ref_s", 1e-4, 1e-12, 1.0);
        let n = num(&mut c, &r.conductance, "conductance", "exponent", 1.0, 0.05, 5.0);
        let t0 = num(&mut c, &r.relaxation, "relaxation", "tau0_s", 0.25, 0.0, 1000.0);
        let t1 = num(&mut c, &r.relaxation, "relaxation", "tau_per_n_s", 0.178, 0.0, 1000.0);
        let sigma = num(&mut c, &r.noise, "noise", "sigma_v", 0.003, 0.0, 10.0);
        let pre = num(&mut c, &r.rig, "rig", "preload_g", 0.0, 0.0, 100000.0);
        let ks = num(&mut c, &r.cover, "cover", "dome_stiffness_n_per_mm", 20.0, 0.001, 1e6);
        let cd = num(&mut c, &r.cover, "cover", "contact_diameter_mm", 12.0, 0.1, 1000.0);
        let crf = num(&mut c, &r.cover, "cover", "relax_fraction", 0.1, 0.0, 1.0);
        let ctau = num(&mut c, &r.cover, "cover", "tau_s", 5.0, 0.001, 1e5);
        let ef = r.effects.clone().unwrap_or_default();
        let e = |name: &str| ef.get(name).cloned();
        // a switch of an effect's table
        let mut switch = |table: &str, key: &str, fix: &str| flag(&mut c, &e(table), &format!("effects.{table}"), key, fix);
        let before_noise = switch("saturation", "before_noise", "use true (an amplifier's rail, before the noise) or false (the ADC's reference, after it)");
        let superposed = switch("creep", "superposed", "use true (each change's creep keeps going after later changes) or false (creep restarts at every step)");
        let in_conductance = switch("creep", "in_conductance", "use true (the conductance creeps, seen through the read-out) or false (the response creeps)");
        let hyst_in_conductance = switch(
            "hysteresis",
            "in_conductance",
            "use true (the conductance keeps a share of the peak's force gap, seen through the read-out) or false (the response keeps a share of the peak's level)",
        );
        let second_in_conductance =
            switch("second_time_constant", "in_conductance", "use true (the conductance relaxes a second time, seen through the read-out) or false (the response does)");
        let spectrum = creep_spectrum(&mut c, &e("creep"), superposed);
        let eff = Effects {
            creep_spectrum_terms: spectrum.0,
            creep_spectrum_min_s: spectrum.1,
            creep_spectrum_max_s: spectrum.2,
            creep_spectrum_tilt: spectrum.3,
            second_in_conductance,
            saturation_before_noise: before_noise,
            creep_superposed: superposed,
            creep_in_conductance: in_conductance,
            hysteresis_in_conductance: hyst_in_conductance,
            creep_per_decade: num(&mut c, &e("creep"), "effects.creep", "per_decade", 0.0, 0.0, 10.0).unwrap_or(0.0),
            creep_time_s: num(&mut c, &e("creep"), "effects.creep", "time_s", 1.0, 1e-3, 1e5).unwrap_or(1.0),
            hysteresis: num(&mut c, &e("hysteresis"), "effects.hysteresis", "fraction", 0.0, 0.0, 1.0).unwrap_or(0.0),
            hysteresis_memory_s: num(&mut c, &e("hysteresis"), "effects.hysteresis", "memory_s", 0.0, 0.0, 1e7).unwrap_or(0.0),
            second_fraction: num(&mut c, &e("second_time_constant"), "effects.second_time_constant", "fraction", 0.0, 0.0, 1.0).unwrap_or(0.0),
            second_tau_s: num(&mut c, &e("second_time_constant"), "effects.second_time_constant", "tau_s", 8.0, 1e-3, 1e5).unwrap_or(8.0),
            drift_v_per_s: num(&mut c, &e("baseline_drift"), "effects.baseline_drift", "rate_v_per_s", 0.0, -10.0, 10.0).unwrap_or(0.0),
            wander_v: num(&mut c, &e("baseline_drift"), "effects.baseline_drift", "wander_v", 0.0, 0.0, 10.0).unwrap_or(0.0),
            drift_warmup_tau_s: num(&mut c, &e("baseline_drift"), "effects.baseline_drift", "warmup_tau_s", 0.0, 0.0, 1e6).unwrap_or(0.0),
            wander_period_s: num(&mut c, &e("baseline_drift"), "effects.baseline_drift", "period_s", 300.0, 1.0, 1e6).unwrap_or(300.0),
            saturation_v: num(&mut c, &e("saturation"), "effects.saturation", "level_v", 0.0, 0.0, 48.0).unwrap_or(0.0),
            spike_v: num(&mut c, &e("handling_spikes"), "effects.handling_spikes", "amplitude_v", 0.0, 0.0, 48.0).unwrap_or(0.0),
            spike_s: num(&mut c, &e("handling_spikes"), "effects.handling_spikes", "duration_s", 0.15, 0.001, 10.0).unwrap_or(0.15),
            spike_force_share: num(&mut c, &e("handling_spikes"), "effects.handling_spikes", "force_share", 0.0, 0.0, 100.0).unwrap_or(0.0),
        };
        let rest_raised = flag(&mut c, &r.nuisance, "nuisance", "rest_raised", "use true (every trial starts raised, its size drawn) or false (sign and size drawn per trial)");
        let nu = Nuisance {
            gain_jitter: num(&mut c, &r.nuisance, "nuisance", "gain_jitter", 0.0, 0.0, 0.5).unwrap_or(0.0),
            rest_v: num(&mut c, &r.nuisance, "nuisance", "rest_v", 0.0, 0.0, 10.0).unwrap_or(0.0),
            rest_tau_s: num(&mut c, &r.nuisance, "nuisance", "rest_tau_s", 100.0, 0.01, 1e6).unwrap_or(100.0),
            rest_raised,
            noise_ar_rho: num(&mut c, &r.nuisance, "nuisance", "noise_ar_rho", 0.0, 0.0, 0.999).unwrap_or(0.0),
            noise_ar_share: num(&mut c, &r.nuisance, "nuisance", "noise_ar_share", 0.0, 0.0, 1.0).unwrap_or(0.0),
        };
        if let Some(b) = bits {
            if b.fract() != 0.0 {
                c.push("circuit.adc_bits", b, "must be a whole number");
            }
        }
        let v = (|| {
            Some(SensorParams {
                circuit: Circuit { vcc_v: vcc?, r_m_ohm: rm?, sensor_high: divider?, adc_bits: bits? as u32, vref_v: vref?, sample_rate_hz: fs? },
                g_ref_s: g?,
                exponent: n?,
                tau0_s: t0?,
                tau_per_n_s: t1?,
                noise_v: sigma?,
                preload_g: pre?,
                dome_stiffness_n_per_mm: ks?,
                contact_diameter_mm: cd?,
                cover_relax_fraction: crf?,
                cover_tau_s: ctau?,
                effects: eff,
                nuisance: nu,
            })
        })();
        if let Some(p) = &v {
            if p.tau0_s + p.tau_per_n_s <= 0.0 {
                c.push("relaxation.tau0_s", p.tau0_s, "τ must be positive at every load: raise tau0_s or tau_per_n_s");
            }
        }
        super::finish(v, c.problems)
    }
}

impl ProtocolParams {
    pub fn from_source(src: &SourceFile) -> Result<ProtocolParams> {
        let mut c = Collector::new(src);
        c.problems.extend(src.unknown_keys(&PROTOCOL_SCHEMA));
        if !c.problems.is_empty() {
            return super::finish(None, c.problems);
        }
        let t = match &src.value {
            toml::Value::Table(t) => Some(t.clone().into_iter().collect::<Table>()),
            _ => None,
        };
        let weights = match t.as_ref().and_then(|t| t.get("weights_g")) {
            Some(toml::Value::Array(a)) => {
                let w: Vec<Option<f64>> = a.iter().map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64))).collect();
                if w.is_empty() || w.iter().any(|x| x.is_none_or(|v| v <= 0.0 || !v.is_finite())) {
                    c.push("weights_g", format!("{a:?}"), "a non-empty list of positive weights in grams, e.g. [200, 200, 200, 200, 200]");
                    None
                } else {
                    Some(w.into_iter().map(|x| x.unwrap()).collect())
                }
            }
            _ => {
                c.push("weights_g", "missing", "add `weights_g = [200, 200, 200, 200, 200]`");
                None
            }
        };
        let hold = num(&mut c, &t, "", "hold_s", 20.0, 1.0, 1e5);
        let base = num(&mut c, &t, "", "baseline_s", 10.0, 1.0, 1e5);
        let off = num(&mut c, &t, "", "logging_offset_s", 0.3, -5.0, 5.0);
        let jit = num(&mut c, &t, "", "logging_jitter_s", 0.15, 0.0, 5.0);
        // a hand's touch (under a second) or an actuator's travel (6–9 s on the strip rig)
        let touch = num(&mut c, &t, "", "touch_s", 0.0, 0.0, 30.0);
        let press = num(&mut c, &t, "", "press_fraction", 0.0, 0.0, 3.0);
        let top = num(&mut c, &t, "", "top_hold_s", hold.unwrap_or(20.0), 1.0, 1e5);
        let final_rest = num(&mut c, &t, "", "final_rest_s", base.unwrap_or(10.0), 1.0, 1e5);
        let cycles = num(&mut c, &t, "", "cycles", 1.0, 1.0, 10.0).and_then(|x| {
            if x.fract() == 0.0 {
                Some(x as usize)
            } else {
                c.push("cycles", x, "a whole number of load-unload cycles, 1 to 10");
                None
            }
        });
        // each touch draws up to 1.5 × touch_s and must end inside the hold before it
        if let (Some(d), Some(h), Some(b)) = (touch, hold, base) {
            let shortest = h.min(b).min(top.unwrap_or(h)).min(final_rest.unwrap_or(b));
            if !touch_fits(d, shortest) {
                c.push(
                    "touch_s",
                    d,
                    format!(
                        "a touch draws up to {TOUCH_DRAW_MAX} × touch_s, which must stay under the shortest hold or rest ({shortest} s): use touch_s < {:.2}",
                        shortest / TOUCH_DRAW_MAX
                    ),
                );
            }
        }
        let v = (|| {
            Some(ProtocolParams {
                weights_g: weights?,
                hold_s: hold?,
                baseline_s: base?,
                logging_offset_s: off?,
                logging_jitter_s: jit?,
                touch_s: touch?,
                press_fraction: press?,
                top_hold_s: top?,
                final_rest_s: final_rest?,
                cycles: cycles?,
            })
        })();
        // paths of top-level keys carry a leading "." from the shared helper; tidy them
        for p in &mut c.problems {
            if let Some(s) = p.path.strip_prefix('.') {
                p.path = s.to_string();
            }
        }
        super::finish(v, c.problems)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> std::result::Result<SensorParams, String> {
        SensorParams::from_source(&SourceFile::parse("s.toml", text.to_string()).map_err(|e| e.to_string())?).map_err(|e| e.to_string())
    }

    /// The creep's Prony spectrum is read from `[effects.creep]`; a spectrum without the superposed
    /// form, with τ_min ≥ τ_max, or with a fractional number of terms or a single one is refused,
    /// every problem with its path and its fix, at once.
    #[test]
    fn a_creep_spectrum_is_read_and_its_problems_named() {
        let base = "kind = \"sensor\"\n[effects.creep]\nper_decade = 0.01\n";
        let s = parse(&format!("{base}superposed = true\nspectrum_terms = 6\nspectrum_min_s = 1.0\nspectrum_max_s = 1000.0\nspectrum_tilt = 0.5\n")).unwrap();
        let e = &s.effects;
        assert_eq!((e.creep_spectrum_terms, e.creep_spectrum_min_s, e.creep_spectrum_max_s, e.creep_spectrum_tilt), (6, 1.0, 1000.0, 0.5));
        assert_eq!(parse(base).unwrap().effects.creep_spectrum_terms, 0, "absent: the log-time form");
        let err = parse(&format!("{base}spectrum_terms = 6\nspectrum_min_s = 50.0\nspectrum_max_s = 10.0\n")).unwrap_err();
        assert!(err.contains("effects.creep.spectrum_min_s") && err.contains("must be below spectrum_max_s (10)"), "{err}");
        assert!(err.contains("effects.creep.spectrum_terms") && err.contains("superposed = true"), "{err}");
        let err = parse(&format!("{base}superposed = true\nspectrum_terms = 2.5\n")).unwrap_err();
        assert!(err.contains("effects.creep.spectrum_terms") && err.contains("whole number"), "{err}");
        let err = parse(&format!("{base}superposed = true\nspectrum_terms = 1\n")).unwrap_err();
        assert!(err.contains("effects.creep.spectrum_terms") && err.contains("2 or more terms"), "{err}");
    }
}
