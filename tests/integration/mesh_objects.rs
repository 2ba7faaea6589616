//! Objects from mesh files (`MeshFile`): a non-convex OBJ is decomposed into convex parts that
//! keep its cavity (a cube dropped into a cup lands inside it), the decomposition is cached on
//! disk by content and settings, files of convex blocks are taken as they are, STL files load,
//! and bad files are refused by name.

use crate::common::obj_files;
use crate::common::objects;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use obj_files::box_obj;
use objects::{object, run};
use panda_rapier::{
    Decomposition, Error, MeshCollision, MeshFile, ObjectShape, ObjectSpec, Scene, ShapeCache,
    Simulation,
};

/// A fresh scratch directory under the target directory.
fn scratch(name: &str) -> PathBuf {
    obj_files::scratch("mesh_objects", name)
}

/// A cup: a square box 8 x 8 cm, 6 cm high, open at the top, walls and bottom 1 cm thick,
/// its bottom on z = 0; as one OBJ object of five overlapping closed boxes (not convex).
fn cup_obj() -> String {
    let mut obj = String::from("# a cup of five boxes\no cup\n");
    let parts = [
        ([-0.04, -0.04, 0.0], [0.04, 0.04, 0.01]),
        ([-0.04, -0.04, 0.0], [-0.03, 0.04, 0.06]),
        ([0.03, -0.04, 0.0], [0.04, 0.04, 0.06]),
        ([-0.04, -0.04, 0.0], [0.04, -0.03, 0.06]),
        ([-0.04, 0.03, 0.0], [0.04, 0.04, 0.06]),
    ];
    for (i, (lo, hi)) in parts.into_iter().enumerate() {
        box_obj(&mut obj, lo, hi, 1 + 8 * i);
    }
    obj
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The default robot with `objects` on the floor (no platform).
fn world(objects: Vec<ObjectSpec>) -> Simulation {
    objects::world(Scene {
        platform: None,
        objects,
        floor_friction: None,
        articulations: Vec::new(),
    })
}

fn hull_count(shape: &ObjectShape) -> usize {
    match shape {
        ObjectShape::Compound { parts } => parts.len(),
        _ => 1,
    }
}

#[test]
fn a_decomposed_cup_keeps_its_cavity_and_a_hull_does_not() {
    let dir = scratch("cup");
    let path = write(&dir, "cup.obj", &cup_obj());
    let decomposed = MeshFile::new(&path)
        .load("cup", &ShapeCache::none())
        .unwrap();
    let parts = hull_count(&decomposed);
    assert!(
        (5..=16).contains(&parts),
        "the cup became {parts} convex part(s)"
    );
    // At most `max_parts`, merged where they add the least volume; the same cup outline.
    let few = MeshFile {
        collision: MeshCollision::Decompose(Decomposition {
            max_parts: 3,
            ..Decomposition::default()
        }),
        ..MeshFile::new(&path)
    }
    .load("cup", &ShapeCache::none())
    .unwrap();
    assert_eq!(hull_count(&few), 3);
    let extent = |shape: &ObjectShape| {
        let ObjectShape::Compound { parts } = shape else {
            panic!("{shape:?}")
        };
        let points: Vec<[f64; 3]> = parts
            .iter()
            .flat_map(|p| match &p.shape {
                ObjectShape::ConvexHull { points } => points.clone(),
                other => panic!("{other:?}"),
            })
            .collect();
        (0..3)
            .map(|a| {
                let lo = points.iter().map(|p| p[a]).fold(f64::MAX, f64::min);
                let hi = points.iter().map(|p| p[a]).fold(f64::MIN, f64::max);
                (lo, hi)
            })
            .collect::<Vec<_>>()
    };
    for ((lo, hi), (lo3, hi3)) in extent(&decomposed).into_iter().zip(extent(&few)) {
        assert!((lo - lo3).abs() < 1e-6 && (hi - hi3).abs() < 1e-6);
    }
    let hull = MeshFile {
        collision: MeshCollision::Hull,
        ..MeshFile::new(&path)
    }
    .load("cup", &ShapeCache::none())
    .unwrap();
    assert!(matches!(hull, ObjectShape::ConvexHull { .. }));

    // The cup stands on the floor; a 2 cm cube falls into it from 15 cm above its bottom.
    let landing = |cup: ObjectShape| {
        let mut sim = world(vec![
            object("cup", cup, [0.5, 0.3, 0.001]),
            object("cube", ObjectShape::cube(0.02), [0.5, 0.3, 0.15]),
        ]);
        run(&mut sim, 1.5);
        let cup = sim.object_state(sim.object("cup").unwrap());
        let cube = sim.object_state(sim.object("cube").unwrap());
        (cup.position, cube.position)
    };
    let (cup, cube) = landing(decomposed);
    assert!(cup.z.abs() < 1.5e-3, "the decomposed cup stands at {cup}");
    // Inside: on the 1 cm bottom, its centre 1 cm above that.
    assert!((cube.z - 0.02).abs() < 2e-3, "the cube rests at {cube}");
    assert!((cube.xy() - cup.xy()).norm() < 0.03, "{cube} vs {cup}");
    let (_, cube) = landing(hull);
    // The hull closes the cup's mouth: the cube rests on top.
    assert!(
        (cube.z - 0.07).abs() < 2e-3,
        "on the hull the cube rests at {cube}"
    );
}

#[test]
fn decompositions_are_cached_by_content_and_settings() {
    let dir = scratch("cache");
    let cache = ShapeCache::at(dir.join("cache"));
    let path = write(&dir, "cup.obj", &cup_obj());
    let mesh = MeshFile::new(&path);
    let entries = || std::fs::read_dir(dir.join("cache")).map_or(0, |d| d.count());

    let first = mesh.load_report("cup", &cache).unwrap();
    assert!(!first.from_cache);
    assert_eq!(entries(), 1);
    let second = mesh.load_report("cup", &cache).unwrap();
    assert!(second.from_cache);
    assert_eq!(second.shape, first.shape);

    // Another scale or setting is another entry; the same file under another name is not.
    let scaled = MeshFile {
        scale: [2.0; 3],
        ..mesh.clone()
    };
    assert!(!scaled.load_report("cup", &cache).unwrap().from_cache);
    let coarse = MeshFile {
        collision: MeshCollision::Decompose(Decomposition {
            resolution: 32,
            ..Decomposition::default()
        }),
        ..mesh.clone()
    };
    assert!(!coarse.load_report("cup", &cache).unwrap().from_cache);
    assert_eq!(entries(), 3);
    let copy = write(&dir, "copy.obj", &cup_obj());
    assert!(
        MeshFile::new(&copy)
            .load_report("cup", &cache)
            .unwrap()
            .from_cache
    );

    // What the cache says is what is used ...
    let entry = std::fs::read_dir(dir.join("cache"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .min()
        .unwrap();
    let key = entry.file_stem().unwrap().to_str().unwrap().to_owned();
    let tenth = 0.1f32.to_bits();
    let tetrahedron = format!(
        r#"{{"key":"{key}","parts":[[[0,0,0],[{tenth},0,0],[0,{tenth},0],[0,0,{tenth}]]]}}"#
    );
    std::fs::write(&entry, tetrahedron).unwrap();
    let from_entry = |m: &MeshFile| m.load_report("cup", &cache).unwrap();
    let loaded = [&mesh, &scaled, &coarse]
        .into_iter()
        .map(from_entry)
        .find(|l| matches!(&l.shape, ObjectShape::ConvexHull { points } if points.len() == 4))
        .expect("the edited entry is read back");
    assert!(loaded.from_cache);
    // ... and a corrupt entry is recomputed and replaced.
    std::fs::write(&entry, "not json").unwrap();
    for m in [&mesh, &scaled, &coarse] {
        m.load("cup", &cache).unwrap();
    }
    assert!(std::fs::read_dir(dir.join("cache"))
        .unwrap()
        .all(|e| std::fs::read_to_string(e.unwrap().path()).unwrap() != "not json"));
    // No cache directory that can be written: loads anyway.
    let unwritable = ShapeCache::at(path.join("not-a-dir"));
    assert!(!mesh.load_report("cup", &unwritable).unwrap().from_cache);
}

#[test]
fn files_of_convex_blocks_are_taken_as_they_are() {
    // PyBullet's `_vhacd` files: one `o` block per convex hull.
    let dir = scratch("blocks");
    let mut obj = String::from("o convex_0\n");
    box_obj(&mut obj, [0.0, 0.0, 0.0], [0.02, 0.02, 0.02], 1);
    obj.push_str("o convex_1\n");
    box_obj(&mut obj, [0.05, 0.0, 0.0], [0.07, 0.03, 0.01], 9);
    let path = write(&dir, "blocks_vhacd.obj", &obj);
    let mesh = MeshFile {
        collision: MeshCollision::Parts,
        scale: [1.0, 1.0, 2.0],
        ..MeshFile::new(&path)
    };
    let ObjectShape::Compound { parts } = mesh.load("blocks", &ShapeCache::none()).unwrap() else {
        panic!("two blocks make a compound");
    };
    assert_eq!(parts.len(), 2);
    let tops: Vec<f64> = parts
        .iter()
        .map(|p| match &p.shape {
            ObjectShape::ConvexHull { points } => {
                points.iter().map(|q| q[2]).fold(f64::MIN, f64::max)
            }
            other => panic!("{other:?}"),
        })
        .collect();
    // The file's coordinates are single precision.
    assert!(
        (tops[0] - 0.04).abs() < 1e-7 && (tops[1] - 0.02).abs() < 1e-7,
        "{tops:?}"
    );
    // Merged into one hull, the gap between them is filled.
    let hull = MeshFile {
        collision: MeshCollision::Hull,
        ..mesh
    }
    .load("blocks", &ShapeCache::none())
    .unwrap();
    let ObjectShape::ConvexHull { points } = hull else {
        panic!("{hull:?}")
    };
    let x = |f: fn(f64, f64) -> f64, init| points.iter().map(|p| p[0]).fold(init, f);
    assert!(x(f64::min, 1.0).abs() < 1e-7 && (x(f64::max, -1.0) - 0.07).abs() < 1e-7);
    // Each corner once: at most the two boxes' sixteen.
    assert!(points.len() <= 16, "{}", points.len());
}

#[test]
fn stl_files_load() {
    let dir = scratch("stl");
    let corners = [
        [0.0, 0.0, 0.0],
        [0.05, 0.0, 0.0],
        [0.0, 0.05, 0.0],
        [0.0, 0.0, 0.05],
    ];
    let mut stl = String::from("solid tetra\n");
    for [a, b, c] in [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] {
        stl.push_str(" facet normal 0 0 0\n  outer loop\n");
        for k in [a, b, c] {
            let p: [f64; 3] = corners[k];
            writeln!(stl, "   vertex {} {} {}", p[0], p[1], p[2]).unwrap();
        }
        stl.push_str("  endloop\n endfacet\n");
    }
    stl.push_str("endsolid tetra\n");
    let path = write(&dir, "tetra.STL", &stl);
    let shape = MeshFile {
        collision: MeshCollision::Hull,
        ..MeshFile::new(&path)
    }
    .load("tetra", &ShapeCache::none())
    .unwrap();
    let mut sim = world(vec![object("tetra", shape, [0.5, 0.3, 0.02])]);
    run(&mut sim, 1.0);
    let z = sim.object_state(sim.object("tetra").unwrap()).position.z;
    assert!(z.abs() < 1e-3, "the tetrahedron's base rests at {z}");
}

#[test]
fn bad_mesh_files_are_refused_by_file_and_field() {
    let dir = scratch("bad");
    let field = "scene.objects[0].mesh";
    let refused = |mesh: MeshFile| -> String {
        let err = mesh.load(field, &ShapeCache::none()).unwrap_err();
        assert!(
            matches!(&err, Error::BadMesh { field: f, path, .. } if f == field && *path == mesh.path),
            "{err:?}"
        );
        err.to_string()
    };
    let hull = |path: PathBuf| MeshFile {
        collision: MeshCollision::Hull,
        ..MeshFile::new(path)
    };
    let message = refused(MeshFile::new(dir.join("missing.obj")));
    assert!(
        message.contains("missing.obj")
            && message.contains(field)
            && message.contains("cannot be read")
    );
    let message = refused(MeshFile::new(write(&dir, "mesh.ply", "ply\n")));
    assert!(message.contains("extension `ply`"), "{message}");
    let message = refused(MeshFile::new(write(&dir, "empty.obj", "")));
    assert!(message.contains("no triangles"), "{message}");
    let message = refused(MeshFile::new(write(
        &dir,
        "points.obj",
        "v 0 0 0\nv 1 0 0\n",
    )));
    assert!(message.contains("no triangles"), "{message}");
    let message = refused(hull(write(
        &dir,
        "nan.obj",
        "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n",
    )));
    assert!(message.contains("not finite"), "{message}");
    let message = refused(hull(write(
        &dir,
        "flat.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )));
    assert!(
        message.contains("no convex part with a volume"),
        "{message}"
    );
    let message = refused(MeshFile::new(write(
        &dir,
        "flat2.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )));
    assert!(
        message.contains("no convex part with a volume"),
        "{message}"
    );
    let message = refused(hull(write(&dir, "broken.stl", "solid x\n facet normal\n")));
    assert!(message.contains("cannot be parsed"), "{message}");

    // Settings are configuration errors naming the setting.
    let cup = write(&dir, "cup.obj", &cup_obj());
    for (mesh, setting) in [
        (
            MeshFile {
                scale: [1.0, 0.0, 1.0],
                ..MeshFile::new(&cup)
            },
            "scale",
        ),
        (
            MeshFile {
                scale: [1.0, f64::NAN, 1.0],
                ..MeshFile::new(&cup)
            },
            "scale",
        ),
        (
            MeshFile {
                collision: MeshCollision::Decompose(Decomposition {
                    resolution: 0,
                    ..Decomposition::default()
                }),
                ..MeshFile::new(&cup)
            },
            "resolution",
        ),
        (
            MeshFile {
                collision: MeshCollision::Decompose(Decomposition {
                    concavity: -1.0,
                    ..Decomposition::default()
                }),
                ..MeshFile::new(&cup)
            },
            "concavity",
        ),
        (
            MeshFile {
                collision: MeshCollision::Decompose(Decomposition {
                    max_parts: 0,
                    ..Decomposition::default()
                }),
                ..MeshFile::new(&cup)
            },
            "max_parts",
        ),
    ] {
        let err = mesh.load(field, &ShapeCache::none()).unwrap_err();
        assert!(
            matches!(&err, Error::InvalidConfig { field: f, .. } if *f == format!("{field}.{setting}")),
            "{err:?}"
        );
    }
    // The cup itself is fine, with any positive scale.
    let scaled = MeshFile {
        scale: [0.5, 2.0, 1.0],
        ..MeshFile::new(&cup)
    };
    assert!(scaled.load(field, &ShapeCache::none()).is_ok());
}

/// The shipped object set (`assets/objects`, made by `scripts/make_objects.py`): each
/// decomposes, keeps the size the script gives it, and comes to rest on the floor on its base
/// without sinking into it.
#[test]
fn the_shipped_objects_load_and_rest_on_the_floor() {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/objects");
    // (file, size along x, y, z in m, as the script prints them)
    let expected = [
        ("can", [0.066, 0.066, 0.122]),
        ("bottle", [0.064, 0.064, 0.225]),
        ("bowl", [0.140, 0.140, 0.050]),
        ("mug", [0.098, 0.066, 0.095]),
        ("banana", [0.184, 0.065, 0.036]),
        ("tennis_ball", [0.066, 0.066, 0.066]),
        ("block", [0.050, 0.080, 0.050]),
        ("hammer", [0.180, 0.090, 0.030]),
        ("screwdriver", [0.1885, 0.0275, 0.0275]),
        ("pear", [0.0597, 0.0597, 0.082]),
    ];
    let cache = ShapeCache::at(Path::new(env!("CARGO_TARGET_TMPDIR")).join("object-set-cache"));
    let mut objects = Vec::new();
    for (i, (name, size)) in expected.iter().enumerate() {
        // Convex parts where the set ships them, else the mesh's decomposition.
        let shape = MeshFile::with_parts_beside(assets.join(format!("{name}.obj")))
            .load(name, &cache)
            .unwrap();
        let points: Vec<[f64; 3]> = match &shape {
            ObjectShape::Compound { parts } => parts
                .iter()
                .flat_map(|p| match &p.shape {
                    ObjectShape::ConvexHull { points } => points.clone(),
                    other => panic!("{other:?}"),
                })
                .collect(),
            ObjectShape::ConvexHull { points } => points.clone(),
            other => panic!("{other:?}"),
        };
        for axis in 0..3 {
            let lo = points.iter().map(|p| p[axis]).fold(f64::MAX, f64::min);
            let hi = points.iter().map(|p| p[axis]).fold(f64::MIN, f64::max);
            assert!(
                (hi - lo - size[axis]).abs() < 1.5e-3,
                "{name} spans {} m along axis {axis}, not {}",
                hi - lo,
                size[axis]
            );
        }
        let (x, y) = (0.3 + 0.25 * (i % 3) as f64, -0.45 + 0.3 * (i / 3) as f64);
        objects.push(object(name, shape, [x, y, 0.003]));
    }
    let mut sim = world(objects);
    run(&mut sim, 2.0);
    let settled: Vec<_> = expected
        .iter()
        .map(|(name, _)| sim.object_state(sim.object(name).unwrap()))
        .collect();
    run(&mut sim, 1.0);
    for ((name, _), before) in expected.iter().zip(settled) {
        let now = sim.object_state(sim.object(name).unwrap());
        let drift = (now.position - before.position).norm();
        assert!(drift < 1e-3, "{name} still moves: {drift} m in 1 s");
        let tilt = now
            .orientation
            .angle_to(&nalgebra::UnitQuaternion::identity());
        assert!(tilt < 0.05, "{name} fell over: tilted {tilt} rad");
        assert!(
            now.position.z.abs() < 1.5e-3,
            "{name}'s base rests at z = {}",
            now.position.z
        );
    }
}
