//! Criterion bench of the CPU renderer: one 720x480 frame (and 320x240) of the pick-and-place
//! scene mid-grasp, with shadows; and the observation sizes 128x128 and 84x84.
//!
//! `cargo bench --bench render` (throughput is reported as frames per second).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use panda_rapier::env::PandaEnv;
use panda_rapier::policies::ScriptedPolicy;
use panda_rapier::render::{RenderConfig, Renderer};
use panda_rapier::task::{EnvConfig, ResetOptions};

fn render(c: &mut Criterion) {
    let config = EnvConfig::default();
    let mut env = PandaEnv::new(config.clone()).unwrap();
    env.reset(Some(0), &ResetOptions::default()).unwrap();
    let mut policy = ScriptedPolicy::new(&config).unwrap();
    let mut action = vec![0.0; env.action_dim()];
    // The arm reaching down to the cube: the busiest picture of an episode.
    for _ in 0..15 {
        policy.act(env.observation(), &mut action).unwrap();
        env.step(&action).unwrap();
    }
    let mut group = c.benchmark_group("render");
    group.throughput(Throughput::Elements(1));
    for (width, height) in [(720, 480), (320, 240), (128, 128), (84, 84)] {
        let mut renderer = Renderer::new(RenderConfig {
            width,
            height,
            ..RenderConfig::default()
        })
        .unwrap();
        group.bench_function(
            BenchmarkId::from_parameter(format!("{width}x{height}")),
            |b| b.iter(|| renderer.render(&env).rgb().len()),
        );
    }
    group.finish();
}

// criterion_group! generates an undocumented public function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, render);
}
use group::benches;
criterion_main!(benches);
