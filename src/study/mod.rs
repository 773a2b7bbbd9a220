//! A whole study: a folder of meshes and a lab's SMI recordings to stimuli, fixations, ground
//! truth, saliency maps and scores, resumable and shardable. May import every pipeline stage.
pub mod config;
pub mod demo;
mod error;
pub mod run;

pub use config::{template, Study, StudyMesh};
pub use error::StudyError;
pub use run::{merge_scores, merge_study, run_study, shard_of, RunOptions, StudyRun};
