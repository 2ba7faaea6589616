//! Objects from mesh files ([`MeshFile`]): an OBJ, STL or COLLADA (DAE) file becomes the
//! convex parts an object collides with, as an [`ObjectShape`] (a `ConvexHull`, or a
//! `Compound` of them). Non-convex meshes are decomposed with parry's V-HACD once per file and
//! settings and cached on disk ([`ShapeCache`]), keyed by the file's bytes and the settings, so
//! a vector env of many copies (and the next run) pays once. Files that already are a set of
//! convex hulls (PyBullet's `_vhacd` files: one `o` block per hull) are taken as they are.
//!
//! Over 600 lines because it holds one pipeline (read, parse, decompose or take the hulls,
//! cache, and the visual mesh of the same file), whose steps share the file and its errors;
//! the disk cache and its key are the part to move out first if it grows.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};

use rapier3d::parry::transformation::vhacd::{VHACDParameters, VHACD};
use rapier3d::parry::transformation::voxelization::FillMode;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::convert::vec_from_array;
use super::shape::{ObjectShape, ShapePart};
use super::visuals::{
    color_from_fractions, ObjectVisual, SharedMesh, TriangleMesh, VisualPart, VisualShape,
};
use crate::error::{Error, Result};

/// How a mesh file's triangles become the convex parts an object collides with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MeshCollision {
    /// Each part of the file is one convex hull: an OBJ's `o` or `g` blocks (or material
    /// changes), a COLLADA file's meshes; for files that already are a convex decomposition
    /// (PyBullet's `_vhacd` files). Parts whose points span no volume are dropped.
    Parts,
    /// One convex hull of all the file's vertices.
    Hull,
    /// A convex decomposition of the whole mesh by parry's V-HACD.
    Decompose(Decomposition),
}

/// Settings of the convex decomposition ([`MeshCollision::Decompose`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decomposition {
    /// Voxels along the mesh's longest side (V-HACD's `resolution`); memory grows with its
    /// cube. Default 64.
    pub resolution: u32,
    /// The largest concavity a part may keep, relative to the mesh's size (V-HACD's
    /// `concavity`). Default 0.0025 (parry's docs advise 0.001-0.005 for robotics).
    pub concavity: f64,
    /// The most parts. Default 16 (parry's docs advise 8-32 for dynamic bodies). parry
    /// 0.31.1's V-HACD does not read its own `max_convex_hulls`, so the parts it makes are
    /// merged here afterwards, as V-HACD's original does: repeatedly the two whose merged hull
    /// adds the least volume to theirs.
    pub max_parts: u32,
}

impl Default for Decomposition {
    fn default() -> Self {
        Self {
            resolution: 64,
            concavity: 0.0025,
            max_parts: 16,
        }
    }
}

/// A mesh file to build an object's collision shape from.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFile {
    /// The file: `.obj`, `.stl` or `.dae` (the format is read from the extension). An OBJ's
    /// material library is not needed (a missing one is ignored).
    pub path: PathBuf,
    /// Scale along x, y and z applied to the file's coordinates (which are taken as metres).
    pub scale: [f64; 3],
    /// How the triangles become convex parts.
    pub collision: MeshCollision,
}

