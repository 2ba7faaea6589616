//! Renders the scripted policy's episode on the CPU: prints frames per second and writes the
//! frame after `STEP` steps as a binary PPM.
//!
//! `cargo run --release --example render -- [WIDTH HEIGHT STEP OUT.ppm]` (default 720 480 15
//! frame.ppm).

use std::io::Write;
use std::time::Instant;

use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::render::{RenderConfig, Renderer};
use panda_rapier::task::{EnvConfig, ResetOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let width = args.first().map_or(Ok(720), |s| s.parse())?;
    let height = args.get(1).map_or(Ok(480), |s| s.parse())?;
    let keep = args.get(2).map_or(Ok(15), |s| s.parse::<u32>())?;
    let out = args.get(3).map_or("frame.ppm", String::as_str);

    let config = EnvConfig::default();
    let mut env = PandaEnv::new(config.clone())?;
    env.reset(Some(0), &ResetOptions::default())?;
    let mut policy = ScriptedPolicy::new(&config)?;
    let mut renderer = Renderer::new(RenderConfig {
        width,
        height,
        ..RenderConfig::default()
    })?;
    let mut action = vec![0.0; env.action_dim()];
    let steps = config.max_episode_steps.unwrap_or(70);
    let mut render_time = 0.0;
    for step in 0..=steps {
        let start = Instant::now();
        let frame = renderer.render(&env);
        render_time += start.elapsed().as_secs_f64();
        if step == keep {
            let mut file = std::fs::File::create(out)?;
            write!(file, "P6\n{} {}\n255\n", frame.width(), frame.height())?;
            file.write_all(frame.rgb())?;
        }
        if step < steps {
            policy.act(env.observation(), &mut action)?;
            env.step(&action)?;
        }
    }
    let frames = f64::from(steps + 1);
    println!(
        "{width}x{height}: {frames} frames in {render_time:.3} s, {:.1} frames/s ({:.2} ms per frame); frame {keep} written to {out}",
        frames / render_time,
        1e3 * render_time / frames
    );
    Ok(())
}
