//! thinshell-mesh (placeholder, filled by a later issue).