impl MeshFile {
    /// The file at its own scale, decomposed with the default [`Decomposition`].
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            scale: [1.0; 3],
            collision: MeshCollision::Decompose(Decomposition::default()),
        }
    }

    /// The collision source of the mesh at `path` by the shipped object set's convention
    /// (`assets/objects`): the convex parts of `STEM_collision.obj` beside it where that file
    /// exists ([`MeshCollision::Parts`], as PyBullet ships `_vhacd` files), else the mesh
    /// itself decomposed with the default [`Decomposition`].
    pub fn with_parts_beside(path: impl Into<PathBuf>) -> Self {
        let path = path.into();
        let parts = path.file_stem().map(|stem| {
            let mut name = stem.to_os_string();
            name.push("_collision.obj");
            path.with_file_name(name)
        });
        match parts {
            Some(parts) if parts.is_file() => Self {
                collision: MeshCollision::Parts,
                ..Self::new(parts)
            },
            _ => Self::new(path),
        }
    }

    /// The collision shape: one [`ObjectShape::ConvexHull`], or a [`ObjectShape::Compound`] of
    /// them at the identity pose, in the file's (scaled) frame. `field` names this file in
    /// error messages (e.g. `scene.objects[2].mesh`). Decompositions are looked up in and
    /// written to `cache`.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for a bad scale or decomposition setting;
    /// [`Error::BadMesh`] when the file is missing or unreadable, of an unknown format,
    /// malformed, empty (no triangles), has non-finite coordinates, or yields no part with a
    /// volume.
    pub fn load(&self, field: &str, cache: &ShapeCache) -> Result<ObjectShape> {
        Ok(self.load_report(field, cache)?.shape)
    }

    /// [`MeshFile::load`], saying also whether the decomposition came from the cache.
    pub fn load_report(&self, field: &str, cache: &ShapeCache) -> Result<LoadedMesh> {
        self.validate(field)?;
        let bytes = self.read(field)?;
        self.load_bytes(&bytes, field, cache)
    }

    /// The file's bytes.
    ///
    /// # Errors
    /// [`Error::BadMesh`] naming `field` and the path when the file is missing or unreadable.
    pub fn read(&self, field: &str) -> Result<Vec<u8>> {
        fs::read(&self.path).map_err(|e| Error::BadMesh {
            field: field.to_owned(),
            path: self.path.clone(),
            reason: format!("cannot be read: {e}"),
        })
    }

    /// [`MeshFile::load_report`] for a file's contents already in memory (an object compiled
    /// into the library): `bytes` are read as the file at [`MeshFile::path`] would be, whose
    /// extension gives the format and which error messages name.
    pub fn load_bytes(&self, bytes: &[u8], field: &str, cache: &ShapeCache) -> Result<LoadedMesh> {
        self.validate(field)?;
        let bad = |reason: String| Error::BadMesh {
            field: field.to_owned(),
            path: self.path.clone(),
            reason,
        };
        let key = self.cache_key(bytes);
        if let MeshCollision::Decompose(_) = self.collision {
            if let Some(parts) = cache.read(&key) {
                return Ok(LoadedMesh {
                    shape: shape_of(parts, field, &bad)?,
                    from_cache: true,
                });
            }
        }
        let meshes = self.read_meshes(bytes, &bad, &read_material_library)?;
        let parts = match self.collision {
            MeshCollision::Parts => meshes.into_iter().map(|m| m.vertices).collect(),
            MeshCollision::Hull => vec![meshes.into_iter().flat_map(|m| m.vertices).collect()],
            MeshCollision::Decompose(settings) => {
                let mut parts = decompose(&meshes, &settings);
                merge_parts(&mut parts, settings.max_parts as usize);
                cache.write(&key, &parts);
                parts
            }
        };
        Ok(LoadedMesh {
            shape: shape_of(parts, field, &bad)?,
            from_cache: false,
        })
    }

    fn validate(&self, field: &str) -> Result<()> {
        if !self.scale.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(Error::InvalidConfig {
                field: format!("{field}.scale"),
                reason: format!(
                    "must be three finite positive numbers, got {:?}",
                    self.scale
                ),
            });
        }
        if let MeshCollision::Decompose(d) = self.collision {
            if !(8..=512).contains(&d.resolution) {
                return Err(Error::InvalidConfig {
                    field: format!("{field}.resolution"),
                    reason: format!("must be 8 to 512 voxels, got {}", d.resolution),
                });
            }
            if !(d.concavity.is_finite() && d.concavity > 0.0 && d.concavity < 1.0) {
                return Err(Error::InvalidConfig {
                    field: format!("{field}.concavity"),
                    reason: format!("must be above 0 and below 1, got {}", d.concavity),
                });
            }
            if !(1..=1024).contains(&d.max_parts) {
                return Err(Error::InvalidConfig {
                    field: format!("{field}.max_parts"),
                    reason: format!("must be 1 to 1024, got {}", d.max_parts),
                });
            }
        }
        Ok(())
    }

    /// sha256 of what decides the decomposition: the file's bytes, the scale and the settings.
    fn cache_key(&self, bytes: &[u8]) -> String {
        let mut hash = Sha256::new();
        hash.update(b"panda_rapier convex parts v1\0");
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(bytes);
        for s in self.scale {
            hash.update(s.to_le_bytes());
        }
        if let MeshCollision::Decompose(d) = self.collision {
            hash.update(d.resolution.to_le_bytes());
            hash.update(d.concavity.to_le_bytes());
            hash.update(d.max_parts.to_le_bytes());
        }
        hash.finalize().iter().map(|b| format!("{b:02x}")).collect()
    }

    /// How the mesh looks: one [`VisualPart`] per mesh of the file (an OBJ's groups, objects
    /// and material changes; a COLLADA file's meshes), its triangles as the file gives them
    /// (scaled), coloured by its material's diffuse colour where the file gives one (an OBJ's
    /// material library, read from beside it; a missing library leaves the parts uncoloured).
    /// `bytes` are the file's contents; errors as [`MeshFile::load`]'s.
    pub fn visual(&self, bytes: &[u8], field: &str) -> Result<ObjectVisual> {
        self.visual_with(bytes, field, &read_material_library)
    }

    /// [`MeshFile::visual`] with an OBJ's material library read by `materials` (given the
    /// library's path beside the file): an object compiled into the library reads its own.
    pub fn visual_with(
        &self,
        bytes: &[u8],
        field: &str,
        materials: &dyn Fn(&Path) -> io::Result<Vec<u8>>,
    ) -> Result<ObjectVisual> {
        self.validate(field)?;
        let bad = |reason: String| Error::BadMesh {
            field: field.to_owned(),
            path: self.path.clone(),
            reason,
        };
        let parts = self
            .read_meshes(bytes, &bad, materials)?
            .into_iter()
            .filter_map(|m| {
                let vertices = m.vertices.iter().map(|&v| Vector3::from(v)).collect();
                let mesh = TriangleMesh::new(vertices, m.triangles)?;
                Some(VisualPart {
                    shape: VisualShape::Mesh {
                        mesh: SharedMesh(Arc::new(mesh)),
                    },
                    pose: Isometry3::identity(),
                    color: m.color,
                })
            })
            .collect();
        Ok(ObjectVisual { parts })
    }

    /// The file's meshes, scaled, each with its triangles and colour; every coordinate finite.
    fn read_meshes(
        &self,
        bytes: &[u8],
        bad: &dyn Fn(String) -> Error,
        materials: &dyn Fn(&Path) -> io::Result<Vec<u8>>,
    ) -> Result<Vec<Mesh>> {
        let extension = self
            .path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let loader = mesh_loader::Loader::default();
        let scene = match extension.as_str() {
            "obj" => {
                // mesh-loader starts a new mesh at `g` lines and material changes but not at
                // `o` lines, which is how PyBullet's `_vhacd` files separate their hulls.
                let text = obj_objects_as_groups(bytes);
                loader.load_obj_from_slice_with_reader(&text, &self.path, materials)
            }
            "stl" => loader.load_stl_from_slice(bytes, &self.path),
            "dae" => loader.load_collada_from_slice(bytes, &self.path),
            other => {
                return Err(bad(format!(
                    "has extension `{other}`; OBJ (.obj), STL (.stl) and COLLADA (.dae) files \
                     are read"
                )))
            }
        }
        .map_err(|e| bad(format!("cannot be parsed: {e}")))?;

        let mut meshes = Vec::new();
        for (k, mesh) in scene.meshes.iter().enumerate() {
            if mesh.faces.is_empty() {
                continue;
            }
            let color = scene
                .materials
                .get(k)
                .and_then(|m| m.color.diffuse)
                .and_then(|c| color_from_fractions([c[0], c[1], c[2]].map(f64::from)));
            let mut vertices = Vec::with_capacity(mesh.vertices.len());
            for (k, v) in mesh.vertices.iter().enumerate() {
                let p = [
                    f64::from(v[0]) * self.scale[0],
                    f64::from(v[1]) * self.scale[1],
                    f64::from(v[2]) * self.scale[2],
                ];
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(bad(format!(
                        "vertex {k} of mesh `{}` is not finite: {v:?}",
                        mesh.name
                    )));
                }
                vertices.push(p);
            }
            let count = vertices.len() as u32;
            if let Some(face) = mesh.faces.iter().find(|f| f.iter().any(|&i| i >= count)) {
                return Err(bad(format!(
                    "a triangle of mesh `{}` names vertex {face:?} of {count}",
                    mesh.name
                )));
            }
            meshes.push(Mesh {
                vertices,
                triangles: mesh.faces.clone(),
                color,
            });
        }
        if meshes.is_empty() {
            return Err(bad("has no triangles".into()));
        }
        Ok(meshes)
    }
}

