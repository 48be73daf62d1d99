//! Jobs: the model (states, settings, JSON view), request parsing and validation, and scene
//! uploads (multipart, tar/zip).

pub mod model;
pub mod request;
pub mod upload;
#[cfg(test)]
mod upload_fuzz;
