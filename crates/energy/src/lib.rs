//! thinshell-energy (placeholder, filled by a later issue).
