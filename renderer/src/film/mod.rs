//! Film output (placeholder; being written).
