//! Segmentation ids: what each pixel of a segmentation image shows, one fixed scheme for every
//! task (an id never changes meaning between tasks or configurations), and the table of the
//! ids a scene can show.

use panda_rapier_core::{Simulation, VisualPrimitive, VisualTag};

/// Nothing drawn (the sky).
pub const BACKGROUND: u8 = 0;
/// The floor.
pub const FLOOR: u8 = 1;
/// The platform.
pub const PLATFORM: u8 = 2;
/// A goal marker (drawn only by cameras with `show_goal`).
pub const GOAL: u8 = 3;
/// Link `l` of an articulated object of the scene (`Scene::articulations`; a cabinet's carcass,
/// its drawer) is `FIRST_ARTICULATION_LINK + l`, up to link 3 (later links share id 7; several
/// articulated objects share these ids).
pub const FIRST_ARTICULATION_LINK: u8 = 4;
/// Object `k` of the task's scene (`Scene::objects`, in order) is `FIRST_OBJECT + k`, up to
/// object 23 (later objects share id 31).
pub const FIRST_OBJECT: u8 = 8;
/// Robot link `l` (`RobotModel::links`, in order; the fingers are links) is `FIRST_LINK + l`,
/// up to link 223 (later links share id 255).
pub const FIRST_LINK: u8 = 32;

/// The segmentation id of what a primitive belongs to.
pub fn id_of(tag: &VisualTag) -> u8 {
    match *tag {
        VisualTag::Floor => FLOOR,
        VisualTag::Platform => PLATFORM,
        VisualTag::Object { index } => FIRST_OBJECT + index.min(23) as u8,
        VisualTag::Articulation { link, .. } => FIRST_ARTICULATION_LINK + link.min(3) as u8,
        VisualTag::RobotLink { link, .. } => FIRST_LINK.saturating_add(link.min(223) as u8),
    }
}

/// Every id a picture of `sim` can show, with what it stands for, by increasing id:
/// `background`, `floor`, `platform`, `goal`, `articulation:<name>:<link>` for each link of an
/// articulated object, `object:<name>` for each object of the scene and `link:<name>` for each robot link that has a shape to draw.
pub fn table(sim: &Simulation) -> Vec<(u8, String)> {
    let mut primitives: Vec<VisualPrimitive> = Vec::new();
    sim.visual_primitives(&mut primitives);
    let mut out = vec![
        (BACKGROUND, "background".to_string()),
        (GOAL, "goal".to_string()),
    ];
    let objects = &sim.scene().objects;
    let links = sim.model().links();
    for p in &primitives {
        let name = match p.tag {
            VisualTag::Floor => "floor".to_string(),
            VisualTag::Platform => "platform".to_string(),
            VisualTag::Object { index } => format!(
                "object:{}",
                objects.get(index).map_or("", |o| o.name.as_str())
            ),
            VisualTag::Articulation { index, link } => {
                let articulation = sim.scene().articulations.get(index);
                format!(
                    "articulation:{}:{}",
                    articulation.map_or("", |a| a.name.as_str()),
                    articulation
                        .and_then(|a| a.model.links().get(link))
                        .map_or("", |l| l.name.as_str())
                )
            }
            VisualTag::RobotLink { link, .. } => {
                format!("link:{}", links.get(link).map_or("", |l| l.name.as_str()))
            }
        };
        let id = id_of(&p.tag);
        if !out.iter().any(|(known, _)| *known == id) {
            out.push((id, name));
        }
    }
    out.sort_by_key(|(id, _)| *id);
    out
}
