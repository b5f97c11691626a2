"""The build backend of the ``thinshell`` package: maturin's, with two differences.

- No silent toolchain download. Without ``cargo`` on PATH, maturin's backend downloads a Rust
  toolchain (about 1.2 GB) into a temporary directory; this backend stops instead and says how to
  get Rust, unless ``THINSHELL_DOWNLOAD_RUST=1`` asks for maturin's download.
- One target directory. When the package is built from its place in the thinshell repository
  (``pip install ./python``), the extension is compiled into the workspace's target directory
  (``$CARGO_TARGET_DIR``, else ``<repository>/target``), so the crates the Rust tests compiled are
  reused instead of compiled again into a second one.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import maturin

_PACKAGE = Path(__file__).resolve().parents[1]


def _prepare() -> None:
    if not shutil.which("cargo") and os.environ.get("THINSHELL_DOWNLOAD_RUST") != "1":
        raise SystemExit(
            "\nthinshell: building this package compiles Rust code, and `cargo` was not found on PATH.\n"
            "Install a Rust toolchain (https://rustup.rs, or your system's `cargo` and `rustc` packages;\n"
            "the minimum version is the workspace's `rust-version`) and run the install again.\n"
            "Or set THINSHELL_DOWNLOAD_RUST=1 to let maturin download a toolchain of about 1.2 GB\n"
            "into a temporary directory for this build (it is deleted afterwards).\n"
        )
    workspace = _PACKAGE.parent
    if "CARGO_TARGET_DIR" not in os.environ and (workspace / "Cargo.toml").is_file() and (workspace / "crates").is_dir():
        os.environ["CARGO_TARGET_DIR"] = str(workspace / "target")


def get_requires_for_build_wheel(config_settings=None):
    _prepare()
    return maturin.get_requires_for_build_wheel(config_settings)


def get_requires_for_build_editable(config_settings=None):
    _prepare()
    return maturin.get_requires_for_build_editable(config_settings)


def get_requires_for_build_sdist(config_settings=None):
    _prepare()
    return maturin.get_requires_for_build_sdist(config_settings)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    _prepare()
    return maturin.prepare_metadata_for_build_wheel(metadata_directory, config_settings)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    _prepare()
    return maturin.build_wheel(wheel_directory, config_settings, metadata_directory)


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    _prepare()
    return maturin.build_editable(wheel_directory, config_settings, metadata_directory)


def build_sdist(sdist_directory, config_settings=None):
    _prepare()
    return maturin.build_sdist(sdist_directory, config_settings)
