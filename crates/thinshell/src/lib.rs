//! thinshell: scenes, the run loop and the `thinshell` command-line tool.
//!
//! A scene file (`docs/scenes.md`) is loaded and validated by [`scene`], turned into exactly the
//! energy terms, loads and stimulus it asks for, and run with an observer that reports progress
//! and writes output. The CLI (`thinshell run | check | info`) and `cargo xtask` are thin layers
//! over this library.

pub mod atomic;
pub mod cli;
pub mod face_fields;
pub mod mesh_info;
pub mod modes;
pub mod reference;
pub mod resume;
pub mod scene;
pub mod sim;
pub mod view;
pub mod vtk;

/// The README's example, compiled and run as a doctest so that it cannot go stale.
#[doc = include_str!("../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
