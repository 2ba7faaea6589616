//! Build script of our stand-in for the crates.io package `rapier3d` 0.36.1: it turns the
//! pristine published crate plus our patch (`rapier3d-0.36.1.patch`) into the source tree this
//! package compiles. The procedure, shared with `patches/parry3d`, is `../crate_patch.rs`; its
//! module docs describe every step.

#[path = "../crate_patch.rs"]
mod crate_patch;

fn main() {
    crate_patch::build(&crate_patch::Pinned {
        name: "rapier3d",
        version: "0.36.1",
        // The checksum crates.io publishes (Cargo.lock's, before the patch).
        sha256: "033e2edc815d61ab97bd74ed5d1cbea5ebe575218774a7cfedbd3551f0033317",
        fetch_features: &["dim3", "f32"],
    });
}
