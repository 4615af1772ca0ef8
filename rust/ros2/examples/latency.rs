//! Message-in → command-out latency of the node over loopback DDS, against a bare echo.
//!
//! `cargo run --release -p shieldnav-ros2 --example latency [-- ITERATIONS [METHOD [RATE_HZ [RUNS]]]]`
//!
//! `RATE_HZ` 0 or absent: each message once the last was answered. `RUNS`: a comma-separated
//! choice of `scan`, `twist`, `echo-scan`, `echo-twist` (default all four).
//!
//! Two messages in, each answered by one command out:
//! - a 1024-beam `LaserScan` (8 KB, sent in fragments): the node runs with `filter_on_scan:
//!   true`, so every scan is filtered against the nominal command held;
//! - a nominal `Twist` (48 B): the node filters it against the scan held.
//!
//! A probe in the same process publishes one message per period (`RATE_HZ`; without it, the
//! next as soon as the last was answered), waits for the command and takes the time between.
//! The same round trips through an echo node (each message answered at once by a zero
//! `Twist`) are what DDS itself costs; the difference is what the node adds. A message whose
//! command has not come 500 ms after it was sent is unanswered (a command coming later is
//! counted as late). Printed: median, p90, p99 of each, and the node's own time without DDS.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{ring_scan, BEAMS};
use std::time::{Duration, Instant};

use futures::{FutureExt, StreamExt};
use ros2_client::{NodeName, NodeOptions, Publisher, Subscription};
use shieldnav_ros2::msg::{LaserScan, Odometry, Twist, Vector3};
use shieldnav_ros2::params::{RawParams, Value};
use shieldnav_ros2::ros::{advertise, command_in_qos, command_out_qos, context, sensor_qos, spawn, subscribe};
use shieldnav_ros2::ShieldNode;

/// A command not come this long after its message is unanswered.
const DEADLINE: Duration = Duration::from_millis(500);
/// Rounds before the timed ones.
const WARM_UP: usize = 50;

/// A 1024-beam 360° scan of a corridor 2 m wide, `shift` moving the walls a little so that
/// no two scans are equal.
fn corridor(shift: f64) -> LaserScan {
    ring_scan(30.0, |a| {
        let (s, c) = a.sin_cos();
        let side = if s.abs() > 1e-6 { (1.0 + shift) / s.abs() } else { f64::INFINITY };
        let end = if c > 1e-6 { 4.0 / c } else { f64::INFINITY };
        side.min(end).min(30.0) as f32
    })
}

fn nominal(k: usize) -> Twist {
    Twist { linear: Vector3 { x: 0.8 + 1e-4 * (k % 50) as f64, y: 0.0, z: 0.0 }, ..Default::default() }
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted.get(((sorted.len().max(1) - 1) as f64 * q).round() as usize).copied().unwrap_or(f64::NAN)
}

/// Round-trip times (µs) of the answered messages, and the unanswered and late counts.
#[derive(Default)]
struct Trips {
    times: Vec<f64>,
    unanswered: usize,
    late: usize,
}

impl Trips {
    fn row(&self, what: &str) -> String {
        let mut v = self.times.clone();
        v.sort_by(f64::total_cmp);
        format!("| {what} | {:.0} | {:.0} | {:.0} | {} | {} |", percentile(&v, 0.5), percentile(&v, 0.9), percentile(&v, 0.99), self.unanswered, self.late)
    }
}

/// A clock ticking every 2 ms while the probe waits (the probe does not spin: it would take a
/// core from the node).
fn ticker() -> futures::channel::mpsc::UnboundedReceiver<()> {
    let (tx, rx) = futures::channel::mpsc::unbounded::<()>();
    std::thread::spawn(move || {
        while tx.unbounded_send(()).is_ok() {
            std::thread::sleep(Duration::from_millis(2));
        }
    });
    rx
}

