//! No code: see `Cargo.toml` (the features that give the whole workspace one build).
