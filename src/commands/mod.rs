pub mod bench;
pub mod demo;
pub mod ingest;
pub mod progress_bar;
pub mod saliency;
pub mod score;
pub mod stimulus;
