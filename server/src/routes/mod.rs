//! HTTP handlers, one module per resource: jobs (submit, list, control), events (SSE), images
//! (PNG/EXR snapshots), scenes (built-ins), integrators (the registry), ops (health, metrics),
//! workers (the farm's workers), static_files (web viewer).
//! The router itself is assembled in `app.rs`.

pub mod events;
pub mod extract;
pub mod images;
pub mod integrators;
pub mod jobs;
pub mod ops;
pub mod scenes;
pub mod static_files;
pub mod workers;
