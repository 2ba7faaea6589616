//! Helpers shared by the tests that write mesh files (`mesh_objects.rs`, `visual_meshes.rs`):
//! a fresh scratch directory and the OBJ lines of a box.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A fresh scratch directory `TEST-NAME` under the target directory.
pub fn scratch(test: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{test}-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// OBJ lines of a closed box from `lo` to `hi`, its vertices numbered from `first` (1-based).
pub fn box_obj(out: &mut String, lo: [f64; 3], hi: [f64; 3], first: usize) {
    for k in 0..8 {
        let c = |axis: usize| {
            if k >> axis & 1 == 1 {
                hi[axis]
            } else {
                lo[axis]
            }
        };
        writeln!(out, "v {} {} {}", c(0), c(1), c(2)).unwrap();
    }
    // Two triangles per face, outward (corner k has bit 0 = x, bit 1 = y, bit 2 = z).
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for [a, b, c, d] in faces {
        let [a, b, c, d] = [a, b, c, d].map(|i| i + first);
        writeln!(out, "f {a} {b} {c}\nf {a} {c} {d}").unwrap();
    }
}
