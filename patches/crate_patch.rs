//! The build script of our stand-ins for crates.io packages (`patches/rapier3d`,
//! `patches/parry3d`): it turns a pristine published crate plus our patch into the source tree
//! the stand-in compiles. Each stand-in's `build.rs` includes this file as a module
//! (`#[path = "../crate_patch.rs"]`) and calls [`build`] with the crate's name, version and
//! sha256; below, `NAME-VERSION` stands for those (for example `parry3d-0.31.1`).
//!
//! Over 600 lines: one linear procedure (find, verify, extract, patch, generate) with its
//! documentation; a build script is a single crate root, and scattering it over modules would
//! only make it harder to read.
//!
//! # Why
//!
//! We carry changes to rapier3d 0.36.1 and parry3d 0.31.1. The repository holds no copy of
//! their source, only a patch file each; the root `Cargo.toml` points `[patch.crates-io]` at
//! the stand-in packages, and this script rebuilds each patched crate at build time. Nothing is
//! needed beyond a normal `cargo build`, `cargo test`, `pip install .` or `pip wheel .`, even
//! on a fresh clone.
//!
//! # What it does, each time it runs
//!
//! 1. **Finds the pristine `NAME-VERSION.crate`** (the gzipped tarball crates.io serves) and
//!    checks its sha256 against the pinned one (the checksum crates.io publishes, as recorded
//!    in Cargo.lock before the patch). A file with another checksum is never used. In order:
//!    - the file named by the environment variable `PANDA_RAPIER_<NAME>_CRATE` (the name in
//!      upper case, e.g. `PANDA_RAPIER_PARRY3D_CRATE`), if set (an escape hatch for machines
//!      without network or registry cache; a wrong file is an error);
//!    - cargo's download cache, `$CARGO_HOME/registry/cache/*/NAME-VERSION.crate`
//!      (`CARGO_HOME` is set by rustup for everything it runs; else `$HOME/.cargo`), whatever
//!      registry or mirror it came from;
//!    - an earlier download of this script, `$OUT_DIR/download/NAME-VERSION.crate`;
//!    - otherwise it asks cargo to download it: it writes a throwaway manifest depending on
//!      `NAME = "=VERSION"` into `$OUT_DIR/fetch/` (with its own `[workspace]`) and runs
//!      `$CARGO fetch --manifest-path ... --target $TARGET` (`--offline` when
//!      `CARGO_NET_OFFLINE` is true), which honours the user's registry, mirror, proxy and
//!      offline configuration and fills the cache above, then looks there again. The outer
//!      cargo does not hold the package-cache lock while build scripts run (tested with cargo
//!      1.95 on an empty `CARGO_HOME`), so this does not deadlock; a watchdog still kills it
//!      after [`FETCH_TIMEOUT`];
//!    - last, `curl` downloads it from crates.io's static address into `$OUT_DIR/download/`.
//!
//!    If all of that fails the build stops with a message listing what was tried.
//! 2. **Extracts** it into `$OUT_DIR/NAME-VERSION/` (deleting an earlier extraction first).
//! 3. **Applies `NAME-VERSION.patch`** (next to the stand-in's `build.rs`): a unified diff as
//!    written by `git diff` in a git repository whose root is the pristine crate (paths
//!    `a/src/...`, `b/src/...`; the first path component is stripped, like `patch -p1`),
//!    preceded by a free-text header: everything before the first `diff --git` line (or the
//!    first `--- ` line followed by a `+++ ` line, for a plain `diff -u`) is the header and
//!    ignored. A patch that is only a header changes nothing. Every file is parsed and applied
//!    with `diffy` (modified, created `--- /dev/null`, deleted `+++ /dev/null`, renamed and
//!    copied files); a hunk whose context and removed lines are not in the pristine file fails
//!    the build, naming the file and the hunk. Binary diffs are refused. Only `src/` is
//!    compiled: the stand-in's `Cargo.toml` replaces the crate's, so dependency changes go
//!    there, not into the patch.
//! 4. **Generates the crate root.** `src/lib.rs` is `include!`d by the stand-in's own
//!    `src/lib.rs`, and an `include!`d file may not contain inner attributes or inner doc
//!    comments. So the leading inner docs of the patched `src/lib.rs` (`//!` lines, or one
//!    `/*! ... */` block) go to `$OUT_DIR/NAME-VERSION/crate-doc.md` (the stand-in's
//!    `src/lib.rs` uses it as the crate docs), and its leading `#![...]` attributes are
//!    removed; each removed line is blanked, so line numbers in compiler messages stay right.
//!    Inner attributes can only appear there, at the top of the file, so nothing else needs
//!    moving; `mod foo;` declarations in the generated file resolve next to it, in
//!    `$OUT_DIR/NAME-VERSION/src/`. The removed attributes must be exactly the ones listed
//!    between the `// BEGIN NAME crate attributes` / `// END NAME crate attributes` marker
//!    comments of the stand-in's `src/lib.rs`, which declares them for the crate; if a patch
//!    changes them, the build stops and says what to update.
//!
//! It reruns when this file, the stand-in's `build.rs`, the patch, its `src/lib.rs` or
//! `PANDA_RAPIER_<NAME>_CRATE` changes. See `patches/README.md` for how to write or regenerate
//! a patch.

