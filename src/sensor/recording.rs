//! Recordings: one trial per CSV file (format in docs/recording-format.md). Streams the file
//! through the `csv` crate; every problem is reported with file:line and the fix, never a panic.

use super::csv_source::CommentTee;
use crate::error::{Error, Problem, Problems, Result};
use std::collections::BTreeMap;
use std::io::BufRead;
use std::path::Path;

/// Which side of the divider the sensor is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Divider {
    /// Sensor between supply and node: V = Vcc·Rm/(Rm + Rs).
    SensorHigh,
    /// Sensor between node and ground: V = Vcc·Rs/(Rm + Rs).
    SensorLow,
}

#[derive(Debug, Clone, Default, PartialEq)]
pub struct Meta {
    pub sample_rate_hz: Option<f64>,
    pub vcc_v: Option<f64>,
    pub r_m_ohm: Option<f64>,
    pub adc_bits: Option<u32>,
    pub vref_v: Option<f64>,
    pub divider: Option<Divider>,
    /// Every `key=value` line, including unknown keys (kept, not interpreted).
    pub all: BTreeMap<String, String>,
}

/// What the protocol column means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProtocolKind {
    LoadG,
    ForceN,
    Input,
}

impl ProtocolKind {
    pub fn column(self) -> &'static str {
        match self {
            ProtocolKind::LoadG => "load_g",
            ProtocolKind::ForceN => "force_n",
            ProtocolKind::Input => "input",
        }
    }
    /// Converts a protocol value to grams where that is meaningful.
    pub fn grams(self, v: f64) -> Option<f64> {
        match self {
            ProtocolKind::LoadG => Some(v),
            ProtocolKind::ForceN => Some(v / 9.80665 * 1000.0),
            ProtocolKind::Input => None,
        }
    }
}

#[derive(Debug, Clone)]
pub struct Recording {
    /// File it came from (as given).
    pub source: String,
    pub meta: Meta,
    pub time_s: Vec<f64>,
    /// The response, in `unit` ("V" when it could be converted to the divider voltage, else the
    /// column's own unit).
    pub response: Vec<f64>,
    pub unit: &'static str,
    /// The column the response came from.
    pub response_column: &'static str,
    pub protocol: Vec<f64>,
    pub protocol_kind: ProtocolKind,
    /// Columns present but not used.
    pub ignored_columns: Vec<String>,
    /// Set when the samples were block-averaged to the working rate ([`super::decimate`]): the
    /// recording as it was read.
    pub raw: Option<super::decimate::Raw>,
}

/// Time columns read, with the factor to seconds.
const TIMES: [(&str, f64); 3] = [("time_s", 1.0), ("time_ms", 1e-3), ("time_us", 1e-6)];
/// Response columns read: the name in the file, the column it is, the factor to that column's unit.
const RESPONSES: [(&str, &str, f64); 5] = [
    ("voltage_v", "voltage_v", 1.0),
    ("voltage_mv", "voltage_v", 1e-3),
    ("adc_counts", "adc_counts", 1.0),
    ("resistance_ohm", "resistance_ohm", 1.0),
    ("resistance_kohm", "resistance_ohm", 1e3),
];
/// Protocol columns read: the name in the file, what it is, the factor to that kind's unit.
const PROTOCOLS: [(&str, ProtocolKind, f64); 5] = [
    ("load_g", ProtocolKind::LoadG, 1.0),
    ("load_kg", ProtocolKind::LoadG, 1e3),
    ("force_n", ProtocolKind::ForceN, 1.0),
    ("force_kgf", ProtocolKind::ForceN, 9.80665),
    ("input", ProtocolKind::Input, 1.0),
];

fn listed<T>(table: &[T], name: impl Fn(&T) -> &str) -> String {
    table.iter().map(|x| name(x).to_string()).collect::<Vec<_>>().join(", ")
}

impl Recording {
    pub fn len(&self) -> usize {
        self.time_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
    /// Median sample interval (s).
    pub fn dt(&self) -> f64 {
        let stride = self.time_s.len().div_ceil(super::preprocess::MAX_STAT_SAMPLES).max(1);
        let mut d: Vec<f64> = self.time_s.windows(2).step_by(stride).map(|w| w[1] - w[0]).collect();
        if d.is_empty() {
            return 0.0;
        }
        let k = d.len() / 2;
        *d.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
    }
    /// Sample rate: from metadata, else from the time column.
    pub fn sample_rate_hz(&self) -> f64 {
        self.meta.sample_rate_hz.unwrap_or_else(|| 1.0 / self.dt().max(1e-12))
    }
    /// File stem, for output names.
    pub fn stem(&self) -> String {
        Path::new(&self.source).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "recording".into())
    }
}