/// `iterations` round trips: `send(k)` publishes message `k`, `answers` hears the command.
fn round_trips(iterations: usize, period: Option<Duration>, send: impl Fn(usize), answers: &Subscription<Twist>) -> Trips {
    let mut ticks = ticker();
    let mut trips = Trips::default();
    let start = Instant::now();
    for k in 0..iterations + WARM_UP {
        if let Some(p) = period {
            let slot = start + p * k as u32;
            if let Some(wait) = slot.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        // a command here answers an earlier message, already counted unanswered
        while let Ok(Some(_)) = answers.take() {
            trips.late += 1;
        }
        let sent = Instant::now();
        send(k);
        let got = futures::executor::block_on(async {
            loop {
                futures::select! {
                    r = answers.async_take().fuse() => break r.is_ok(),
                    _ = ticks.next() => if sent.elapsed() >= DEADLINE { break false },
                }
            }
        });
        let dt = sent.elapsed().as_secs_f64() * 1e6;
        if k >= WARM_UP {
            if got {
                trips.times.push(dt);
            } else {
                trips.unanswered += 1;
            }
        }
        if period.is_none() {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    std::thread::sleep(Duration::from_millis(100));
    while let Ok(Some(_)) = answers.take() {
        trips.late += 1;
    }
    trips
}

fn wait_until(what: &str, mut send: impl FnMut(), answers: &Subscription<Twist>) {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) {
        send();
        std::thread::sleep(Duration::from_millis(50));
        if matches!(answers.take(), Ok(Some(_))) {
            std::thread::sleep(Duration::from_millis(200));
            while let Ok(Some(_)) = answers.take() {}
            return;
        }
    }
    panic!("{what}: no answer within 60 s: is DDS discovery working on this host?");
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let iterations: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let method = args.get(1).cloned().unwrap_or_else(|| "braking".into());
    let rate: Option<f64> = args.get(2).and_then(|s| s.parse().ok()).filter(|r: &f64| *r > 0.0);
    let period = rate.map(|r| Duration::from_secs_f64(1.0 / r));
    let runs: Vec<String> = args.get(3).map_or_else(|| vec!["scan".into(), "twist".into(), "echo-scan".into(), "echo-twist".into()], |r| r.split(',').map(str::to_owned).collect());
    if let Some(bad) = runs.iter().find(|r| !["scan", "twist", "echo-scan", "echo-twist"].contains(&r.as_str())) {
        eprintln!("latency: unknown run {bad:?} (scan, twist, echo-scan, echo-twist)");
        std::process::exit(2);
    }
    let wanted = |r: &str| runs.iter().any(|x| x == r);
    let domain = 100 + (std::process::id() % 100) as i64;
    let mut raw = RawParams::default();
    raw.set("domain_id", Value::Int(domain))
        .set("method", Value::Str(method.clone()))
        .set("filter_on_scan", Value::Bool(true))
        .set("command_timeout", Value::Float(3600.0))
        .set("scan_timeout", Value::Float(3600.0))
        .set("odom_timeout", Value::Float(3600.0))
        .set("watchdog_rate", Value::Float(0.0));
    let params = raw.build().expect("parameters");

    // the node's own time, no network: translation and shield
    let mut local = ShieldNode::new(params.clone()).expect("shield");
    let t = Instant::now();
    local.on_odometry(&Odometry::default(), t).unwrap();
    local.on_nominal(&nominal(0), t);
    let mut in_node = Vec::new();
    let mut shield_only = Vec::new();
    for k in 0..iterations {
        let scan = corridor(1e-4 * (k % 50) as f64);
        let start = Instant::now();
        local.on_scan(&scan, start).unwrap();
        let out = local.command(start);
        in_node.push(start.elapsed().as_secs_f64() * 1e6);
        shield_only.push(out.state.solve_time_us);
        assert!(out.state.ok, "{:?}", out.state);
    }
    shield_only.sort_by(f64::total_cmp);

    let node = spawn(params).expect("the node starts");
    let ctx = context(domain as u16).expect("participant");
    let mut n = ctx.new_node(NodeName::new("/", "latency_probe").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let scan_pub = advertise::<LaserScan>(&mut n, "/scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
    let odom_pub = advertise::<Odometry>(&mut n, "/odom", "nav_msgs", "Odometry", sensor_qos()).unwrap();
    let nominal_pub = advertise::<Twist>(&mut n, "/cmd_vel_nominal", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    let cmd_sub = subscribe::<Twist>(&mut n, "/cmd_vel", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    wait_until(
        "the node",
        || {
            let _ = odom_pub.publish(Odometry::default());
            let _ = nominal_pub.publish(nominal(0));
            let _ = scan_pub.publish(corridor(0.0));
        },
        &cmd_sub,
    );
    let scans = wanted("scan").then(|| round_trips(iterations, period, |k| drop(scan_pub.publish(corridor(1e-4 * (k % 50) as f64))), &cmd_sub));
    let twists = wanted("twist").then(|| round_trips(iterations, period, |k| drop(nominal_pub.publish(nominal(k))), &cmd_sub));
    drop(n);
    node.stop().expect("the node stops");

    // the echo: each message answered at once by a zero Twist, on the node's QoS
    let echo = std::thread::spawn(move || {
        let ctx = context(domain as u16).expect("participant");
        let mut n = ctx.new_node(NodeName::new("/", "latency_echo").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
        let ping_scan = subscribe::<LaserScan>(&mut n, "/ping_scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
        let ping_twist = subscribe::<Twist>(&mut n, "/ping_twist", "geometry_msgs", "Twist", command_in_qos()).unwrap();
        let pong = advertise::<Twist>(&mut n, "/pong", "geometry_msgs", "Twist", command_out_qos()).unwrap();
        futures::executor::block_on(async {
            let (mut s, mut t) = (Box::pin(ping_scan.async_stream()), Box::pin(ping_twist.async_stream()));
            loop {
                futures::select! {
                    r = s.next() => match r {
                        Some(Ok((m, _))) if m.ranges.is_empty() => break,
                        _ => drop(pong.publish(Twist::default())),
                    },
                    _ = t.next() => drop(pong.publish(Twist::default())),
                }
            }
        });
    });
    let mut n = ctx.new_node(NodeName::new("/", "latency_probe2").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let ping_scan: Publisher<LaserScan> = advertise(&mut n, "/ping_scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
    let ping_twist: Publisher<Twist> = advertise(&mut n, "/ping_twist", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    let pong = subscribe::<Twist>(&mut n, "/pong", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    wait_until(
        "the echo",
        || {
            let _ = ping_scan.publish(corridor(0.0));
            let _ = ping_twist.publish(nominal(0));
        },
        &pong,
    );
    let echo_scans = wanted("echo-scan").then(|| round_trips(iterations, period, |k| drop(ping_scan.publish(corridor(1e-4 * (k % 50) as f64))), &pong));
    let echo_twists = wanted("echo-twist").then(|| round_trips(iterations, period, |k| drop(ping_twist.publish(nominal(k))), &pong));
    let _ = ping_scan.publish(LaserScan::default());
    let _ = ping_scan.publish(LaserScan::default());

    in_node.sort_by(f64::total_cmp);
    let pace = rate.map_or("each message once the last was answered".to_string(), |r| format!("{r} Hz"));
    println!("shieldnav-ros2 over loopback DDS, method {method}, {iterations} messages each, {pace}\n");
    println!("| round trip | median (µs) | p90 (µs) | p99 (µs) | unanswered | late |");
    println!("|---|---:|---:|---:|---:|---:|");
    let scan_name = format!("{BEAMS}-beam LaserScan");
    for (trips, what) in [
        (scans, format!("{scan_name} → node → Twist")),
        (echo_scans, format!("{scan_name} → echo → Twist")),
        (twists, "Twist (48 B) → node → Twist".into()),
        (echo_twists, "Twist (48 B) → echo → Twist".into()),
    ] {
        if let Some(t) = trips {
            println!("{}", t.row(&what));
        }
    }
    println!(
        "\nin the node without DDS (scan → command): median {:.0} µs, p99 {:.0} µs; of which the shield {:.0} µs, {:.0} µs",
        percentile(&in_node, 0.5),
        percentile(&in_node, 0.99),
        percentile(&shield_only, 0.5),
        percentile(&shield_only, 0.99)
    );
    drop(n);
    let _ = echo.join();
}
