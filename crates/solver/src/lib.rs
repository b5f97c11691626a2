//! thinshell-solver (placeholder, filled by a later issue).
