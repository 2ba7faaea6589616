// Crate root of our stand-in for rapier3d 0.36.1 (see ../build.rs and patches/README.md): the
// build script extracts the pristine published crate into OUT_DIR, applies
// ../rapier3d-0.36.1.patch and generates rapier's src/lib.rs there without its inner doc
// comments and inner attributes, which an `include!`d file may not have. They live here.

// rapier's crate documentation, taken from the `//!` lines of its (patched) lib.rs.
#![doc = include_str!(concat!(env!("OUT_DIR"), "/rapier3d-0.36.1/crate-doc.md"))]
// BEGIN rapier3d crate attributes: exactly the inner attributes of rapier's (patched) lib.rs,
// in order. build.rs checks this block against them and stops the build if they differ.
#![no_std]
#![deny(bare_trait_objects)]
#![warn(missing_docs)]
#![allow(clippy::too_many_arguments)]
#![allow(clippy::needless_range_loop)]
#![allow(clippy::module_inception)]
// END rapier3d crate attributes
// Ours: rapier's code is not ours to lint. cargo caps the lints of a crates.io dependency
// (`--cap-lints allow`) but not of a path dependency like this one, so silence its warnings
// here, as if it still came from the registry. Errors (such as the `deny` above) remain.
#![allow(warnings)]

include!(concat!(env!("OUT_DIR"), "/rapier3d-0.36.1/src/lib.rs"));
