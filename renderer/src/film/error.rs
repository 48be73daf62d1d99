//! [`FilmError`]: everything that can go wrong reading, encoding or writing an image.

use std::path::{Path, PathBuf};

/// An image could not be read, encoded or written. Every message is one line and names the file
/// (or says the encoding was in memory).
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    /// Creating, writing or renaming the output (or its temporary sibling) failed.
    #[error("cannot write {}: {source}", .path.display())]
    Write {
        /// The file that was to be written.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The file could not be opened or decoded.
    #[error("cannot read {}: {message}", .path.display())]
    Read {
        /// The file that was to be read.
        path: PathBuf,
        /// What went wrong, one line.
        message: String,
    },
    /// The encoder refused the image.
    #[error("cannot encode {format} {}: {message}", target(.path))]
    Encode {
        /// "EXR" or "PNG".
        format: &'static str,
        /// The destination file, `None` when encoding in memory.
        path: Option<PathBuf>,
        /// What went wrong, one line.
        message: String,
    },
    /// `write_image` was given a path whose extension it does not know.
    #[error(
        "cannot write {}: unsupported extension {extension:?} (expected .exr or .png)",
        .path.display()
    )]
    UnsupportedExtension {
        /// The file that was to be written.
        path: PathBuf,
        /// The extension found ("" when there is none).
        extension: String,
    },
    /// `pixels.len()` is not `width * height`.
    #[error("cannot encode {}: malformed image, {len} pixels for {width}x{height}", target(.path))]
    Malformed {
        /// The destination file, `None` when encoding in memory.
        path: Option<PathBuf>,
        /// Declared width.
        width: u32,
        /// Declared height.
        height: u32,
        /// Actual number of pixels.
        len: usize,
    },
}

impl FilmError {
    /// Attaches the destination file to an error raised while encoding in memory.
    pub(crate) fn at(self, file: &Path) -> Self {
        match self {
            Self::Encode {
                format,
                path: None,
                message,
            } => Self::Encode {
                format,
                path: Some(file.to_path_buf()),
                message,
            },
            Self::Malformed {
                path: None,
                width,
                height,
                len,
            } => Self::Malformed {
                path: Some(file.to_path_buf()),
                width,
                height,
                len,
            },
            other => other,
        }
    }
}

/// "for FILE" or "in memory".
fn target(path: &Option<PathBuf>) -> String {
    match path {
        Some(p) => format!("for {}", p.display()),
        None => "in memory".to_string(),
    }
}

/// A library error message squeezed onto one line.
pub(crate) fn one_line(message: impl std::fmt::Display) -> String {
    message
        .to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}