/// A loaded mesh shape and where its parts came from.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedMesh {
    /// The collision shape.
    pub shape: ObjectShape,
    /// Whether the decomposition was read from the cache (always false unless
    /// [`MeshCollision::Decompose`]).
    pub from_cache: bool,
}

/// Where decompositions of mesh files are kept between runs: one small JSON file per file and
/// settings, named by their sha256. A cache that cannot be read or written is passed over (the
/// decomposition is then computed again); a corrupt entry is recomputed and replaced.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShapeCache {
    dir: Option<PathBuf>,
}

impl ShapeCache {
    /// The cache in `dir` (created when first written).
    pub fn at(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: Some(dir.into()),
        }
    }

    /// No cache: every load decomposes.
    pub fn none() -> Self {
        Self { dir: None }
    }

    /// The default place: `$PANDA_RAPIER_CACHE/convex-parts` if that variable is set (an empty
    /// value turns the cache off), else `$XDG_CACHE_HOME/panda_rapier/convex-parts`, else
    /// `~/.cache/panda_rapier/convex-parts`.
    pub fn default_location() -> Self {
        let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        if let Some(value) = std::env::var_os("PANDA_RAPIER_CACHE") {
            if value.is_empty() {
                return Self::none();
            }
            return Self::at(PathBuf::from(value).join("convex-parts"));
        }
        let base = var("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache")));
        match base {
            Some(base) => Self::at(base.join("panda_rapier").join("convex-parts")),
            None => Self::none(),
        }
    }

    /// The directory, if any.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    fn entry(&self, key: &str) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join(format!("{key}.json")))
    }

    fn read(&self, key: &str) -> Option<Vec<Vec<[f64; 3]>>> {
        let text = fs::read_to_string(self.entry(key)?).ok()?;
        let entry: CacheEntry = serde_json::from_str(&text).ok()?;
        let parts: Vec<Vec<[f64; 3]>> = entry
            .parts
            .iter()
            .map(|part| {
                part.iter()
                    .map(|p| p.map(|bits| f64::from(f32::from_bits(bits))))
                    .collect()
            })
            .collect();
        let valid = entry.key == key
            && !parts.is_empty()
            && parts
                .iter()
                .all(|p| p.len() >= 4 && p.iter().flatten().all(|c| c.is_finite()));
        valid.then_some(parts)
    }

    fn write(&self, key: &str, parts: &[Vec<[f64; 3]>]) {
        let (Some(dir), Some(path)) = (self.dir.as_ref(), self.entry(key)) else {
            return;
        };
        let entry = CacheEntry {
            key: key.to_owned(),
            parts: parts
                .iter()
                .map(|part| {
                    part.iter()
                        .map(|p| p.map(|c| (c as f32).to_bits()))
                        .collect()
                })
                .collect(),
        };
        let Ok(text) = serde_json::to_string(&entry) else {
            return;
        };
        // Written beside and renamed into place, so a reader never sees half a file. The
        // partial file is this write's own (process and write number): two threads storing
        // the same entry at once must not write into one file while the other renames it.
        static WRITES: AtomicU64 = AtomicU64::new(0);
        let n = WRITES.fetch_add(1, Ordering::Relaxed);
        let partial = dir.join(format!("{key}.{}.{n}.part", std::process::id()));
        let _ = fs::create_dir_all(dir)
            .and_then(|()| fs::write(&partial, text))
            .and_then(|()| fs::rename(&partial, &path))
            .inspect_err(|_| {
                let _ = fs::remove_file(&partial);
            });
    }
}