/// Reads a recording; all problems found are returned together.
pub fn read(path: &Path) -> Result<Recording> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    // rows of a typical length: the columns are allocated once instead of doubling (a doubling
    // vector holds up to twice its data at its peak)
    let rows_hint = f.metadata().map(|m| (m.len() / 22) as usize).unwrap_or(0).min(1 << 28);
    parse_with_hint(&path.display().to_string(), std::io::BufReader::with_capacity(1 << 16, f), rows_hint)
}

struct P<'a> {
    file: &'a str,
    out: Vec<Problem>,
}

impl P<'_> {
    fn at(&mut self, line: usize, what: &str, value: impl ToString, fix: impl Into<String>) {
        if self.out.len() < 50 {
            self.out.push(Problem { file: self.file.to_string(), line: Some(line), path: what.to_string(), value: value.to_string(), message: fix.into() });
        }
    }
}

/// One column the recording is read from: its position, its name in the file, the factor that
/// converts it to tipforge's unit.
#[derive(Clone, Copy)]
struct Col {
    at: usize,
    name: &'static str,
    factor: f64,
}

/// The three columns read, and how many cells a row has.
struct Columns {
    time: Col,
    response: Col,
    response_column: &'static str,
    protocol: Col,
    protocol_kind: ProtocolKind,
    ncols: usize,
    ignored: Vec<String>,
}

/// The rows read so far.
#[derive(Default)]
struct Rows {
    t: Vec<f64>,
    r: Vec<f64>,
    g: Vec<f64>,
    bad: usize,
}

/// Parses a recording from any reader: streamed through the `csv` crate (quoted cells and headers
/// as spreadsheets write them), with the `#` lines taken out for the metadata.
pub fn parse(file: &str, reader: impl BufRead) -> Result<Recording> {
    parse_with_hint(file, reader, 0)
}

/// [`parse`], with room for about `rows_hint` rows reserved up front.
fn parse_with_hint(file: &str, reader: impl BufRead, rows_hint: usize) -> Result<Recording> {
    let mut p = P { file, out: Vec::new() };
    let mut rdr = csv::ReaderBuilder::new().has_headers(false).flexible(true).trim(csv::Trim::All).from_reader(CommentTee::new(reader));
    let mut rec = csv::StringRecord::new();
    let mut header: Option<(usize, Option<Columns>)> = None;
    let mut rows = Rows { t: Vec::with_capacity(rows_hint), r: Vec::with_capacity(rows_hint), g: Vec::with_capacity(rows_hint), bad: 0 };
    loop {
        match rdr.read_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => {
                let n = e.position().map(|q| q.line() as usize).unwrap_or(0);
                p.at(n, "(line)", "unreadable", format!("{e}: export the recording as UTF-8 CSV"));
                break;
            }
        }
        let n = rec.position().map(|q| q.line() as usize).unwrap_or(0);
        if rec.iter().all(str::is_empty) {
            continue;
        }
        match &header {
            None => header = Some((n, read_header(&mut p, n, &rec))),
            Some((_, Some(c))) => read_row(&mut p, n, &rec, c, &mut rows),
            Some((_, None)) => break,
        }
    }
    let tee = rdr.into_inner();
    if let Some(n) = tee.not_text {
        p.at(n, "(line)", "unreadable", "the file is not text (invalid UTF-8); export the recording as UTF-8 CSV");
    }
    // metadata lines, wherever they stood
    let mut meta = Meta::default();
    let mut meta_lines: BTreeMap<String, usize> = BTreeMap::new();
    for (n, c) in &tee.comments {
        if let Some((k, v)) = c.split_once('=') {
            let (k, v) = (k.trim().to_string(), v.trim().to_string());
            meta_lines.insert(k.clone(), *n);
            parse_meta(&mut p, *n, &k, &v, &mut meta);
            meta.all.insert(k, v);
        }
    }
    let header_line = header.as_ref().map(|h| h.0).unwrap_or(1);
    match &header {
        None => p.at(1, "(file)", "empty", "no header and no data: a recording needs a header row (time_s, a response column, a protocol column) and data rows"),
        Some((hn, _)) if rows.t.is_empty() && p.out.is_empty() => p.at(*hn, "(file)", "no data rows", "the file has a header but no data"),
        Some(_) => {}
    }
    let Rows { t, r, g, bad: bad_rows } = rows;
    rate_in_range(&mut p, &t, header_line);
    check_meta(&mut p, &meta, &meta_lines, &t);
    let cols = header.and_then(|h| h.1);
    let response_column = cols.as_ref().map(|c| c.response_column).unwrap_or("");
    let (response, unit) = to_unit(&mut p, response_column, r, &meta, header_line);
    if !p.out.is_empty() {
        if bad_rows > 50 {
            p.out.push(Problem {
                file: file.into(),
                line: None,
                path: "(rows)".into(),
                value: format!("{bad_rows} bad rows"),
                message: "only the first 50 problems are listed".into(),
            });
        }
        return Err(Error::Input(Problems(p.out)));
    }
    let (protocol_kind, ignored) = cols.map(|c| (c.protocol_kind, c.ignored)).unwrap_or((ProtocolKind::Input, vec![]));
    Ok(Recording { source: file.to_string(), meta, time_s: t, response, unit, response_column, protocol: g, protocol_kind, ignored_columns: ignored, raw: None })
}

