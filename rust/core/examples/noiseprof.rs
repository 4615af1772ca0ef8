use rand::{SeedableRng, RngCore};
use rand_chacha::ChaCha8Rng;
use shieldnav_core::sensors::noise::*;
use std::time::Instant;
fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut out = vec![0.0f64; 1024];
    let mut bytes = vec![0u8; 8192];
    for _ in 0..3 {
    let t = Instant::now();
    for _ in 0..10000 { fill_standard_normal(&mut rng, &mut out); }
    println!("normal block {:.2} us", t.elapsed().as_secs_f64() / 10000.0 * 1e6);
    let t = Instant::now();
    for _ in 0..10000 { rng.fill_bytes(&mut bytes); }
    println!("fill_bytes {:.2} us", t.elapsed().as_secs_f64() / 10000.0 * 1e6);
    let t = Instant::now();
    let mut s = 0.0;
    for _ in 0..10000 { for _ in 0..1024 { s += standard_normal(&mut rng); } }
    println!("single {:.2} us {s}", t.elapsed().as_secs_f64() / 10000.0 * 1e6);
    }
}