/// One cache file.
#[derive(Serialize, Deserialize)]
struct CacheEntry {
    /// The entry's own key (its file name), checked when read.
    key: String,
    /// Each part's hull points (m), as the bits of their `f32` coordinates (what the
    /// decomposition computes): read back exactly, which decimal text would not promise.
    parts: Vec<Vec<[u32; 3]>>,
}

/// A mesh as read: scaled vertices and triangles.
struct Mesh {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    /// Its material's diffuse colour, where the file gives one.
    color: Option<[u8; 3]>,
}

/// Reads an OBJ's material library from the file system; a missing one only costs the
/// colours, so it reads as empty.
fn read_material_library(path: &Path) -> io::Result<Vec<u8>> {
    match fs::read(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(Vec::new()),
        other => other,
    }
}

/// The OBJ text with each `o` line turned into a `g` line of the same name.
fn obj_objects_as_groups(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    for line in bytes.split_inclusive(|&b| b == b'\n') {
        let start = line
            .iter()
            .take_while(|b| **b == b' ' || **b == b'\t')
            .count();
        let rest = &line[start..];
        if rest.first() == Some(&b'o') && matches!(rest.get(1), Some(b' ' | b'\t')) {
            out.extend_from_slice(&line[..start]);
            out.push(b'g');
            out.extend_from_slice(&rest[1..]);
        } else {
            out.extend_from_slice(line);
        }
    }
    out
}

