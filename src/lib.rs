//! tipforge: printable FSR fingertips, calibration rig and PDMS molds for the Gifu Hand III from
//! parameter files, and the sensor calibration loop. See ARCHITECTURE.md for the module map.

pub mod build;
pub mod checks;
pub mod error;
pub mod export;
pub mod fingertip;
pub mod hand;
pub mod interp;
pub mod mesh;
pub mod mold;
pub mod params;
pub mod part;
pub mod plot;
pub mod preview;
pub mod progress;
pub mod rig;
pub mod sensor;
pub mod slicer;
