//! Rig + sensor simulator: protocol → force (weights + plunger preload) → sensor (power-law
//! conductance, load-dependent first-order relaxation, switchable effects) → divider → ADC →
//! recording, plus the noise-free truth. Deterministic per seed.

use super::recording::{Divider, Meta, ProtocolKind, Recording};
use crate::params::sensor::{ProtocolParams, SensorParams};
use serde::Serialize;

pub const G_N_PER_KG: f64 = 9.80665;

/// SplitMix64: small, fast, deterministic on every platform.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A PDMS cover between the load and the dome (lumped): the cover carries part of the load in
/// parallel with the dome, and relaxes with its own time constant.
#[derive(Debug, Clone, Serialize)]
pub struct Cover {
    pub thickness_mm: f64,
    pub mix_ratio: f64,
    /// Young's modulus estimate ≈ 20 MPa ÷ mix ratio (Wang et al. 2014).
    pub modulus_mpa: f64,
    /// Fraction of the load that reaches the dome at equilibrium.
    pub dome_share: f64,
}

impl Cover {
    pub fn new(thickness_mm: f64, mix_ratio: f64, p: &SensorParams, dome_diameter_mm: f64) -> Cover {
        let modulus_mpa = 20.0 / mix_ratio;
        let ring = std::f64::consts::PI / 4.0 * (p.contact_diameter_mm.powi(2) - dome_diameter_mm.powi(2)).max(0.0);
        let k_cover = modulus_mpa * ring / thickness_mm; // N/mm (MPa·mm²/mm)
        let dome_share = p.dome_stiffness_n_per_mm / (p.dome_stiffness_n_per_mm + k_cover);
        Cover { thickness_mm, mix_ratio, modulus_mpa, dome_share }
    }
}

/// One step of the protocol as it really happened.
#[derive(Debug, Clone, Serialize)]
pub struct TruthStep {
    pub phase: &'static str,
    pub index: usize,
    pub t_land_s: f64,
    pub t_log_s: f64,
    pub load_before_g: f64,
    pub load_after_g: f64,
    pub force_after_n: f64,
    /// Noise-free voltage at landing and the first-order equilibrium after it.
    pub v_start: f64,
    pub v_eq: f64,
    /// The first-order part's step: k = V_eq − V(t_land), τ = τ(F).
    pub k_v: f64,
    pub tau_s: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    pub seed: u64,
    pub preload_g: f64,
    pub steps: Vec<TruthStep>,
    /// Noise-free output (the recording before noise and quantisation).
    #[serde(skip)]
    pub clean_v: Vec<f64>,
    /// The first-order part alone (no effects), for judging models against the truth.
    #[serde(skip)]
    pub first_order_v: Vec<f64>,
}

impl SensorParams {
    pub fn conductance(&self, force_n: f64) -> f64 {
        self.g_ref_s * force_n.max(0.0).powf(self.exponent)
    }
    pub fn v_eq(&self, force_n: f64) -> f64 {
        self.response(self.conductance(force_n))
    }
    /// The divider's response to conductance `g` (S).
    pub fn response(&self, g: f64) -> f64 {
        let c = &self.circuit;
        let x = c.r_m_ohm * g.max(0.0);
        if c.sensor_high {
            c.vcc_v * x / (x + 1.0)
        } else {
            c.vcc_v / (x + 1.0)
        }
    }
    /// The conductance (S) the divider shows as response `v` (the inverse of [`Self::response`],
    /// kept inside the divider's span).
    pub fn conductance_of(&self, v: f64) -> f64 {
        let c = &self.circuit;
        let v = v.clamp(1e-9 * c.vcc_v, (1.0 - 1e-9) * c.vcc_v);
        let x = if c.sensor_high { v / (c.vcc_v - v) } else { c.vcc_v / v - 1.0 };
        x / c.r_m_ohm
    }
    pub fn tau(&self, force_n: f64) -> f64 {
        (self.tau0_s + self.tau_per_n_s * force_n).max(1e-3)
    }
}

