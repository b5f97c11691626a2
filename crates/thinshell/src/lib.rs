//! thinshell: scenes, run loop and command-line tool (placeholder, filled by a later issue).