/// The header row: which columns are read (None when it names no usable set; the problems say why).
fn read_header(p: &mut P, n: usize, rec: &csv::StringRecord) -> Option<Columns> {
    let line = rec.iter().collect::<Vec<_>>().join(",");
    if rec.len() == 1 {
        if let Some(sep) = [';', '\t'].into_iter().find(|c| line.contains(*c)) {
            let shown = if sep == ';' { "`;`" } else { "tabs" };
            p.at(n, "header", &line, format!("cells are separated by {shown}: tipforge reads comma-separated files with a decimal point; export the recording as CSV with commas"));
            return None;
        }
    }
    let names: Vec<String> = rec.iter().map(|c| c.to_ascii_lowercase()).collect();
    let find = |want: &str| names.iter().enumerate().filter(|(_, c)| *c == want).map(|(i, _)| i).collect::<Vec<_>>();
    let time: Vec<Col> = TIMES.iter().flat_map(|&(c, f)| find(c).into_iter().map(move |at| Col { at, name: c, factor: f })).collect();
    if time.len() != 1 {
        let why = if time.is_empty() {
            format!(
                "no `time_s` column: the first non-comment line must be a header naming time_s (or {}), one response column and one protocol column",
                listed(&TIMES[1..], |x| x.0)
            )
        } else {
            "`time_s` appears more than once (a time column is needed exactly once)".to_string()
        };
        p.at(n, "header", &line, why);
    }
    let resp: Vec<(Col, &'static str)> = RESPONSES.iter().flat_map(|&(c, canon, f)| find(c).into_iter().map(move |at| (Col { at, name: c, factor: f }, canon))).collect();
    if resp.len() != 1 {
        p.at(n, "header", &line, format!("exactly one response column is needed, one of {}; found {}", listed(&RESPONSES, |x| x.0), resp.len()));
    }
    let prot: Vec<(Col, ProtocolKind)> = PROTOCOLS.iter().flat_map(|&(c, k, f)| find(c).into_iter().map(move |at| (Col { at, name: c, factor: f }, k))).collect();
    if prot.len() != 1 {
        p.at(n, "header", &line, format!("exactly one protocol column is needed, one of {}; found {}", listed(&PROTOCOLS, |x| x.0), prot.len()));
    }
    if time.len() != 1 || resp.len() != 1 || prot.len() != 1 {
        return None;
    }
    let used = [time[0].at, resp[0].0.at, prot[0].0.at];
    let ignored = names.iter().enumerate().filter(|(i, _)| !used.contains(i)).map(|(_, c)| c.clone()).collect();
    Some(Columns { time: time[0], response: resp[0].0, response_column: resp[0].1, protocol: prot[0].0, protocol_kind: prot[0].1, ncols: names.len(), ignored })
}

/// One data row: its three values in tipforge's units, or its problems.
fn read_row(p: &mut P, n: usize, rec: &csv::StringRecord, c: &Columns, rows: &mut Rows) {
    if rec.len() != c.ncols {
        p.at(n, "row", rec.iter().collect::<Vec<_>>().join(","), format!("has {} cells, the header has {}", rec.len(), c.ncols));
        rows.bad += 1;
        return;
    }
    let mut vals = [0.0; 3];
    let mut ok = true;
    for (k, col) in [c.time, c.response, c.protocol].iter().enumerate() {
        match rec[col.at].parse::<f64>() {
            Ok(v) if v.is_finite() => vals[k] = v * col.factor,
            Ok(v) => {
                p.at(n, col.name, v, "NaN or infinite values are not allowed: remove the row or fill the gap");
                ok = false;
            }
            Err(_) => {
                p.at(n, col.name, format!("{:?}", &rec[col.at]), "not a number");
                ok = false;
            }
        }
    }
    if !ok {
        rows.bad += 1;
        return;
    }
    if let Some(&last) = rows.t.last() {
        if vals[0] <= last {
            p.at(n, c.time.name, shown(vals[0] / c.time.factor), format!("time must increase (previous row: {})", shown(last / c.time.factor)));
            rows.bad += 1;
            return;
        }
    }
    if let Some(why) = implausible(c.response_column, vals[1]) {
        p.at(n, c.response.name, shown(vals[1] / c.response.factor), why);
        rows.bad += 1;
        return;
    }
    if c.protocol_kind != ProtocolKind::Input && vals[2] < 0.0 {
        p.at(
            n,
            c.protocol.name,
            rec[c.protocol.at].to_string(),
            "a load on the sensor cannot be negative: log the load the weights or the actuator put on the sensor (0 when unloaded)",
        );
        rows.bad += 1;
        return;
    }
    rows.t.push(vals[0]);
    rows.r.push(vals[1]);
    rows.g.push(vals[2]);
}

/// Metadata that contradicts the data.
fn check_meta(p: &mut P, meta: &Meta, meta_lines: &BTreeMap<String, usize>, t: &[f64]) {
    if let (Some(fs), true) = (meta.sample_rate_hz, t.len() > 10) {
        let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(|a, b| a.total_cmp(b));
        let med = d[d.len() / 2];
        if ((1.0 / med) / fs - 1.0).abs() > 0.1 {
            p.at(
                meta_lines.get("sample_rate_hz").copied().unwrap_or(1),
                "sample_rate_hz",
                fs,
                format!("contradicts the time column (median interval {med:.5} s = {:.2} Hz): fix the metadata", 1.0 / med),
            );
        }
    }
}

impl Meta {
    /// The ADC's full scale in counts (2^bits − 1) and its reference (V), when the metadata give
    /// both (bits 1–63, vref positive and finite).
    pub fn adc_scale(&self) -> Option<(f64, f64)> {
        match (self.adc_bits, self.vref_v) {
            (Some(bits), Some(vref)) if (1..64).contains(&bits) && vref > 0.0 && vref.is_finite() => Some(((1u64 << bits) as f64 - 1.0, vref)),
            _ => None,
        }
    }
    /// One ADC count in volts, vref / (2^bits − 1).
    pub fn adc_step_v(&self) -> Option<f64> {
        self.adc_scale().map(|(full, vref)| vref / full)
    }
}

/// The response in volts where the metadata allow, else in its column's unit.
fn to_unit(p: &mut P, response_column: &'static str, r: Vec<f64>, meta: &Meta, header_line: usize) -> (Vec<f64>, &'static str) {
    if let (Some((max, _)), Some(bits), "adc_counts") = (meta.adc_scale(), meta.adc_bits, response_column) {
        if let Some(bad) = r.iter().position(|&v| v < 0.0 || v > max) {
            p.at(0, "adc_counts", r[bad], format!("outside 0..{max} for adc_bits = {bits}: the metadata or the column is wrong"));
        }
    }
    match response_column {
        "voltage_v" => (r, "V"),
        "adc_counts" => match meta.adc_scale() {
            Some((full, vref)) => (r.iter().map(|c| c / full * vref).collect(), "V"),
            None => {
                p.at(header_line, "adc_counts", "no adc_bits/vref_v", "converting counts to volts needs `# adc_bits=12` and `# vref_v=3.3` metadata lines");
                (r, "counts")
            }
        },
        "resistance_ohm" => match (meta.vcc_v, meta.r_m_ohm, meta.divider) {
            (Some(vcc), Some(rm), Some(div)) => (
                r.iter()
                    .map(|rs| match div {
                        Divider::SensorHigh => vcc * rm / (rm + rs),
                        Divider::SensorLow => vcc * rs / (rm + rs),
                    })
                    .collect(),
                "V",
            ),
            _ => (r, "ohm"),
        },
        _ => (r, ""),
    }
}

/// The largest response magnitudes tipforge reads, per column: beyond them the column is in
/// another unit (mV, kΩ written as Ω·10⁹, a scaling gone wrong) and sums of squares overflow.
pub const MAX_VOLTAGE_V: f64 = 1000.0;
pub const MAX_RESISTANCE_OHM: f64 = 1e13;
pub const MAX_ADC_COUNTS: f64 = 4_294_967_295.0;

/// A number as a person reads it: plain when ordinary, in e-notation when huge or tiny.
fn shown(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// Why a response value cannot be a reading of its column, if it cannot.
fn implausible(column: &str, v: f64) -> Option<String> {
    match column {
        "voltage_v" if v.abs() > MAX_VOLTAGE_V => {
            Some(format!("a divider voltage beyond ±{MAX_VOLTAGE_V} V: voltage_v must be in volts (convert millivolts; check the export's scaling)"))
        }
        "resistance_ohm" if !(0.0..=MAX_RESISTANCE_OHM).contains(&v) => {
            Some(format!("a resistance must lie between 0 and {MAX_RESISTANCE_OHM:e} ohm: resistance_ohm must be in ohms (convert kΩ or MΩ)"))
        }
        "adc_counts" if !(0.0..=MAX_ADC_COUNTS).contains(&v) => Some("ADC counts lie between 0 and 2^32 − 1: check the column".into()),
        _ => None,
    }
}

/// The sample rates tipforge reads (Hz): from a meter logging every 10 s to a 100 kHz DAQ; the
/// simulator writes 1 to 100 000 Hz.
pub const RATE_RANGE_HZ: (f64, f64) = (0.1, 100_000.0);

/// The time column's rate, from its median and its mean interval, must lie in [`RATE_RANGE_HZ`]:
/// a column in the wrong unit (µs, hours) or a corrupted one is named before any fitting.
fn rate_in_range(p: &mut P, t: &[f64], header_line: usize) {
    if t.len() < 2 {
        return;
    }
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    d.sort_by(|a, b| a.total_cmp(b));
    let median = d[d.len() / 2];
    let mean = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    let (lo, hi) = RATE_RANGE_HZ;
    for (what, dt) in [("median", median), ("mean", mean)] {
        let rate = 1.0 / dt;
        if !(lo..=hi).contains(&rate) {
            p.at(
                header_line + 1,
                "time_s",
                format!("{what} interval {dt:e} s"),
                format!("a sample rate of {rate:.3e} Hz is outside {lo} to {hi} Hz: time_s must be in seconds (convert milliseconds or microseconds), increasing by the sampling interval"),
            );
            return;
        }
    }
}

fn parse_meta(p: &mut P, n: usize, k: &str, v: &str, m: &mut Meta) {
    let num = |p: &mut P, v: &str| -> Option<f64> {
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() && x > 0.0 => Some(x),
            _ => {
                p.at(n, k, v, "must be a positive number");
                None
            }
        }
    };
    match k {
        "sample_rate_hz" => m.sample_rate_hz = num(p, v),
        "vcc_v" => m.vcc_v = num(p, v),
        "r_m_ohm" => m.r_m_ohm = num(p, v),
        "vref_v" => m.vref_v = num(p, v),
        "adc_bits" => match v.parse::<u32>() {
            Ok(b) if (1..=32).contains(&b) => m.adc_bits = Some(b),
            _ => p.at(n, k, v, "must be a whole number of bits from 1 to 32"),
        },
        "divider" => match v {
            "sensor_high" => m.divider = Some(Divider::SensorHigh),
            "sensor_low" => m.divider = Some(Divider::SensorLow),
            _ => p.at(n, k, v, "use `sensor_high` (sensor between supply and node) or `sensor_low`"),
        },
        _ => {}
    }
    if let (Some(vcc), Some(vref)) = (m.vcc_v, m.vref_v) {
        if (k == "vref_v" || k == "vcc_v") && vref > 0.0 && vcc > 2.0 * vref.max(1e-9) * 10.0 {
            p.at(n, k, v, format!("vcc_v = {vcc} and vref_v = {vref} contradict each other"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Recording> {
        parse("t.csv", std::io::Cursor::new(s.as_bytes().to_vec()))
    }

    fn problems(s: &str) -> String {
        match parse_str(s) {
            Err(Error::Input(p)) => p.to_string(),
            Err(e) => panic!("unexpected {e}"),
            Ok(_) => panic!("accepted:\n{s}"),
        }
    }

    #[test]
    fn voltage_recording_parses_with_metadata() {
        let r = parse_str("# sample_rate_hz=100\n# note: hi\ntime_s,voltage_v,load_g,extra\n0,0.1,0,x\n0.01,0.2,200,y\n").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r.unit, "V");
        assert_eq!(r.protocol_kind, ProtocolKind::LoadG);
        assert_eq!(r.ignored_columns, vec!["extra".to_string()]);
    }

    #[test]
    fn adc_counts_convert_with_bits_and_reference() {
        let r = parse_str("# adc_bits=12\n# vref_v=3.3\ntime_s,adc_counts,force_n\n0,4095,0\n0.01,0,1\n").unwrap();
        assert!((r.response[0] - 3.3).abs() < 1e-12 && r.response[1] == 0.0);
    }

    #[test]
    fn resistance_converts_through_the_divider_or_stays_in_ohm() {
        let r = parse_str("# vcc_v=3.3\n# r_m_ohm=1000\n# divider=sensor_high\ntime_s,resistance_ohm,input\n0,1000,0\n1,3000,1\n").unwrap();
        assert!((r.response[0] - 1.65).abs() < 1e-12 && (r.response[1] - 0.825).abs() < 1e-12);
        let r = parse_str("time_s,resistance_ohm,input\n0,1000,0\n1,3000,1\n").unwrap();
        assert_eq!(r.unit, "ohm");
    }

    #[test]
    fn byte_order_mark_and_crlf_are_read_and_other_separators_named() {
        let r = parse("a.csv", "\u{feff}time_s,voltage_v,load_g\r\n0,0.1,0\r\n0.01,0.2,100\r\n".as_bytes()).unwrap();
        assert_eq!((r.len(), r.response[1], r.protocol[1]), (2, 0.2, 100.0));
        let e = problems("time_s;voltage_v;load_g\n0;0,1;0\n");
        assert!(e.contains("separated by `;`") && e.matches("t.csv").count() == 1, "{e}");
        assert!(problems("time_s\tvoltage_v\tload_g\n0\t0.1\t0\n").contains("separated by tabs"));
    }

    #[test]
    fn missing_and_duplicate_columns() {
        assert!(problems("time_s,load_g\n0,1\n").contains("exactly one response column"));
        assert!(problems("time_s,voltage_v,adc_counts,load_g\n0,1,2,3\n").contains("found 2"));
        assert!(problems("voltage_v,load_g\n0,1\n").contains("no `time_s` column"));
        assert!(problems("time_s,voltage_v\n0,1\n").contains("exactly one protocol column"));
        assert!(problems("time_s,time_s,voltage_v,load_g\n0,0,1,1\n").contains("more than once"));
    }

    #[test]
    fn bad_cells_name_their_line_all_at_once() {
        let s = problems("time_s,voltage_v,load_g\n0,0.1,0\n0.01,abc,0\n0.02,NaN,0\n0.03,inf,0\n0.0,0.1,0\n0.05,0.1\n");
        assert!(s.contains("t.csv:3: voltage_v = \"abc\": not a number"), "{s}");
        assert!(s.contains("t.csv:4:") && s.contains("NaN or infinite"), "{s}");
        assert!(s.contains("t.csv:5:"), "{s}");
        assert!(s.contains("t.csv:6: time_s = 0: time must increase"), "{s}");
        assert!(s.contains("t.csv:7:") && s.contains("has 2 cells"), "{s}");
    }

    /// Issue 17, defect 10: CSV as spreadsheets write it.
    #[test]
    fn quoted_headers_and_cells_are_read() {
        let r = parse_str("\"time_s\",\"voltage_v\",\"load_g\",\"note, free text\"\n\"0\",\"0.1\",\"0\",\"a, b\"\n0.01,0.2,100,\"x\"\n").unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.01]);
        assert_eq!(r.response, vec![0.1, 0.2]);
        assert_eq!(r.protocol, vec![0.0, 100.0]);
        assert_eq!(r.ignored_columns, vec!["note, free text".to_string()]);
        // a comment with a lone quote does not swallow the rows after it
        let r = parse_str("time_s,voltage_v,load_g\n# 5\" weight placed\n0,0.1,0\n0.01,0.2,100\n").unwrap();
        assert_eq!(r.len(), 2);
    }

    #[test]
    fn columns_in_other_obvious_units_are_converted() {
        let r = parse_str("time_ms,voltage_mv,force_kgf\n0,100,0\n10,250,1\n").unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.01]);
        assert!((r.response[1] - 0.25).abs() < 1e-12 && r.unit == "V" && r.response_column == "voltage_v");
        assert_eq!(r.protocol_kind, ProtocolKind::ForceN);
        assert!((r.protocol[1] - 9.80665).abs() < 1e-12);
        let r = parse_str("time_s,resistance_kohm,load_kg\n0,40,0\n1,35,0.2\n").unwrap();
        assert_eq!((r.response[0], r.unit), (40_000.0, "ohm"));
        assert_eq!((r.protocol[1], r.protocol_kind), (200.0, ProtocolKind::LoadG));
        // a problem names the column as the file does
        assert!(problems("time_ms,voltage_mv,load_g\n0,1,0\n10,abc,0\n").contains("t.csv:3: voltage_mv = \"abc\""));
    }

    #[test]
    fn empty_file_and_header_only() {
        assert!(problems("").contains("no header and no data"));
        assert!(problems("# sample_rate_hz=100\n").contains("no header and no data"));
        assert!(problems("time_s,voltage_v,load_g\n").contains("no data"));
    }

    #[test]
    fn contradictory_metadata() {
        let mut s = String::from("# sample_rate_hz=100\ntime_s,voltage_v,load_g\n");
        for i in 0..50 {
            s += &format!("{},0.1,0\n", i as f64 * 0.1);
        }
        assert!(problems(&s).contains("contradicts the time column"));
        assert!(problems("# divider=middle\ntime_s,voltage_v,load_g\n0,1,1\n").contains("sensor_high"));
        assert!(problems("# adc_bits=40\ntime_s,voltage_v,load_g\n0,1,1\n").contains("1 to 32"));
        assert!(problems("time_s,adc_counts,load_g\n0,1,1\n").contains("needs `# adc_bits=12`"));
        assert!(problems("# adc_bits=10\n# vref_v=3.3\ntime_s,adc_counts,load_g\n0,2000,1\n").contains("outside 0..1023"));
    }

    #[test]
    fn time_steps_outside_the_rate_range_are_named() {
        for dt in [1e-300, 2e-10, 100.0] {
            let mut s = String::from("time_s,voltage_v,load_g\n");
            for i in 0..400 {
                s += &format!("{:e},0.1,{}\n", i as f64 * dt, if i > 200 { 100 } else { 0 });
            }
            let e = problems(&s);
            assert!(e.contains("t.csv:2: time_s") && e.contains("outside 0.1 to 100000 Hz"), "{dt}: {e}");
        }
        let ok = parse_str("time_s,voltage_v,load_g\n0,0.1,0\n0.1,0.1,0\n0.2,0.2,100\n").unwrap();
        assert_eq!(ok.len(), 3);
    }

    #[test]
    fn responses_no_sensor_gives_and_negative_loads_are_named_with_their_line() {
        let e = problems("time_s,voltage_v,load_g\n0,0.1,0\n0.01,1e300,0\n0.02,0.1,-200\n");
        assert!(e.contains("t.csv:3: voltage_v") && e.contains("in volts"), "{e}");
        assert!(e.contains("t.csv:4: load_g = -200") && e.contains("cannot be negative"), "{e}");
        assert!(problems("time_s,resistance_ohm,input\n0,-5,0\n1,3,1\n").contains("t.csv:2: resistance_ohm = -5"));
        // an actuator's unitless input may be negative
        assert!(parse_str("time_s,voltage_v,input\n0,0.1,-3\n0.01,0.2,0\n").is_ok());
    }

    #[test]
    fn shared_real_recording_parses() {
        let path = std::path::Path::new("../shared/data/real/cbsilicone_v10_Ro.csv");
        if !path.exists() {
            eprintln!("skipped: {} is absent", path.display());
            return;
        }
        let r = read(path).unwrap();
        assert_eq!(r.unit, "ohm");
        assert_eq!(r.protocol_kind, ProtocolKind::Input);
        assert!(r.len() > 13000);
    }
}
