//! Renders every step of scripted episodes as an observation camera sees them, for profilers
//! (callgrind counts instructions reliably on a busy machine):
//!
//! `valgrind --tool=callgrind target/release/examples/profile_frames -- STEPS SIZE [render|none] [RENDER.json]`
//!
//! `none` steps the same episodes without drawing, so that the difference of the two counts
//! is the frames' cost (`scripts/instructions-per-frame`). The default picture is the default
//! observation camera (`CameraConfig::OBSERVATION`, Python's `panda_rapier.pixels.DEFAULT_CAMERA`,
//! no goal markers); a render configuration file (JSON, as `RenderConfig::from_json` reads it)
//! replaces it. The environment is pick-and-place's default unless `PROFILE_FRAMES_ENV` holds
//! an environment configuration (JSON, as `EnvConfig::from_json` reads it).

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::render::{CameraConfig, RenderConfig, Renderer};
use panda_rapier::task::{EnvConfig, ResetOptions};

fn main() -> panda_rapier::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let steps: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(200);
    let size: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(84);
    let draw = args.get(2).is_none_or(|s| s != "none");
    let render = match args.get(3) {
        Some(path) => RenderConfig::from_json(
            &std::fs::read_to_string(path).expect("render configuration file"),
        )?,
        None => RenderConfig {
            width: size,
            height: size,
            show_goal: false,
            camera: CameraConfig::OBSERVATION,
            ..RenderConfig::default()
        },
    };
    let mut renderer = Renderer::new(render)?;
    let config = match std::env::var("PROFILE_FRAMES_ENV") {
        Ok(json) => EnvConfig::from_json(&json)?,
        Err(_) => EnvConfig::default(),
    };
    let mut env = PandaEnv::new(config.clone())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let options = ResetOptions::default();
    let mut seed = 0;
    env.reset(Some(seed), &options)?;
    let mut action = vec![0.0f32; env.action_dim()];
    let mut checksum = 0u64;
    for _ in 0..steps {
        if draw {
            let frame = renderer.render(&env);
            checksum = frame
                .rgb()
                .iter()
                .fold(checksum, |h, &b| h.rotate_left(5) ^ u64::from(b));
        }
        policy.act(env.observation(), &mut action)?;
        let t = env.step(&action)?;
        if t.terminated || t.truncated {
            seed += 1;
            env.reset(Some(seed), &options)?;
        }
    }
    println!("{steps} steps, frames drawn: {draw}, checksum {checksum:016x}");
    Ok(())
}
