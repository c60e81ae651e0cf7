//! The catalogue of physics the paper's first-order model leaves out: one module per effect, each
//! with its signature in the residuals, its model term and a sentence a lab user understands.

pub mod handling_spikes;
