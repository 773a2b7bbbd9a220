//! Measures on saliency maps.
pub mod gini;

pub use gini::{gini_index, lorenz_curve};
