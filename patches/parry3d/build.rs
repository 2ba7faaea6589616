//! Build script of our stand-in for the crates.io package `parry3d` 0.31.1: it turns the
//! pristine published crate plus our patch (`parry3d-0.31.1.patch`) into the source tree this
//! package compiles. The procedure, shared with `patches/rapier3d`, is `../crate_patch.rs`; its
//! module docs describe every step.

#[path = "../crate_patch.rs"]
mod crate_patch;

fn main() {
    crate_patch::build(&crate_patch::Pinned {
        name: "parry3d",
        version: "0.31.1",
        // The checksum crates.io publishes (Cargo.lock's, before the patch).
        sha256: "7b626edc0b497dba4bdf6e1e0797895294ed9f61dac2bd28cb5d34d37ad2ca7e",
        fetch_features: &["required-features"],
    });
}
