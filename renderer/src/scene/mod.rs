//! Scene loading (placeholder; being written).
pub mod types;
pub use types::*;
