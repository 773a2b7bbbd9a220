//! From 2D screen fixations to mesh vertices (paper §4): the camera that was on screen at the
//! fixation's time (the stimulus's own [`CameraPlan`](crate::stimulus::CameraPlan)), the screen point mapped into the video
//! (letterbox-aware), a ray from the eye through it, the first hit through a BVH with a
//! watertight triangle test, and the hit triangle's nearest corner.
//!
//! Every fixation ends with exactly one [`ProjectionFate`]; nothing is dropped.
mod fates;
pub mod project_file;
mod project_fixations;
pub(crate) mod ray_caster;
pub mod round_trip;
mod screen_mapping;
pub mod self_check;
pub mod table;

pub use fates::{count_fates, fate_counts_by_name, fate_table_text, ProjectionFate};
pub use project_fixations::*;
pub use ray_caster::{nearest_corner, Hit, RayCaster};
pub use screen_mapping::ScreenMapping;