use std::env;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::fs;
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use diffy::patch_set::{FileOperation, ParseOptions, PatchKind, PatchSet};
use sha2::{Digest, Sha256};

/// A published crate we patch, as the stand-in's `build.rs` pins it.
pub struct Pinned {
    /// The package's name on crates.io, e.g. `parry3d`; the stand-in's directory under
    /// `patches/` has the same name.
    pub name: &'static str,
    /// The published version we patch; must match `version` in the stand-in's Cargo.toml.
    pub version: &'static str,
    /// sha256 of `NAME-VERSION.crate` as published on crates.io (its Cargo.lock checksum).
    pub sha256: &'static str,
    /// Features the throwaway manifest of the `cargo fetch` fallback asks for (with default
    /// features off): enough for the crate to resolve, nothing is compiled.
    pub fetch_features: &'static [&'static str],
}

/// How long the nested `cargo fetch` may take before it is killed.
const FETCH_TIMEOUT: Duration = Duration::from_secs(15 * 60);
/// The stand-in's crate root, relative to its package directory.
const OUR_LIB_RS: &str = "src/lib.rs";

/// Everything the steps need to know about the crate, derived once from [`Pinned`].
struct Spec {
    name: String,
    version: String,
    sha256: &'static str,
    fetch_features: &'static [&'static str],
    /// `NAME-VERSION.crate`, the file's name in cargo's download cache.
    crate_file: String,
    /// `NAME-VERSION`: the tarball's single top-level directory and the extraction directory.
    top_dir: String,
    /// `NAME-VERSION.patch`, next to the stand-in's build.rs.
    patch_file: String,
    /// `PANDA_RAPIER_<NAME>_CRATE`: names a `.crate` file to use instead of looking for one.
    crate_env: String,
    /// crates.io's download address for the file, used by the `curl` fallback.
    url: String,
    /// Marker comments around the crate attributes in the stand-in's `src/lib.rs`.
    attrs_begin: String,
    attrs_end: String,
}

