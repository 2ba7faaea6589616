// Crate root of our stand-in for parry3d 0.31.1 (see ../build.rs, ../../crate_patch.rs and
// patches/README.md): the build script extracts the pristine published crate into OUT_DIR,
// applies ../parry3d-0.31.1.patch and generates parry's src/lib.rs there without its inner doc
// comments and inner attributes, which an `include!`d file may not have. They live here.

// parry's crate documentation, taken from the `/*! ... */` block of its (patched) lib.rs.
#![doc = include_str!(concat!(env!("OUT_DIR"), "/parry3d-0.31.1/crate-doc.md"))]
// BEGIN parry3d crate attributes: exactly the inner attributes of parry's (patched) lib.rs,
// in order. build.rs checks this block against them and stops the build if they differ.
#![deny(non_camel_case_types)]
#![deny(unused_parens)]
#![deny(non_upper_case_globals)]
#![deny(unused_results)]
#![deny(unused_qualifications)]
#![warn(missing_docs)]
#![warn(unused_imports)]
#![allow(missing_copy_implementations)]
#![allow(clippy::too_many_arguments)] // Maybe revisit this one later.
#![allow(clippy::module_inception)]
#![allow(clippy::manual_range_contains)] // This usually makes it way more verbose that it could be.
#![allow(clippy::type_complexity)] // Complains about closures that are fairly simple.
#![cfg_attr(feature = "dim2", doc(html_root_url = "https://docs.rs/parry2d"))]
#![cfg_attr(feature = "dim3", doc(html_root_url = "https://docs.rs/parry3d"))]
#![no_std]
// END parry3d crate attributes
// Ours: parry's code is not ours to lint. cargo caps the lints of a crates.io dependency
// (`--cap-lints allow`) but not of a path dependency like this one, so silence its warnings
// here, as if it still came from the registry. Errors (such as the `deny`s above) remain.
#![allow(warnings)]

include!(concat!(env!("OUT_DIR"), "/parry3d-0.31.1/src/lib.rs"));
