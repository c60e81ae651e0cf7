//! Screws by name (`screw = "ISO 7045 M2"`): the clearance hole and the head a recess must take.
//!
//! Head sizes are the standards' maximum values: ISO 4762 / DIN 912 socket head cap screws,
//! ISO 7045 / DIN 7985 pan head screws, ISO 7046 / DIN 965 90° countersunk screws. Clearance holes
//! are ISO 273 "medium". A recess is sized from them with a clearance, so that a head of the
//! largest size the standard allows fits and sits below the surface.

/// How a screw's head is seated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeadKind {
    /// Cylindrical head (cap, pan): a counterbore.
    Cylindrical,
    /// 90° countersunk head: a countersink.
    Countersunk,
}

/// One screw's dimensions (millimetres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Screw {
    pub clearance_hole_mm: f64,
    pub head: HeadKind,
    pub head_diameter_mm: f64,
    pub head_height_mm: f64,
}

/// (thread, ISO 273 medium clearance hole, ISO 4762 dk/k, ISO 7045 dk/k, ISO 7046 dk/k)
const SIZES: &[(&str, f64, [f64; 2], [f64; 2], [f64; 2])] = &[
    ("M1.6", 1.8, [3.0, 1.6], [3.2, 1.3], [3.0, 1.0]),
    ("M2", 2.4, [3.8, 2.0], [4.0, 1.6], [3.8, 1.2]),
    ("M2.5", 2.9, [4.5, 2.5], [5.0, 2.1], [4.7, 1.5]),
    ("M3", 3.4, [5.5, 3.0], [5.6, 2.4], [5.5, 1.65]),
    ("M4", 4.5, [7.0, 4.0], [8.0, 3.1], [8.4, 2.7]),
    ("M5", 5.5, [8.5, 5.0], [9.5, 3.7], [9.3, 2.7]),
];

/// The standards by their names, each with the head it describes.
const STANDARDS: &[(&str, usize)] = &[("ISO 4762", 0), ("DIN 912", 0), ("ISO 7045", 1), ("DIN 7985", 1), ("ISO 7046", 2), ("DIN 965", 2)];

/// Every name `lookup` knows, for messages.
pub fn known() -> Vec<String> {
    STANDARDS.iter().flat_map(|(s, _)| SIZES.iter().map(move |z| format!("{s} {}", z.0))).collect()
}

/// The screw a designation names ("ISO 7045 M2", "din 912 m2.5"), or a message saying what is
/// known.
pub fn lookup(name: &str) -> Result<Screw, String> {
    let norm = name.split_whitespace().collect::<Vec<_>>().join(" ").to_uppercase();
    let Some((std_name, which)) = STANDARDS.iter().find(|(s, _)| norm.starts_with(&format!("{s} "))) else {
        let standards: Vec<&str> = STANDARDS.iter().map(|s| s.0).collect();
        return Err(format!("unknown screw standard; name one of {} followed by a size, e.g. \"ISO 7045 M2\"", standards.join(", ")));
    };
    let size = norm[std_name.len()..].trim();
    let Some(&(_, hole, cap, pan, csk)) = SIZES.iter().find(|z| z.0 == size) else {
        let sizes: Vec<&str> = SIZES.iter().map(|z| z.0).collect();
        return Err(format!("no size {size:?} in the table of {std_name}; use one of {}", sizes.join(", ")));
    };
    let (head, [d, k]) = match which {
        0 => (HeadKind::Cylindrical, cap),
        1 => (HeadKind::Cylindrical, pan),
        _ => (HeadKind::Countersunk, csk),
    };
    Ok(Screw { clearance_hole_mm: hole, head, head_diameter_mm: d, head_height_mm: k })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_issue_s_two_m2_screws_differ_in_their_heads() {
        let pan = lookup("ISO 7045 M2").unwrap();
        let cap = lookup("din 912  m2").unwrap();
        assert_eq!((pan.head_diameter_mm, pan.head_height_mm, pan.clearance_hole_mm), (4.0, 1.6, 2.4));
        assert_eq!((cap.head_diameter_mm, cap.head_height_mm), (3.8, 2.0));
        assert_eq!(lookup("DIN 965 M3").unwrap().head, HeadKind::Countersunk);
    }

    #[test]
    fn unknown_names_say_what_is_known() {
        assert!(lookup("ISO 9999 M2").unwrap_err().contains("ISO 7045"));
        assert!(lookup("ISO 7045 M7").unwrap_err().contains("M2.5"));
        assert_eq!(known().len(), STANDARDS.len() * SIZES.len());
    }
}