/// Runs the four steps of the module docs for `pinned`; called from the stand-in's `main`.
pub fn build(pinned: &Pinned) {
    let Pinned {
        name,
        version,
        sha256,
        fetch_features,
    } = *pinned;
    let top_dir = format!("{name}-{version}");
    let s = Spec {
        name: name.to_owned(),
        version: version.to_owned(),
        sha256,
        fetch_features,
        crate_file: format!("{top_dir}.crate"),
        patch_file: format!("{top_dir}.patch"),
        crate_env: format!("PANDA_RAPIER_{}_CRATE", name.to_uppercase()),
        url: format!("https://static.crates.io/crates/{name}/{top_dir}.crate"),
        attrs_begin: format!("// BEGIN {name} crate attributes"),
        attrs_end: format!("// END {name} crate attributes"),
        top_dir,
    };

    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=../crate_patch.rs");
    println!("cargo::rerun-if-changed={}", s.patch_file);
    println!("cargo::rerun-if-changed={OUR_LIB_RS}");
    println!("cargo::rerun-if-env-changed={}", s.crate_env);

    let manifest_dir = PathBuf::from(required_env("CARGO_MANIFEST_DIR"));
    let out_dir = PathBuf::from(required_env("OUT_DIR"));

    let tarball = pristine_crate(&s, &manifest_dir, &out_dir);
    let root = out_dir.join(&s.top_dir);
    extract(&s, &tarball, &out_dir, &root);
    apply_patch(&s, &manifest_dir.join(&s.patch_file), &root);
    generate_crate_root(&s, &root, &manifest_dir.join(OUR_LIB_RS));
}

fn required_env(name: &str) -> OsString {
    env::var_os(name).unwrap_or_else(|| panic!("cargo did not set {name} for the build script"))
}

// ---------------------------------------------------------------------------------------------
// 1. The pristine crate
// ---------------------------------------------------------------------------------------------

/// The verified bytes of the pristine `.crate` file, found or downloaded as the module docs say.
fn pristine_crate(s: &Spec, manifest_dir: &Path, out_dir: &Path) -> Vec<u8> {
    let Spec { name, version, sha256, crate_file, crate_env, url, .. } = s;
    if let Some(path) = env::var_os(crate_env).filter(|p| !p.is_empty()) {
        let path = PathBuf::from(path);
        return read_verified(s, &path).unwrap_or_else(|e| {
            panic!(
                "{crate_env} names {}, which cannot be used: {e}",
                path.display()
            )
        });
    }

    let mut tried = Vec::new();
    let cache = cargo_home().map(|home| home.join("registry").join("cache"));
    if let Some(bytes) = from_registry_cache(s, cache.as_deref(), &mut tried) {
        return bytes;
    }
    let downloaded = out_dir.join("download").join(crate_file);
    if downloaded.is_file() {
        match read_verified(s, &downloaded) {
            Ok(bytes) => return bytes,
            Err(e) => tried.push(format!("an earlier download: {e}")),
        }
    }

    match cargo_fetch(s, manifest_dir, out_dir) {
        Ok(()) => {
            if let Some(bytes) = from_registry_cache(s, cache.as_deref(), &mut tried) {
                return bytes;
            }
            tried.push(format!(
                "`cargo fetch` succeeded, but left no {crate_file} in cargo's download cache \
                 (a vendored or local-registry source replacement keeps none)"
            ));
        }
        Err(e) => tried.push(format!("`cargo fetch` of {name} {version}: {e}")),
    }

    match curl(s, &downloaded).and_then(|()| read_verified(s, &downloaded)) {
        Ok(bytes) => return bytes,
        Err(e) => tried.push(format!("`curl` from {url}: {e}")),
    }

    panic!(
        "cannot get the pristine {crate_file} (sha256 {sha256}), which patches/{name} builds \
         our patched {name} from.\nTried:\n  - {}\nFix: let cargo reach its registry (check \
         network, proxy and registry configuration, or drop --offline once), or download the \
         file yourself from {url} and set {crate_env} to its path.",
        tried.join("\n  - ")
    );
}

/// Cargo's home: `$CARGO_HOME` (rustup sets it for the tools it runs), else `~/.cargo`.
fn cargo_home() -> Option<PathBuf> {
    if let Some(home) = env::var_os("CARGO_HOME").filter(|h| !h.is_empty()) {
        return Some(PathBuf::from(home));
    }
    ["HOME", "USERPROFILE"]
        .iter()
        .filter_map(env::var_os)
        .find(|h| !h.is_empty())
        .map(|h| PathBuf::from(h).join(".cargo"))
}

