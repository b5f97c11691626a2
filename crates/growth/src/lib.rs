//! thinshell-growth (placeholder, filled by a later issue).
