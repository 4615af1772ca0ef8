use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::env::{Batch, EpisodeConfig, Site, AutoReset, SlotOutcome};
use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args[1].parse().unwrap();
    let threads: usize = args[2].parse().unwrap();
    let steps: usize = args[3].parse().unwrap();
    let mut cfg = EpisodeConfig::default();
    if std::env::var("NONOISE").is_ok() { cfg.world.lidar.range_noise_std = 0.0; }
    let site = Site::Preset("dynamic_obstacles".into());
    let seeds: Vec<u64> = (0..n as u64).collect();
    let mut b = Batch::new(site, cfg.clone(), &seeds, AutoReset::SameStep, threads).unwrap();
    let l = b.observation_len();
    let mut obs = vec![0f32; n * l];
    let mut fin = vec![0f32; n * l];
    let mut out = vec![SlotOutcome::default(); n];
    b.reset(&seeds, &mut obs).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let acts: Vec<Vec<f64>> = (0..64).map(|_| (0..3 * n).map(|_| rng.random_range(-1.0..1.0)).collect()).collect();
    let mut resets = 0;
    let t0 = Instant::now();
    for k in 0..steps {
        b.step(&acts[k % 64], &seeds, &mut obs, &mut fin, &mut out).unwrap();
        resets += out.iter().filter(|o| o.reset).count();
    }
    let dt = t0.elapsed().as_secs_f64();
    println!("n={n} threads={threads} {:.0} steps/s resets={resets} pts={}", (steps * n) as f64 / dt, b.episodes()[0].shield_points().len() / 3);
    let _ = &mut cfg;
}