/// The first verified `registry/cache/*/<name>-<version>.crate`, in name order.
fn from_registry_cache(
    s: &Spec,
    cache: Option<&Path>,
    tried: &mut Vec<String>,
) -> Option<Vec<u8>> {
    let crate_file = &s.crate_file;
    let Some(cache) = cache else {
        tried.push("cargo's download cache: neither CARGO_HOME nor HOME is set".to_owned());
        return None;
    };
    let mut candidates: Vec<PathBuf> = match fs::read_dir(cache) {
        Ok(dirs) => dirs
            .filter_map(Result::ok)
            .map(|dir| dir.path().join(crate_file))
            .filter(|file| file.is_file())
            .collect(),
        Err(_) => Vec::new(),
    };
    candidates.sort();
    if candidates.is_empty() {
        tried.push(format!(
            "cargo's download cache: no {}/*/{crate_file}",
            cache.display()
        ));
    }
    for file in candidates {
        match read_verified(s, &file) {
            Ok(bytes) => return Some(bytes),
            Err(e) => {
                println!("cargo::warning=skipping {}: {e}", file.display());
                tried.push(e);
            }
        }
    }
    None
}

/// The file's bytes if their sha256 is the pinned one.
fn read_verified(s: &Spec, path: &Path) -> Result<Vec<u8>, String> {
    let sha256 = s.sha256;
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let digest = Sha256::digest(&bytes);
    let hex = digest.iter().fold(String::new(), |mut hex, byte| {
        let _ = write!(hex, "{byte:02x}");
        hex
    });
    if hex == sha256 {
        Ok(bytes)
    } else {
        Err(format!(
            "{} has sha256 {hex}, expected {sha256}",
            path.display()
        ))
    }
}

/// Runs `$CARGO fetch` on a throwaway manifest that depends on exactly the pinned version.
fn cargo_fetch(s: &Spec, manifest_dir: &Path, out_dir: &Path) -> Result<(), String> {
    let Spec { name, version, fetch_features, .. } = s;
    let features = fetch_features
        .iter()
        .map(|f| format!("\"{f}\""))
        .collect::<Vec<_>>()
        .join(", ");
    let dir = out_dir.join("fetch");
    let io_err = |e: io::Error| format!("cannot prepare {}: {e}", dir.display());
    fs::create_dir_all(dir.join("src")).map_err(io_err)?;
    fs::write(dir.join("src").join("lib.rs"), "").map_err(io_err)?;
    let manifest = dir.join("Cargo.toml");
    fs::write(
        &manifest,
        format!(
            "# Written by panda_rapier's patches/{name}/build.rs, only to make cargo download\n\
             # the pristine {name} {version} into its cache.\n\
             [package]\nname = \"fetch-pristine-{name}\"\nversion = \"0.0.0\"\n\
             edition = \"2021\"\npublish = false\n\n\
             [dependencies]\n{name} = {{ version = \"={version}\", default-features = false, \
             features = [{features}] }}\n\n\
             # Not part of any enclosing workspace (OUT_DIR lies inside ours).\n[workspace]\n"
        ),
    )
    .map_err(io_err)?;
    let log_path = dir.join("fetch.log");
    let log = fs::File::create(&log_path).map_err(io_err)?;
    let log_err = log.try_clone().map_err(io_err)?;

    let cargo = env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut command = Command::new(&cargo);
    command
        .arg("fetch")
        .arg("--manifest-path")
        .arg(&manifest)
        // The working directory decides which `.cargo/config.toml` files apply: the project's.
        .current_dir(manifest_dir)
        // Keep the nested cargo's own files (lock file, rustc info) away from the outer build.
        .env("CARGO_TARGET_DIR", dir.join("target"))
        // A fetch compiles nothing: it needs no share of the outer build's jobserver.
        .env_remove("CARGO_MAKEFLAGS")
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(log_err);
    if let Some(target) = env::var_os("TARGET") {
        command.arg("--target").arg(target);
    }
    let offline =
        env::var("CARGO_NET_OFFLINE").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"));
    if offline {
        command.arg("--offline");
    }

    let mut child = command
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", cargo.to_string_lossy()))?;
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if started.elapsed() > FETCH_TIMEOUT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "timed out after {} s; its output:\n{}",
                    FETCH_TIMEOUT.as_secs(),
                    log_tail(&log_path)
                ));
            }
            Ok(None) => thread::sleep(Duration::from_millis(100)),
            Err(e) => return Err(format!("cannot wait for cargo: {e}")),
        }
    };
    if status.success() {
        Ok(())
    } else {
        Err(format!("{status}; its output:\n{}", log_tail(&log_path)))
    }
}