/// The protocol's schedule: (landing time, load after, phase, index) for each placement and
/// removal, in order, and the recording's length (s).
pub fn schedule(proto: &ProtocolParams) -> (Vec<(f64, f64, &'static str, usize)>, f64) {
    let mut events: Vec<(f64, f64, &'static str, usize)> = Vec::new();
    let mut load = 0.0;
    let mut t = proto.baseline_s;
    let nw = proto.weights_g.len();
    for cycle in 0..proto.cycles {
        if cycle > 0 {
            // the rest at zero load between cycles
            t += proto.baseline_s - proto.hold_s;
        }
        for (i, w) in proto.weights_g.iter().enumerate() {
            load += w;
            events.push((t, load, "loading", i + cycle * nw));
            t += if i + 1 == nw { proto.top_hold_s } else { proto.hold_s };
        }
        for (i, w) in proto.weights_g.iter().rev().enumerate() {
            load -= w;
            events.push((t, load.max(0.0), "unloading", i + cycle * nw));
            t += proto.hold_s;
        }
    }
    let total = t - proto.hold_s + proto.final_rest_s;
    (events, total)
}

/// Simulates one trial.
pub fn simulate(p0: &SensorParams, proto: &ProtocolParams, preload_g: f64, cover: Option<&Cover>, seed: u64) -> (Recording, Truth) {
    let mut rng = Rng::new(seed);
    let c = &p0.circuit;
    let dt = 1.0 / c.sample_rate_hz;
    let e = &p0.effects;
    let (events, total) = schedule(proto);
    let n = (total / dt).round() as usize + 1;
    let logs: Vec<f64> = events.iter().map(|ev| ev.0 + proto.logging_offset_s + proto.logging_jitter_s * rng.normal()).collect();
    let spike_signs: Vec<f64> = events.iter().map(|_| if rng.uniform() < 0.5 { -1.0 } else { 1.0 }).collect();
    // nuisances (each draws only when it is on, so the sequence without them is unchanged)
    let touches = touches(proto, events.len(), &mut rng);
    // handling spikes as presses of force: drawn from their own stream, so that every other draw
    // is the same with them on or off
    let presses = force_spikes(e, &events, &touches, seed);
    let nu = &p0.nuisance;
    let mut scaled = p0.clone();
    if nu.gain_jitter > 0.0 {
        scaled.g_ref_s *= (1.0 + nu.gain_jitter * rng.normal()).max(0.2);
    }
    let p = &scaled;
    // the same draw either way (a sensor that rests raised sees the sizes one drawn both ways does)
    let rest_amp = if nu.rest_v > 0.0 { nu.rest_v * (2.0 * rng.uniform() - 1.0) } else { 0.0 };
    let rest_amp = if nu.rest_raised { rest_amp.abs() } else { rest_amp };
    let share = cover.map(|cv| cv.dome_share).unwrap_or(1.0);
    let force_of = |g: f64| (g + preload_g) / 1000.0 * G_N_PER_KG * share;
    let (mut time, mut clean, mut fo, mut logged) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    let f0 = force_of(0.0);
    let mut v_fast = p.v_eq(f0);
    let mut v_slow = v_fast;
    // the second relaxation of the conductance (`second_in_conductance`): its slow part, in S
    let mut g_slow = p.conductance_of(v_fast);
    // the first-order part: the mix of the fast and slow relaxations, in the response or in the
    // conductance seen through the read-out
    let mix = |v_fast: f64, v_slow: f64, g_slow: f64| {
        if e.second_in_conductance && e.second_fraction > 0.0 {
            p.response((1.0 - e.second_fraction) * p.conductance_of(v_fast) + e.second_fraction * g_slow)
        } else {
            (1.0 - e.second_fraction) * v_fast + e.second_fraction * v_slow
        }
    };
    let mut v_cov = 0.0;
    let mut creep_carry = 0.0;
    let mut t_change = 0.0;
    let mut f_max = f0;
    let mut ev_i = 0;
    let mut cur_load = 0.0;
    let mut steps = Vec::new();
    let mut creep_now = 0.0;
    let shape = CreepShape::of(e);
    for k in 0..n {
        let tk = k as f64 * dt;
        while ev_i < events.len() && events[ev_i].0 <= tk + 1e-12 {
            let (tl, after, phase, idx) = events[ev_i];
            let f_after = force_of(after);
            let v_start = mix(v_fast, v_slow, g_slow);
            let veq = p.v_eq(f_after);
            steps.push(TruthStep {
                phase,
                index: idx,
                t_land_s: tl,
                t_log_s: logs[ev_i],
                load_before_g: cur_load,
                load_after_g: after,
                force_after_n: f_after,
                v_start,
                v_eq: veq,
                k_v: veq - v_start,
                tau_s: p.tau(f_after),
            });
            creep_carry = creep_now;
            t_change = tl;
            cur_load = after;
            f_max = f_max.max(f_after);
            ev_i += 1;
        }
        let f = force_of(load_now(cur_load, touches.get(ev_i), events.get(ev_i), tk) + presses.iter().map(|pr| pr.at(tk)).sum::<f64>());
        // a fading memory: the remembered peak follows the force up at once and fades toward it
        if e.hysteresis_memory_s > 0.0 {
            f_max = if k == 0 || f >= f_max { f } else { f + (f_max - f) * (-dt / e.hysteresis_memory_s).exp() };
        }
        let mut target = p.v_eq(f);
        if e.hysteresis > 0.0 && f < f_max {
            target =
                if e.hysteresis_in_conductance { p.response(p.conductance(f) + e.hysteresis * (f_max - f) * p.g_ref_s) } else { target + e.hysteresis * (p.v_eq(f_max) - target) };
        }
        if k > 0 {
            let tau = p.tau(f);
            v_fast = target + (v_fast - target) * (-dt / tau).exp();
            v_slow = target + (v_slow - target) * (-dt / e.second_tau_s).exp();
            let g_target = p.conductance_of(target);
            g_slow = g_target + (g_slow - g_target) * (-dt / e.second_tau_s).exp();
            let cov_target = if cover.is_some() { p.cover_relax_fraction * (target - p.v_eq(f0)) } else { 0.0 };
            v_cov = cov_target + (v_cov - cov_target) * (-dt / p.cover_tau_s).exp();
        } else {
            v_fast = target;
            v_slow = target;
            g_slow = p.conductance_of(target);
        }
        let first = mix(v_fast, v_slow, g_slow);
        creep_now = creep(p, &shape, (f0, f), tk, &steps, (t_change, creep_carry));
        // a creep of the conductance shows through the divider at the level the sensor is at
        let creep_v = if e.creep_in_conductance && creep_now != 0.0 { p.response(p.conductance_of(first) + creep_now) - first } else { creep_now };
        let ramp = if e.drift_warmup_tau_s > 0.0 { e.drift_warmup_tau_s * (1.0 - (-tk / e.drift_warmup_tau_s).exp()) } else { tk };
        let drift = e.drift_v_per_s * ramp + e.wander_v * (2.0 * std::f64::consts::PI * tk / e.wander_period_s).sin();
        let rest = if rest_amp != 0.0 { rest_amp * (-tk / nu.rest_tau_s).exp() } else { 0.0 };
        let v = first + creep_v + drift - v_cov + rest + spikes(e, &events, &spike_signs, tk);
        time.push(tk);
        clean.push(v);
        fo.push(first);
        // the operator's log: the load changes when logged
        let lg = logs.iter().zip(&events).filter(|(l, _)| **l <= tk).map(|(_, ev)| ev.1).next_back().unwrap_or(0.0);
        logged.push(lg);
    }
    let recorded = read_out(p, &mut rng, &mut clean);
    let rec = as_recording(c, seed, time, recorded, logged);
    (rec, Truth { seed, preload_g, steps, clean_v: clean, first_order_v: fo })
}

/// The load as applied at `tk`: a hand's touch (duration, press) ramps it in before the landing of
/// the next event, with a press; otherwise the current load.
fn load_now(cur_load: f64, touch: Option<&(f64, f64)>, next: Option<&(f64, f64, &str, usize)>, tk: f64) -> f64 {
    if let (Some(&(d, press)), Some(ev)) = (touch, next) {
        let u = (tk - (ev.0 - d)) / d;
        if (0.0..1.0).contains(&u) {
            let delta = ev.1 - cur_load;
            return cur_load + delta * u * u * (3.0 - 2.0 * u) + press * delta.abs() * bump(u);
        }
    }
    cur_load
}

/// A superposed creep's growth since a change, per unit of `creep_per_decade`: log-time,
/// log10(1 + t/time_s), or with a Prony spectrum Σ_k w_k (1 − e^(−t/τ_k)) (see
/// `Effects::creep_spectrum_terms`: the weights sum to the span in decades, at least one). Fewer
/// than two terms is the log-time form. Built once per simulation: every sample evaluates it once
/// per change so far.
struct CreepShape {
    time_s: f64,
    /// The spectrum's τ_k and weights w_k, its span in decades (at least one) and Σ w_k.
    prony: Option<(Vec<f64>, Vec<f64>, f64, f64)>,
}

impl CreepShape {
    fn of(e: &crate::params::sensor::Effects) -> CreepShape {
        let n = e.creep_spectrum_terms;
        // (a spectrum needs two τ or more, 0 < τ_min < τ_max: the sensor file's parse checks it)
        if n < 2 || !(e.creep_spectrum_min_s > 0.0 && e.creep_spectrum_max_s > e.creep_spectrum_min_s) {
            debug_assert!(n == 0, "a creep spectrum of {n} terms over {}–{} s", e.creep_spectrum_min_s, e.creep_spectrum_max_s);
            return CreepShape { time_s: e.creep_time_s, prony: None };
        }
        let decades = (e.creep_spectrum_max_s / e.creep_spectrum_min_s).log10();
        let taus: Vec<f64> = (0..n).map(|k| e.creep_spectrum_min_s * 10f64.powf(decades * k as f64 / (n - 1) as f64)).collect();
        let weights: Vec<f64> = taus.iter().map(|t| (t / e.creep_spectrum_min_s).powf(e.creep_spectrum_tilt)).collect();
        let total: f64 = weights.iter().sum();
        CreepShape { time_s: e.creep_time_s, prony: Some((taus, weights, decades.max(1.0), total)) }
    }

    fn at(&self, since: f64) -> f64 {
        match &self.prony {
            None => (1.0 + since / self.time_s).log10(),
            Some((taus, weights, span, total)) => weights.iter().zip(taus).map(|(w, tau)| w * (1.0 - (-since / tau).exp())).sum::<f64>() * span / total,
        }
    }
}

/// Creep at `tk` under force `f` (from `f0` at no load): log-time growth under the current load,
/// the previous creep (`creep_carry` at the last change, `t_change`) relaxing away; or, superposed,
/// every change's own creep (log-time, or a Prony spectrum: [`CreepShape`]), which keeps going. In conductance (S) when the effect says
/// so, else in the response (V).
fn creep(p: &SensorParams, shape: &CreepShape, (f0, f): (f64, f64), tk: f64, steps: &[TruthStep], (t_change, creep_carry): (f64, f64)) -> f64 {
    let e = &p.effects;
    let level = |force_n: f64| if e.creep_in_conductance { p.conductance(force_n) } else { p.v_eq(force_n) };
    if e.creep_per_decade > 0.0 && e.creep_superposed {
        // every change so far adds its own creep, which keeps going (superposition
        // over the load history); the change in progress counts from its landing
        let mut c = 0.0;
        let mut before = level(f0);
        for st in steps {
            let since = (tk - st.t_land_s).max(0.0);
            let after = level(st.force_after_n);
            c += e.creep_per_decade * (after - before) * shape.at(since);
            before = after;
        }
        c
    } else if e.creep_per_decade > 0.0 {
        let since = (tk - t_change).max(0.0);
        let decay = creep_carry * (-since / p.tau(f)).exp();
        decay + e.creep_per_decade * (level(f) - level(f0)) * (1.0 + since / e.creep_time_s).log10()
    } else {
        0.0
    }
}

/// A hand's touch per event (its duration and press; none without `touch_s`).
fn touches(proto: &ProtocolParams, n: usize, rng: &mut Rng) -> Vec<(f64, f64)> {
    if proto.touch_s > 0.0 {
        (0..n).map(|_| (proto.touch_s * (crate::params::sensor::TOUCH_DRAW_MAX - 1.0 + rng.uniform()), proto.press_fraction * (0.5 + rng.uniform()))).collect()
    } else {
        vec![]
    }
}

/// A handling spike as a press of force (g): a sin² bump of `peak_g` over [`start_s`, `start_s` + `dur_s`].
struct Press {
    start_s: f64,
    dur_s: f64,
    peak_g: f64,
}

impl Press {
    fn at(&self, tk: f64) -> f64 {
        self.peak_g * bump((tk - self.start_s) / self.dur_s)
    }
}

/// A sin² bump over [0, 1) at `u` (0 outside): the shape of a hand's press.
fn bump(u: f64) -> f64 {
    if (0.0..1.0).contains(&u) {
        (std::f64::consts::PI * u).sin().powi(2)
    } else {
        0.0
    }
}

/// The presses of `effects.spike_force_share` (none when 0): at about half of the events, a press
/// of 0.3–1.7 × the share of the weight changed, 0.03–0.15 s long (no longer than the touch), within
/// the event's touch (its last `d` seconds before the landing), or from the landing without one.
/// They add to the force, so a peak's memory (`hysteresis_memory_s`) remembers them, as it does
/// the touch's press.
fn force_spikes(e: &crate::params::sensor::Effects, events: &[(f64, f64, &str, usize)], touches: &[(f64, f64)], seed: u64) -> Vec<Press> {
    if e.spike_force_share <= 0.0 {
        return vec![];
    }
    let mut rng = Rng::new(seed ^ 0x5EED_5B1C_E000_0001);
    let mut before = 0.0;
    let mut out = Vec::new();
    for (j, ev) in events.iter().enumerate() {
        let delta = (ev.1 - before).abs();
        before = ev.1;
        let (on, size, dur, at) = (rng.uniform() < 0.5, 0.3 + 1.4 * rng.uniform(), 0.03 + 0.12 * rng.uniform(), rng.uniform());
        if on {
            // within the touch (no longer than it); without a touch, from the landing
            let d = touches.get(j).map_or(0.0, |t| t.0);
            let dur = if d > 0.0 { dur.min(d) } else { dur };
            out.push(Press { start_s: ev.0 - d + at * (d - dur), dur_s: dur, peak_g: e.spike_force_share * size * delta });
        }
    }
    out
}

/// Handling spikes at `tk`: a half sine of each event's sign around its landing.
fn spikes(e: &crate::params::sensor::Effects, events: &[(f64, f64, &str, usize)], signs: &[f64], tk: f64) -> f64 {
    let mut v = 0.0;
    if e.spike_v > 0.0 {
        for (j, ev) in events.iter().enumerate() {
            let s = tk - ev.0 + 0.5 * e.spike_s;
            if (0.0..e.spike_s).contains(&s) {
                v += signs[j] * e.spike_v * (std::f64::consts::PI * s / e.spike_s).sin();
            }
        }
    }
    v
}

/// The read-out of the noise-free signal `clean`: a rail before the noise or a clip after it,
/// white and AR(1) noise, the ADC; `clean` is clipped as the recording is.
fn read_out(p: &SensorParams, rng: &mut Rng, clean: &mut [f64]) -> Vec<f64> {
    let (c, e, nu) = (&p.circuit, &p.effects, &p.nuisance);
    let full = (1u64 << c.adc_bits.min(32)) as f64 - 1.0;
    // the rail (or the ADC's reference) clips the signal with its noise, so clipped samples pile up
    // at one value
    let sat = if e.saturation_v > 0.0 { e.saturation_v } else { f64::INFINITY };
    // an amplifier's rail clips the signal before the noise: the plateau is the rail ± noise
    let (sat, rail) = if e.saturation_before_noise { (f64::INFINITY, sat) } else { (sat, f64::INFINITY) };
    // noise: white, plus an AR(1) part with its share of the variance when that is on
    let share = if nu.noise_ar_share > 0.0 { nu.noise_ar_share } else { 0.0 };
    let (s_white, s_ar, rho) = (p.noise_v * (1.0 - share).sqrt(), p.noise_v * share.sqrt(), nu.noise_ar_rho);
    let mut ar = if share > 0.0 { s_ar * rng.normal() } else { 0.0 };
    let recorded: Vec<f64> = clean
        .iter()
        .map(|&v| {
            let n = if share > 0.0 {
                ar = rho * ar + (1.0 - rho * rho).sqrt() * s_ar * rng.normal();
                s_white * rng.normal() + ar
            } else {
                p.noise_v * rng.normal()
            };
            let noisy = (v.min(rail) + n).min(sat);
            (noisy / c.vref_v * full).round().clamp(0.0, full) * c.vref_v / full
        })
        .collect();
    for v in clean.iter_mut() {
        *v = v.min(sat).min(rail);
    }
    recorded
}

/// The simulated trial as a recording in the documented format.
fn as_recording(c: &crate::params::sensor::Circuit, seed: u64, time: Vec<f64>, recorded: Vec<f64>, logged: Vec<f64>) -> Recording {
    let meta = Meta {
        sample_rate_hz: Some(c.sample_rate_hz),
        vcc_v: Some(c.vcc_v),
        r_m_ohm: Some(c.r_m_ohm),
        adc_bits: Some(c.adc_bits),
        vref_v: Some(c.vref_v),
        divider: Some(if c.sensor_high { Divider::SensorHigh } else { Divider::SensorLow }),
        all: Default::default(),
    };
    Recording {
        source: format!("sim-{seed}.csv"),
        meta,
        time_s: time,
        response: recorded,
        unit: "V",
        response_column: "voltage_v",
        protocol: logged,
        protocol_kind: ProtocolKind::LoadG,
        ignored_columns: vec![],
        raw: None,
    }
}

/// Writes a recording in the documented CSV format.
pub fn to_csv(rec: &Recording, comment: &str) -> String {
    let mut s = String::with_capacity(rec.len() * 28 + 256);
    s.push_str(&format!("# {comment}\n"));
    let m = &rec.meta;
    if let Some(v) = m.sample_rate_hz {
        s.push_str(&format!("# sample_rate_hz={v}\n"));
    }
    if let Some(v) = m.vcc_v {
        s.push_str(&format!("# vcc_v={v}\n"));
    }
    if let Some(v) = m.r_m_ohm {
        s.push_str(&format!("# r_m_ohm={v}\n"));
    }
    if let Some(v) = m.adc_bits {
        s.push_str(&format!("# adc_bits={v}\n"));
    }
    if let Some(v) = m.vref_v {
        s.push_str(&format!("# vref_v={v}\n"));
    }
    if let Some(d) = m.divider {
        s.push_str(&format!("# divider={}\n", if d == Divider::SensorHigh { "sensor_high" } else { "sensor_low" }));
    }
    s.push_str(&format!("time_s,{},{}\n", rec.response_column, rec.protocol_kind.column()));
    for i in 0..rec.len() {
        s.push_str(&format!("{:.4},{:.6},{}\n", rec.time_s[i], rec.response[i], rec.protocol[i]));
    }
    s
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::params::SourceFile;

    pub fn defaults() -> (SensorParams, ProtocolParams) {
        let s = SensorParams::from_source(&SourceFile::parse("s.toml", std::fs::read_to_string("params/sensor.toml").unwrap()).unwrap()).unwrap();
        let p = ProtocolParams::from_source(&SourceFile::parse("p.toml", std::fs::read_to_string("params/protocol-1000g.toml").unwrap()).unwrap()).unwrap();
        (s, p)
    }

    #[test]
    fn deterministic_per_seed_and_different_across_seeds() {
        let (s, p) = defaults();
        let (a, _) = simulate(&s, &p, 20.0, None, 7);
        let (b, _) = simulate(&s, &p, 20.0, None, 7);
        let (c, _) = simulate(&s, &p, 20.0, None, 8);
        assert_eq!(a.response, b.response);
        assert_ne!(a.response, c.response);
    }

    /// Handling spikes as presses of force (`effects.handling_spikes.force_share`): on light
    /// weights (τ under a second, 20 s holds, so that a press's response has died out before the
    /// next touch) the noise-free signal departs from the one without them only within a touch
    /// (its last 0.75 s before a landing at most) and only upward, at some of the events; and every
    /// other draw is unchanged (the recorded samples before the first touch are the same, noise and
    /// all).
    #[test]
    fn a_press_of_force_rises_within_the_touch_at_some_events_and_changes_nothing_else() {
        let (mut s, mut p) = defaults();
        p.weights_g = vec![40.0; 5];
        p.touch_s = 0.5;
        p.press_fraction = 0.1;
        let (rec0, plain) = simulate(&s, &p, 20.0, None, 11);
        s.effects.spike_force_share = 2.0;
        let (rec1, with) = simulate(&s, &p, 20.0, None, 11);
        let t = |k: usize| k as f64 / s.circuit.sample_rate_hz;
        let lead = 0.75 + 1e-9;
        let first_touch = plain.steps[0].t_land_s - lead;
        let before: Vec<usize> = (0..rec0.response.len()).filter(|&k| t(k) < first_touch).collect();
        assert!(before.len() > 100 && before.iter().all(|&k| rec0.response[k] == rec1.response[k]), "the noise or the other draws moved");
        let diff: Vec<f64> = with.clean_v.iter().zip(&plain.clean_v).map(|(a, b)| a - b).collect();
        assert!(diff.iter().all(|&d| d > -1e-12), "a press never lowers the response");
        let mut pressed = 0;
        for (q, st) in plain.steps.iter().enumerate() {
            let end = plain.steps.get(q + 1).map_or(f64::INFINITY, |x| x.t_land_s - lead);
            let span: Vec<usize> = (0..diff.len()).filter(|&k| (st.t_land_s - lead..end).contains(&t(k))).collect();
            if let Some(&k) = span.iter().find(|&&k| diff[k] > 1e-12) {
                assert!(t(k) < st.t_land_s, "step {q}: the press starts at {} s, after the landing at {} s", t(k), st.t_land_s);
                assert!(diff[span[0]] <= 1e-12, "step {q}: the previous press had not died out");
                pressed += 1;
            }
        }
        let n = plain.steps.len();
        assert!((2..n - 1).contains(&pressed), "{pressed} of {n} events pressed");
    }

    #[test]
    fn first_order_truth_matches_the_papers_magnitudes() {
        let (s, p) = defaults();
        let (_, truth) = simulate(&s, &p, 0.0, None, 1);
        let load: Vec<&TruthStep> = truth.steps.iter().filter(|x| x.phase == "loading").collect();
        assert_eq!(load.len(), 5);
        assert!((load[0].tau_s - 0.6).abs() < 0.05, "{}", load[0].tau_s);
        assert!((load[4].tau_s - 2.0).abs() < 0.1, "{}", load[4].tau_s);
        for w in load.windows(2) {
            assert!(w[1].k_v < w[0].k_v, "k must fall with weight");
        }
    }

    #[test]
    fn the_divider_inverts() {
        let (s, _) = defaults();
        for g in [1e-5, 1e-4, 1e-3, 1e-2] {
            let back = s.conductance_of(s.response(g));
            assert!((back - g).abs() < 1e-9 * g.max(1e-12) + 1e-12, "{g} -> {back}");
        }
    }

    /// A creep of the conductance shows through the divider compressed at its top: at the end of
    /// the top hold, by the divider's relative slope 1/(1 + Rm·G) against the same creep of the
    /// response.
    #[test]
    fn a_conductance_creep_is_compressed_at_the_dividers_top() {
        let (mut s, p) = defaults();
        s.noise_v = 0.0;
        s.effects.creep_per_decade = 0.02;
        s.effects.creep_superposed = true;
        let (_, plain) = simulate(&defaults().0, &p, 0.0, None, 5);
        let (_, in_v) = simulate(&s, &p, 0.0, None, 5);
        s.effects.creep_in_conductance = true;
        let (_, in_g) = simulate(&s, &p, 0.0, None, 5);
        let top = in_v.steps.iter().rfind(|x| x.phase == "loading").unwrap();
        let k = ((top.t_land_s + p.top_hold_s - 0.5) * s.circuit.sample_rate_hz) as usize;
        let (dv, dg) = (in_v.clean_v[k] - plain.clean_v[k], in_g.clean_v[k] - plain.clean_v[k]);
        let x = s.circuit.r_m_ohm * s.conductance(top.force_after_n);
        assert!(dv > 0.0 && dg > 0.0, "{dv} {dg}");
        let want = dv / (1.0 + x);
        assert!((dg / want - 1.0).abs() < 0.1, "conductance creep {dg} V, expected ≈ {want} V (response creep {dv} V, Rm·G {x})");
    }

    /// Creep as a Prony spectrum (family B's form, `creep_spectrum_terms`): a change's creep grows
    /// as Σ w_k (1 − e^(−t/τ_k)), reaching `creep_per_decade` × the span in decades once t ≫ τ_max
    /// and stopping there (the log-time form keeps growing); a tilt toward the slow end puts less of
    /// it early. In the simulation, the single-weight hold's creep (the response, superposed)
    /// follows the shape, and the level after unloading sits raised and falls.
    #[test]
    fn a_prony_creep_grows_to_its_spectrum_and_stops() {
        let creep_shape = |e: &crate::params::sensor::Effects, since: f64| CreepShape::of(e).at(since);
        let mut e = crate::params::sensor::Effects { creep_time_s: 1.0, ..Default::default() };
        assert!((creep_shape(&e, 99.0) - 2.0).abs() < 1e-12, "the log-time form is unchanged");
        (e.creep_spectrum_terms, e.creep_spectrum_min_s, e.creep_spectrum_max_s) = (6, 2.0, 3600.0);
        let decades = (3600.0f64 / 2.0).log10();
        assert!((creep_shape(&e, 1e7) - decades).abs() < 1e-9, "{}", creep_shape(&e, 1e7));
        assert!(creep_shape(&e, 0.0) == 0.0 && creep_shape(&e, 10.0) < creep_shape(&e, 100.0) && creep_shape(&e, 100.0) < creep_shape(&e, 1000.0));
        // one term of each τ: 1 − e^(−1) of the 2 s term's weight (a sixth of the span) at t = 2 s
        // plus the slower terms' first rise
        let flat = creep_shape(&e, 2.0);
        e.creep_spectrum_tilt = 0.5;
        assert!(creep_shape(&e, 2.0) < 0.5 * flat && (creep_shape(&e, 1e7) - decades).abs() < 1e-9, "a tilt toward the slow end puts less of it early");
        // in the simulation: one weight of 1000 g held 600 s, the response's creep superposed
        let (mut s, _) = defaults();
        s.noise_v = 0.0;
        let p = ProtocolParams { weights_g: vec![1000.0], hold_s: 600.0, top_hold_s: 600.0, baseline_s: 300.0, final_rest_s: 300.0, ..defaults().1 };
        let (_, plain) = simulate(&s, &p, 0.0, None, 5);
        (s.effects.creep_per_decade, s.effects.creep_superposed) = (0.01, true);
        (s.effects.creep_spectrum_terms, s.effects.creep_spectrum_min_s, s.effects.creep_spectrum_max_s) = (6, 2.0, 3600.0);
        let (_, prony) = simulate(&s, &p, 0.0, None, 5);
        let at = |t: f64| (t * s.circuit.sample_rate_hz).round() as usize;
        let (on, off) = (prony.steps[0].t_land_s, prony.steps[1].t_land_s);
        let dk = prony.steps[0].v_eq - plain.clean_v[at(on - 1.0)];
        for since in [30.0, 300.0, 590.0] {
            let got = prony.clean_v[at(on + since)] - plain.clean_v[at(on + since)];
            let want = 0.01 * dk * creep_shape(&s.effects, since);
            assert!((got / want - 1.0).abs() < 0.02, "{since} s after loading: {got} V, expected {want} V");
        }
        let raised = |t: f64| prony.clean_v[at(t)] - plain.clean_v[at(t)];
        assert!(raised(off + 20.0) > raised(off + 290.0) && raised(off + 290.0) > 0.0, "after unloading: {} then {}", raised(off + 20.0), raised(off + 290.0));
    }

    /// A hysteresis whose memory fades: late in the last removal's hold (zero load), the unloading
    /// branch's offset is the fraction of v_eq(P) − v_eq(F), with the remembered peak P faded
    /// toward each hold's force in turn, dP/dt = −(P − F)/T (computed here from the steps); it
    /// falls through the hold, and without fading it holds.
    #[test]
    fn a_fading_peak_memory_closes_the_unloading_gap() {
        let (mut s, p) = defaults();
        s.noise_v = 0.0;
        let (_, plain) = simulate(&s, &p, 20.0, None, 5);
        s.effects.hysteresis = 0.02;
        let (_, kept) = simulate(&s, &p, 20.0, None, 5);
        let memory_s = 60.0;
        s.effects.hysteresis_memory_s = memory_s;
        let (_, fading) = simulate(&s, &p, 20.0, None, 5);
        let at = |t: f64| (t * s.circuit.sample_rate_hz).round() as usize;
        let gap = |tr: &Truth, t: f64| tr.clean_v[at(t)] - plain.clean_v[at(t)];
        let last = fading.steps.last().unwrap();
        let (early, late) = (last.t_land_s + 3.0, last.t_land_s + p.final_rest_s - 0.5);
        assert!(gap(&kept, early) > 1e-3 && (gap(&kept, late) / gap(&kept, early) - 1.0).abs() < 0.01, "{} {}", gap(&kept, early), gap(&kept, late));
        // the peak remembered at `late`, faded hold by hold from the top
        let unl: Vec<&TruthStep> = fading.steps.iter().filter(|x| x.phase == "unloading").collect();
        let mut peak = fading.steps.iter().map(|x| x.force_after_n).fold(0.0, f64::max);
        for (k, st) in unl.iter().enumerate() {
            let end = unl.get(k + 1).map(|n| n.t_land_s).unwrap_or(late);
            peak = st.force_after_n + (peak - st.force_after_n) * (-(end - st.t_land_s) / memory_s).exp();
        }
        let want = 0.02 * (s.v_eq(peak) - s.v_eq(last.force_after_n));
        assert!((gap(&fading, late) / want - 1.0).abs() < 0.02, "{} vs {want}", gap(&fading, late));
        assert!(
            gap(&fading, late) < 0.97 * gap(&fading, early) && gap(&fading, late) < 0.8 * gap(&kept, late),
            "{} {} {}",
            gap(&fading, early),
            gap(&fading, late),
            gap(&kept, late)
        );
    }

    /// Family B's form of hysteresis: the conductance, not the response, keeps a share of the
    /// peak's force gap. Late in the last removal's hold (without fading) the response is the
    /// divider's at G(F) + h · (F_max − F) / 1 N · g_ref; the same h kept on the response gives
    /// another offset.
    #[test]
    fn a_conductance_hysteresis_keeps_a_share_of_the_peaks_force_gap() {
        let (mut s, p) = defaults();
        s.noise_v = 0.0;
        s.effects.hysteresis = 0.02;
        let (_, in_v) = simulate(&s, &p, 20.0, None, 5);
        s.effects.hysteresis_in_conductance = true;
        let (_, in_g) = simulate(&s, &p, 20.0, None, 5);
        let last = in_g.steps.last().unwrap();
        let peak = in_g.steps.iter().map(|x| x.force_after_n).fold(0.0, f64::max);
        let k = ((last.t_land_s + p.final_rest_s - 0.5) * s.circuit.sample_rate_hz) as usize;
        let f = last.force_after_n;
        let want = s.response(s.conductance(f) + 0.02 * (peak - f) * s.g_ref_s);
        assert!((in_g.clean_v[k] - want).abs() < 1e-6 * s.circuit.vcc_v, "{} vs {want}", in_g.clean_v[k]);
        assert!(want > s.v_eq(f) + 1e-4 && (in_v.clean_v[k] - want).abs() > 1e-4, "{} {} {want}", s.v_eq(f), in_v.clean_v[k]);
        // a value other than a boolean is reported with its TOML path
        let bad = "[effects.hysteresis]\nfraction = 0.01\nin_conductance = 1\n";
        let err = SensorParams::from_source(&SourceFile::parse("s.toml", bad.to_string()).unwrap()).unwrap_err().to_string();
        assert!(err.contains("effects.hysteresis.in_conductance") && err.contains("use true"), "{err}");
    }

    /// Family B's form of a second relaxation: the conductance, not the response, is the mix of a
    /// fast and a slow relaxation. Late in the final rest (the fast part settled, the load
    /// constant) the conductance's excess over G(F) decays by e^(−Δt/τ2) exactly, and near no load
    /// the response lags far more than with the same share of the response's step; a value other
    /// than a boolean is reported with its TOML path.
    #[test]
    fn a_conductance_second_relaxation_decays_in_the_conductance() {
        let (mut s, p) = defaults();
        s.noise_v = 0.0;
        s.effects.second_fraction = 0.1;
        s.effects.second_tau_s = 30.0;
        let (_, in_v) = simulate(&s, &p, 20.0, None, 5);
        s.effects.second_in_conductance = true;
        let (_, in_g) = simulate(&s, &p, 20.0, None, 5);
        let last = in_g.steps.last().unwrap();
        let at = |dt: f64| ((last.t_land_s + dt) * s.circuit.sample_rate_hz).round() as usize;
        let (k1, k2) = (at(3.0), at(8.0));
        let g_f = s.conductance(last.force_after_n);
        let ratio = |v: &[f64]| (s.conductance_of(v[k2]) - g_f) / (s.conductance_of(v[k1]) - g_f);
        let want = (-5.0f64 / 30.0).exp();
        assert!((ratio(&in_g.clean_v) / want - 1.0).abs() < 1e-3, "{} vs {want}", ratio(&in_g.clean_v));
        // near no load a divider shows the conductance's lag in full: far more than the same share
        // of the response's step
        assert!(in_g.clean_v[k1] - in_v.clean_v[k1] > 0.01, "{} vs {}", in_g.clean_v[k1], in_v.clean_v[k1]);
        assert!(s.conductance_of(in_g.clean_v[k1]) > g_f, "the slow share lags the unloading");
        let bad = "[effects.second_time_constant]\nfraction = 0.1\nin_conductance = 1\n";
        let err = SensorParams::from_source(&SourceFile::parse("s.toml", bad.to_string()).unwrap()).unwrap_err().to_string();
        assert!(err.contains("effects.second_time_constant.in_conductance") && err.contains("use true"), "{err}");
    }

    /// Rests of one sign: every trial starts raised by the size a two-signed draw gives (the same
    /// draws, so the two differ only in sign); and a value other than a boolean is reported with
    /// its TOML path.
    #[test]
    fn rests_of_one_sign_start_every_trial_raised() {
        let (mut s, p) = defaults();
        s.noise_v = 0.0;
        let (_, plain) = simulate(&s, &p, 20.0, None, 1);
        s.nuisance.rest_v = 0.01;
        s.nuisance.rest_tau_s = 50.0;
        let start = |s: &SensorParams, seed: u64| simulate(s, &p, 20.0, None, seed).1.clean_v[0] - plain.clean_v[0];
        let two_signed: Vec<f64> = (1..=12).map(|seed| start(&s, seed)).collect();
        s.nuisance.rest_raised = true;
        let raised: Vec<f64> = (1..=12).map(|seed| start(&s, seed)).collect();
        assert!(two_signed.iter().any(|&a| a < -1e-4) && two_signed.iter().any(|&a| a > 1e-4), "{two_signed:?}");
        for (a, r) in two_signed.iter().zip(&raised) {
            assert!(*r >= 0.0 && (r - a.abs()).abs() < 1e-12, "{a} {r}");
        }
        let bad = "[nuisance]\nrest_v = 0.001\nrest_raised = \"yes\"\n";
        let err = SensorParams::from_source(&SourceFile::parse("s.toml", bad.to_string()).unwrap()).unwrap_err().to_string();
        assert!(err.contains("nuisance.rest_raised") && err.contains("use true"), "{err}");
    }

    #[test]
    fn csv_round_trips_through_the_parser() {
        let (s, p) = defaults();
        let (r, _) = simulate(&s, &p, 20.0, None, 3);
        let text = to_csv(&r, "test");
        let back = crate::sensor::recording::parse("x.csv", std::io::Cursor::new(text.into_bytes())).unwrap();
        assert_eq!(back.len(), r.len());
        assert!(back.response.iter().zip(&r.response).all(|(a, b)| (a - b).abs() < 1e-6));
    }

    #[test]
    fn a_cover_shares_the_load() {
        let (s, _) = defaults();
        let cv = Cover::new(1.5, 10.0, &s, 8.0);
        assert!(cv.dome_share > 0.0 && cv.dome_share < 1.0);
        assert!((cv.modulus_mpa - 2.0).abs() < 1e-12);
        let stiffer = Cover::new(1.5, 5.0, &s, 8.0);
        assert!(stiffer.dome_share < cv.dome_share);
    }
}
