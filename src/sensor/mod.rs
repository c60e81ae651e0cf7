//! The sensor loop: recordings → preprocessing → fits → fashion curves → reports; the simulator.

pub mod advice;
pub mod analyze;
pub mod catalogue;
pub mod censored;
pub mod cli;
pub mod csv_source;
pub mod decimate;
pub mod diagnose;
pub mod diagnose_out;
pub mod edges;
pub mod fashion;
pub mod fit;
pub mod golden;
pub mod heldout_guard;
pub mod output;
pub mod pooling;
pub mod preprocess;
pub mod recording;
pub mod sim;
pub mod twin;
pub mod usable;