/// The last lines of a log file, indented, for error messages.
fn log_tail(path: &Path) -> String {
    let text = fs::read_to_string(path).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    let start = lines.len().saturating_sub(20);
    lines[start..]
        .iter()
        .map(|line| format!("      {line}"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Downloads the crate from crates.io to `dest` with the `curl` command.
fn curl(s: &Spec, dest: &Path) -> Result<(), String> {
    let dir = dest.parent().expect("the download path has a directory");
    fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let partial = dest.with_extension("crate.part");
    let output = Command::new("curl")
        .args(["--fail", "--location", "--silent", "--show-error"])
        .args(["--retry", "3", "--connect-timeout", "30", "--output"])
        .arg(&partial)
        .arg(&s.url)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run curl: {e}"))?;
    if !output.status.success() {
        let _ = fs::remove_file(&partial);
        return Err(format!(
            "curl {}: {}",
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    fs::rename(&partial, dest).map_err(|e| format!("cannot move the download: {e}"))
}

// ---------------------------------------------------------------------------------------------
// 2. Extraction
// ---------------------------------------------------------------------------------------------

/// Unpacks the gzipped tarball into `out_dir`; all of it lies under `root`
/// (`out_dir/<name>-<version>`).
fn extract(s: &Spec, tarball: &[u8], out_dir: &Path, root: &Path) {
    let Spec { crate_file, top_dir, .. } = s;
    if root.exists() {
        fs::remove_dir_all(root)
            .unwrap_or_else(|e| panic!("cannot delete the old {}: {e}", root.display()));
    }
    let mut archive = tar::Archive::new(flate2::read::GzDecoder::new(tarball));
    let entries = archive
        .entries()
        .unwrap_or_else(|e| panic!("{crate_file} is not a gzipped tarball: {e}"));
    for entry in entries {
        let mut entry = entry.unwrap_or_else(|e| panic!("cannot read {crate_file}: {e}"));
        let path = entry
            .path()
            .unwrap_or_else(|e| panic!("{crate_file} holds an unreadable path: {e}"))
            .into_owned();
        assert!(
            path.components().next() == Some(Component::Normal(top_dir.as_str().as_ref())),
            "{crate_file} holds {}, outside {top_dir}/",
            path.display()
        );
        let unpacked = entry
            .unpack_in(out_dir)
            .unwrap_or_else(|e| panic!("cannot extract {}: {e}", path.display()));
        assert!(
            unpacked,
            "{crate_file} holds an unsafe path, {}",
            path.display()
        );
    }
    assert!(
        root.join("src").join("lib.rs").is_file(),
        "{crate_file} has no {top_dir}/src/lib.rs"
    );
}

// ---------------------------------------------------------------------------------------------
// 3. The patch
// ---------------------------------------------------------------------------------------------

/// Applies the patch at `patch_path` to the tree at `root`, as the module docs describe.
fn apply_patch(s: &Spec, patch_path: &Path, root: &Path) {
    let Spec { name: crate_name, version, .. } = s;
    let name = patch_path.display();
    let mut text = String::new();
    fs::File::open(patch_path)
        .and_then(|mut f| f.read_to_string(&mut text))
        .unwrap_or_else(|e| panic!("cannot read {name} (it must be UTF-8 text): {e}"));

    let Some(start) = diff_start(&text) else {
        // Only a header: nothing to change. A stray hunk would be silently lost, so refuse it.
        if let Some(line) = text.lines().position(|l| l.starts_with("@@ ")) {
            panic!(
                "{name}:{}: a hunk (`@@ ... @@`) before any `diff --git` or `--- `/`+++ ` file \
                 header; the patch is malformed",
                line + 1
            );
        }
        return;
    };
    let first_line = text[..start].lines().count() + 1;
    let body = &text[start..];
    let options = if body.starts_with("diff --git ") {
        ParseOptions::gitdiff()
    } else {
        ParseOptions::unidiff()
    };

    for file in PatchSet::parse(body, options) {
        let file = file.unwrap_or_else(|e| {
            panic!("cannot parse {name} ({e}; byte offsets count from line {first_line})")
        });
        let operation = file.operation().strip_prefix(1);
        let changed = match &operation {
            FileOperation::Modify { modified: path, .. }
            | FileOperation::Rename { to: path, .. }
            | FileOperation::Copy { to: path, .. }
            | FileOperation::Create(path)
            | FileOperation::Delete(path) => path,
        };
        if !changed.starts_with("src/") {
            println!(
                "cargo::warning=the {crate_name} patch changes `{changed}`, which is not compiled: \
                 only src/ is, and patches/{crate_name}/Cargo.toml replaces its manifest"
            );
        }
        let patch = match file.patch() {
            PatchKind::Text(patch) => patch,
            PatchKind::Binary(_) => panic!(
                "{name}: binary diff for {operation:?} is not supported; patch only text files"
            ),
        };
        let apply = |path: &str, base: &str| {
            diffy::apply(base, patch).unwrap_or_else(|e| {
                panic!(
                    "{name} does not apply to the pristine {crate_name} {version}: {} of `{path}` \
                     is not found in that file (its context and removed lines must match it \
                     exactly).\nRegenerate the patch against the pristine crate, as \
                     patches/README.md describes.",
                    describe_hunk(&e, patch),
                )
            })
        };
        match operation {
            FileOperation::Modify { original, modified } => {
                let result = apply(&original, &read_source(root, &original));
                write_source(root, &modified, &result);
                if original != modified {
                    remove_source(root, &original);
                }
            }
            FileOperation::Rename { from, to } => {
                let result = apply(&from, &read_source(root, &from));
                write_source(root, &to, &result);
                remove_source(root, &from);
            }
            FileOperation::Copy { from, to } => {
                let result = apply(&from, &read_source(root, &from));
                write_source(root, &to, &result);
            }
            FileOperation::Create(path) => {
                let target = source_path(root, &path);
                assert!(
                    !target.exists(),
                    "{name} creates `{path}`, which the pristine crate already has"
                );
                write_source(root, &path, &apply(&path, ""));
            }
            FileOperation::Delete(path) => {
                let result = apply(&path, &read_source(root, &path));
                assert!(
                    result.is_empty(),
                    "{name} deletes `{path}` but does not remove all of its lines"
                );
                remove_source(root, &path);
            }
        }
    }
}

/// Byte offset of the first file header: a `diff --git` line, or a `--- ` line directly
/// followed by a `+++ ` line. Everything before it is the patch's free-text header.
fn diff_start(text: &str) -> Option<usize> {
    let mut offset = 0;
    let mut lines = text.split_inclusive('\n').peekable();
    while let Some(line) = lines.next() {
        if line.starts_with("diff --git ")
            || (line.starts_with("--- ") && lines.peek().is_some_and(|l| l.starts_with("+++ ")))
        {
            return Some(offset);
        }
        offset += line.len();
    }
    None
}

/// "hunk #N (@@ -a,b +c,d @@)" from diffy's "error applying hunk #N".
fn describe_hunk(error: &diffy::ApplyError, patch: &diffy::Patch<'_, str>) -> String {
    let message = error.to_string();
    let hunk = message
        .rsplit('#')
        .next()
        .and_then(|n| n.trim().parse::<usize>().ok())
        .and_then(|n| Some((n, patch.hunks().get(n.checked_sub(1)?)?)));
    match hunk {
        Some((n, hunk)) => {
            let (old, new) = (hunk.old_range(), hunk.new_range());
            format!(
                "hunk #{n} (@@ -{},{} +{},{} @@)",
                old.start(),
                old.len(),
                new.start(),
                new.len()
            )
        }
        None => message,
    }
}

/// `root/path` for a path from the patch, refusing absolute paths and `..`.
fn source_path(root: &Path, path: &str) -> PathBuf {
    let relative = Path::new(path);
    let safe = !path.is_empty()
        && relative
            .components()
            .all(|c| matches!(c, Component::Normal(_)));
    assert!(
        safe,
        "the patch names `{path}`, which is not a path inside the crate"
    );
    root.join(relative)
}

fn read_source(root: &Path, path: &str) -> String {
    let file = source_path(root, path);
    fs::read_to_string(&file).unwrap_or_else(|e| {
        panic!("the patch changes `{path}`, which the pristine crate does not have as text: {e}")
    })
}

fn write_source(root: &Path, path: &str, contents: &str) {
    let file = source_path(root, path);
    if let Some(dir) = file.parent() {
        fs::create_dir_all(dir).unwrap_or_else(|e| panic!("cannot create {}: {e}", dir.display()));
    }
    fs::write(&file, contents).unwrap_or_else(|e| panic!("cannot write {}: {e}", file.display()));
}

fn remove_source(root: &Path, path: &str) {
    let file = source_path(root, path);
    fs::remove_file(&file).unwrap_or_else(|e| panic!("cannot delete {}: {e}", file.display()));
}

// ---------------------------------------------------------------------------------------------
// 4. The crate root
// ---------------------------------------------------------------------------------------------

/// Moves the leading inner doc comments (`//!` lines or a `/*! ... */` block) and inner
/// attributes out of `root/src/lib.rs` (see the module docs) and checks the attributes against
/// those our `src/lib.rs` declares.
fn generate_crate_root(s: &Spec, root: &Path, our_lib_rs: &Path) {
    let lib_rs = root.join("src").join("lib.rs");
    let source = fs::read_to_string(&lib_rs)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", lib_rs.display()));
    let lines: Vec<&str> = source.split_inclusive('\n').collect();

    let mut docs = Vec::new();
    let mut attributes = Vec::new();
    let mut generated = String::with_capacity(source.len());
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i].trim();
        if let Some(doc) = line.strip_prefix("//!") {
            docs.push(doc.to_owned());
            generated.push('\n');
            i += 1;
        } else if let Some(first) = line.strip_prefix("/*!") {
            // A block of inner docs: its lines are the doc text as written (given the `//! `
            // lines' conventional space, dropped below). Nested block comments are refused.
            let mut text = first;
            loop {
                assert!(
                    !text.contains("/*"),
                    "{}:{}: nested block comment in the crate's inner docs",
                    lib_rs.display(),
                    i + 1
                );
                generated.push('\n');
                i += 1;
                if let Some((last, _)) = text.split_once("*/") {
                    if !last.trim().is_empty() {
                        docs.push(format!(" {}", last.trim_end()));
                    }
                    break;
                }
                docs.push(format!(" {}", text.trim_end()));
                assert!(
                    i < lines.len(),
                    "{}: unterminated `/*!` block",
                    lib_rs.display()
                );
                text = lines[i].trim_end_matches(['\n', '\r']);
            }
        } else if line.is_empty() || (line.starts_with("//") && !line.starts_with("///")) {
            generated.push_str(lines[i]);
            i += 1;
        } else if line.starts_with("#![") {
            let (attribute, end) = inner_attribute(&lines, i)
                .unwrap_or_else(|| panic!("{}:{}: unterminated `#![`", lib_rs.display(), i + 1));
            attributes.push(attribute);
            for _ in i..end {
                generated.push('\n');
            }
            i = end;
        } else if line.starts_with("/*") {
            panic!(
                "{}:{}: block comments (other than one `/*! ... */` of crate docs) before the \
                 first item of {}'s lib.rs are not supported by patches/crate_patch.rs; use \
                 line comments",
                lib_rs.display(),
                i + 1,
                s.name
            );
        } else {
            break;
        }
    }
    for line in &lines[i..] {
        generated.push_str(line);
    }

    check_declared_attributes(s, &attributes, our_lib_rs);

    // `//! text` is the doc line " text": drop that one conventional space.
    let unindent = docs.iter().all(|d| d.is_empty() || d.starts_with(' '));
    let mut doc = String::new();
    for line in docs {
        doc.push_str(if unindent {
            line.strip_prefix(' ').unwrap_or(&line)
        } else {
            &line
        });
        doc.push('\n');
    }
    let doc_path = root.join("crate-doc.md");
    fs::write(&doc_path, doc)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", doc_path.display()));
    fs::write(&lib_rs, generated)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", lib_rs.display()));
}

/// The inner attribute starting at `lines[start]` (without any comment after it), and the index
/// of the line after it; brackets inside string literals are skipped.
fn inner_attribute(lines: &[&str], start: usize) -> Option<(String, usize)> {
    let mut attribute = String::new();
    let mut depth = 0usize;
    let mut in_string = false;
    let mut escaped = false;
    for (index, line) in lines.iter().enumerate().skip(start) {
        for c in line.trim_start().chars() {
            attribute.push(c);
            if in_string {
                match c {
                    _ if escaped => escaped = false,
                    '\\' => escaped = true,
                    '"' => in_string = false,
                    _ => {}
                }
                continue;
            }
            match c {
                '"' => in_string = true,
                '[' => depth += 1,
                ']' => {
                    depth = depth.checked_sub(1)?;
                    if depth == 0 {
                        return Some((attribute, index + 1));
                    }
                }
                _ => {}
            }
        }
    }
    None
}

/// Panics unless `attributes` are exactly the ones between the markers in our `src/lib.rs`
/// (compared without whitespace, in order).
fn check_declared_attributes(s: &Spec, attributes: &[String], our_lib_rs: &Path) {
    let Spec { name, attrs_begin, attrs_end, .. } = s;
    let ours = fs::read_to_string(our_lib_rs)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", our_lib_rs.display()));
    let declared: Option<Vec<String>> = ours
        .split_once(attrs_begin)
        .and_then(|(_, rest)| rest.split_once(attrs_end))
        .map(|(block, _)| {
            let lines: Vec<&str> = block.split_inclusive('\n').collect();
            let mut found = Vec::new();
            let mut i = 0;
            while i < lines.len() {
                if lines[i].trim_start().starts_with("#![") {
                    match inner_attribute(&lines, i) {
                        Some((attribute, end)) => {
                            found.push(attribute);
                            i = end;
                        }
                        None => break,
                    }
                } else {
                    i += 1;
                }
            }
            found
        });
    let Some(declared) = declared else {
        panic!(
            "{} lacks the `{attrs_begin}` ... `{attrs_end}` block that build.rs checks",
            our_lib_rs.display()
        );
    };
    let squash = |s: &String| s.split_whitespace().collect::<String>();
    let expected: Vec<String> = attributes.iter().map(squash).collect();
    assert!(
        declared.iter().map(squash).collect::<Vec<_>>() == expected,
        "the crate attributes of {name}'s (patched) src/lib.rs changed; the generated file \
         drops them, so {} must declare exactly these between its `{attrs_begin}` and \
         `{attrs_end}` lines:\n{}",
        our_lib_rs.display(),
        attributes.join("\n")
    );
}