/// parry's V-HACD of all the meshes together; each part as the hull of the mesh's own points
/// inside it.
fn decompose(meshes: &[Mesh], settings: &Decomposition) -> Vec<Vec<[f64; 3]>> {
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    for mesh in meshes {
        let offset = points.len() as u32;
        points.extend(mesh.vertices.iter().map(|&p| vec_from_array(p)));
        triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + offset)));
    }
    let params = VHACDParameters {
        resolution: settings.resolution,
        concavity: settings.concavity as f32,
        max_convex_hulls: settings.max_parts,
        fill_mode: FillMode::FloodFill {
            detect_cavities: false,
        },
        ..VHACDParameters::default()
    };
    let vhacd = VHACD::decompose(&params, &points, &triangles, true);
    vhacd
        .compute_exact_convex_hulls(&points, &triangles)
        .into_iter()
        .map(|(hull, _)| {
            hull.iter()
                .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)])
                .collect()
        })
        .collect()
}

/// The shape of convex parts: those spanning a volume, as one hull or a compound of hulls.
fn shape_of(
    parts: Vec<Vec<[f64; 3]>>,
    field: &str,
    bad: &dyn Fn(String) -> Error,
) -> Result<ObjectShape> {
    let total = parts.len();
    let mut hulls: Vec<ObjectShape> = parts
        .into_iter()
        .map(|points| ObjectShape::ConvexHull {
            points: hull_vertices(&points),
        })
        .filter(|hull| hull.build(field).is_ok())
        .collect();
    match hulls.len() {
        0 => Err(bad(format!(
            "yields no convex part with a volume ({total} part(s), every one flat or empty)"
        ))),
        1 => Ok(hulls.remove(0)),
        _ => Ok(ObjectShape::Compound {
            parts: hulls
                .into_iter()
                .map(|hull| ShapePart::at([0.0; 3], hull))
                .collect(),
        }),
    }
}

/// The corners of the convex hull of `points` (a mesh repeats each vertex once per triangle;
/// points inside are dropped), in parry's order; the points themselves if they span no volume
/// (refused later).
fn hull_vertices(points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    if points.len() < 4 || points.iter().flatten().any(|c| !c.is_finite()) {
        return points.to_vec();
    }
    let as_parry: Vec<_> = points.iter().map(|&p| vec_from_array(p)).collect();
    match rapier3d::parry::transformation::try_convex_hull(&as_parry) {
        Ok((vertices, _)) if vertices.len() >= 4 => vertices
            .iter()
            .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)])
            .collect(),
        _ => points.to_vec(),
    }
}

/// The volume of the convex hull of `points` (0 when they span none).
fn hull_volume(points: &[[f64; 3]]) -> f64 {
    let as_parry: Vec<_> = points.iter().map(|&p| vec_from_array(p)).collect();
    rapier3d::geometry::SharedShape::convex_hull(&as_parry)
        .map_or(0.0, |hull| f64::from(hull.mass_properties(1.0).mass()))
}

/// Merges parts until at most `max` are left: each time the pair whose merged hull exceeds
/// their two volumes by the least (the first such pair in order, so the result is
/// deterministic).
fn merge_parts(parts: &mut Vec<Vec<[f64; 3]>>, max: usize) {
    let mut volumes: Vec<f64> = parts.iter().map(|p| hull_volume(p)).collect();
    while parts.len() > max.max(1) {
        let mut best = (f64::INFINITY, 0, 1, Vec::new(), 0.0);
        for i in 0..parts.len() {
            for j in i + 1..parts.len() {
                let merged = hull_vertices(&[parts[i].as_slice(), parts[j].as_slice()].concat());
                let volume = hull_volume(&merged);
                let cost = volume - volumes[i] - volumes[j];
                if cost < best.0 {
                    best = (cost, i, j, merged, volume);
                }
            }
        }
        let (_, i, j, merged, volume) = best;
        parts[i] = merged;
        volumes[i] = volume;
        parts.remove(j);
        volumes.remove(j);
    }
}
