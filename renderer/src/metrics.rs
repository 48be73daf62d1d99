//! Image metrics (placeholder; being written).
