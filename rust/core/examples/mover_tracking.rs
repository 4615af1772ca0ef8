//! The mover tracker against the simulator's truth: pedestrians walking head-on at, across and
//! along the path of a robot cruising down a hall (the robot driven through the default
//! braking shield). For every step with a reported mover, the velocity error against the
//! nearest pedestrian's true velocity; the tracker's time per scan; false movers (reported
//! more than 1 m from every pedestrian).
//!
//!     cargo run --release -p shieldnav-core --example mover_tracking

use std::time::Instant;

use shieldnav_core::env::{Episode, EpisodeConfig, Site};
use shieldnav_core::sensors::{MoverTracker, MoverTrackerConfig};
use shieldnav_core::world::{MovingObstacle, Polygon, Pose2, Scenario, Segment, StaticMap, Trajectory};

fn hall(walks: &[(&[[f64; 2]], f64)]) -> Site {
    let mut map = StaticMap::new();
    let c = [[-20.0, -8.0], [40.0, -8.0], [40.0, 8.0], [-20.0, 8.0]];
    for k in 0..4 {
        map.add_segment(Segment::new(c[k], c[(k + 1) % 4], 2.0)).unwrap();
    }
    let mut s = Scenario::new("movers", map, Pose2::new(0.0, 0.0, 0.0));
    for (i, (w, speed)) in walks.iter().enumerate() {
        s.obstacles.push(MovingObstacle { name: format!("walker-{i}"), shape: Polygon::rect(-0.25, -0.25, 0.25, 0.25, 1.8), trajectory: Trajectory::walk(w, *speed, 0.0).unwrap() });
    }
    Site::Scenario(Box::new(s))
}

fn main() {
    let sites = [
        ("head-on", hall(&[(&[[14.0, 0.3], [-19.0, 0.3]], 1.5)])),
        ("crossing", hall(&[(&[[6.0, -7.0], [6.0, 7.0]], 1.3), (&[[12.0, 7.0], [12.0, -7.0]], 1.2)])),
        ("along", hall(&[(&[[3.0, 2.0], [39.0, 2.0]], 1.2), (&[[-6.0, -2.0], [39.0, -2.0]], 1.5)])),
    ];
    let (mut errors, mut false_movers, mut reports) = (Vec::new(), 0usize, 0usize);
    for (name, site) in sites {
        let mut ep = Episode::new(site, EpisodeConfig::default(), 0).unwrap();
        let (mut e_site, mut n) = (Vec::new(), 0);
        for _ in 0..1000 {
            let r = ep.step([0.5, 0.0, 0.0]).unwrap();
            if !r.scanned {
                continue;
            }
            let pose = ep.world().true_pose();
            let t = ep.world().time();
            for m in ep.movers() {
                n += 1;
                let c = pose.transform_point(m.centre);
                let (s, co) = pose.yaw.sin_cos();
                let v = [co * m.velocity[0] - s * m.velocity[1], s * m.velocity[0] + co * m.velocity[1]];
                let truth = ep.world().scenario().obstacles.iter().map(|o| {
                    let (a, b) = (o.trajectory.pose_at(t - 0.05), o.trajectory.pose_at(t + 0.05));
                    (((a.x + b.x) / 2.0 - c[0]).hypot((a.y + b.y) / 2.0 - c[1]), [(b.x - a.x) / 0.1, (b.y - a.y) / 0.1])
                });
                let (d, tv) = truth.min_by(|a, b| a.0.total_cmp(&b.0)).unwrap();
                if d > 1.0 {
                    false_movers += 1;
                } else {
                    e_site.push((v[0] - tv[0]).hypot(v[1] - tv[1]));
                }
            }
        }
        e_site.sort_by(f64::total_cmp);
        let q = |p: f64| e_site.get(((e_site.len() as f64 - 1.0) * p) as usize).copied().unwrap_or(f64::NAN);
        println!("{name:9} mover reports {n:5}: velocity error median {:.3} m/s, 95th percentile {:.3} m/s", q(0.5), q(0.95));
        reports += n;
        errors.extend(e_site);
    }
    errors.sort_by(f64::total_cmp);
    let q = |p: f64| errors[((errors.len() as f64 - 1.0) * p) as usize];
    println!("all       mover reports {reports:5}: velocity error median {:.3} m/s, 95th percentile {:.3} m/s; false movers {false_movers}", q(0.5), q(0.95));

    // the tracker's time per scan: a 1024-beam scan of the hall with two pedestrians
    let site = hall(&[(&[[14.0, 0.3], [-19.0, 0.3]], 1.5), (&[[6.0, -7.0], [6.0, 7.0]], 1.3)]);
    let mut ep = Episode::new(site, EpisodeConfig { track_movers: false, ..EpisodeConfig::default() }, 0).unwrap();
    let mut scans = Vec::new();
    for _ in 0..500 {
        if ep.step([0.5, 0.0, 0.0]).unwrap().scanned {
            scans.push((ep.world().scan().points.clone(), ep.world().estimated_pose(), ep.world().time()));
        }
    }
    let mut tracker = MoverTracker::new(MoverTrackerConfig::default()).unwrap();
    let rounds = 200;
    let start = Instant::now();
    for r in 0..rounds {
        tracker.reset();
        for (k, (pts, pose, _)) in scans.iter().enumerate() {
            std::hint::black_box(tracker.update(pts, *pose, (r * scans.len() + k) as f64 * 0.1).unwrap());
        }
    }
    let per = start.elapsed().as_secs_f64() / (rounds * scans.len()) as f64;
    println!("tracker: {:.1} µs per 1024-beam scan ({} scans × {rounds})", per * 1e6, scans.len());
}
