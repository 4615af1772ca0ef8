//! Scan-in → command-out latency of the node over loopback DDS, for 1024-beam scans.
//!
//! `cargo run --release -p shieldnav-ros2 --example latency [-- ITERATIONS [METHOD]]`
//!
//! The node runs with `filter_on_scan: true`, so every scan is filtered against the nominal
//! command held and a command goes out; a fake robot in the same process publishes a scan,
//! waits for the command and takes the time between (publish to receipt: DDS both ways,
//! the decode, the translation, the shield, the encode). It prints the median and the 90th
//! and 99th percentiles, the node's own time (message in to command out, without DDS), and
//! the shield's time alone.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{ring_scan, BEAMS};
use std::time::{Duration, Instant};

use futures::{FutureExt, StreamExt};
use ros2_client::{NodeName, NodeOptions};
use shieldnav_ros2::msg::{LaserScan, Odometry, StringMsg, Twist, Vector3};
use shieldnav_ros2::params::{RawParams, Value};
use shieldnav_ros2::ros::{advertise, command_out_qos, context, sensor_qos, spawn, subscribe};
use shieldnav_ros2::ShieldNode;

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

fn percentile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn report(what: &str, mut v: Vec<f64>) {
    v.sort_by(f64::total_cmp);
    println!("{what:<44} median {:8.1} µs   p90 {:8.1} µs   p99 {:8.1} µs   (n = {})", percentile(&v, 0.5), percentile(&v, 0.9), percentile(&v, 0.99), v.len());
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let iterations: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let method = args.get(1).cloned().unwrap_or_else(|| "braking".into());
    let domain = 100 + (std::process::id() % 100) as i64;
    let mut raw = RawParams::default();
    raw.set("domain_id", Value::Int(domain))
        .set("method", Value::Str(method.clone()))
        .set("filter_on_scan", Value::Bool(true))
        .set("command_timeout", Value::Float(3600.0))
        .set("odom_timeout", Value::Float(3600.0))
        .set("watchdog_rate", Value::Float(0.0));
    let params = raw.build().expect("parameters");

    // the node's own time, no network: translation and shield
    let mut local = ShieldNode::new(params.clone()).expect("shield");
    let t = Instant::now();
    local.on_odometry(&Odometry::default(), t).unwrap();
    local.on_nominal(&Twist { linear: Vector3 { x: 0.8, y: 0.0, z: 0.0 }, ..Default::default() }, t);
    let (mut in_node, mut shield) = (Vec::new(), Vec::new());
    for k in 0..iterations {
        let scan = corridor(1e-4 * (k % 50) as f64);
        let start = Instant::now();
        local.on_scan(&scan, start).unwrap();
        let out = local.command(start);
        in_node.push(start.elapsed().as_secs_f64() * 1e6);
        assert!(out.state.ok, "{:?}", out.state);
        shield.push(out.state.solve_time_us);
    }

    let node = spawn(params).expect("the node starts");
    let ctx = context(domain as u16).expect("participant");
    let mut n = ctx.new_node(NodeName::new("/", "latency_probe").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let scan_pub = advertise::<LaserScan>(&mut n, "/scan", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
    let odom_pub = advertise::<Odometry>(&mut n, "/odom", "nav_msgs", "Odometry", sensor_qos()).unwrap();
    let nominal_pub = advertise::<Twist>(&mut n, "/cmd_vel_nominal", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    let cmd_sub = subscribe::<Twist>(&mut n, "/cmd_vel", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    let state_sub = subscribe::<StringMsg>(&mut n, "/shieldnav/state", "std_msgs", "String", command_out_qos()).unwrap();
    let nominal = Twist { linear: Vector3 { x: 0.8, y: 0.0, z: 0.0 }, ..Default::default() };

    // discovery: until a filtered command comes back
    let start = Instant::now();
    let mut ready = false;
    while start.elapsed() < Duration::from_secs(60) && !ready {
        let _ = odom_pub.publish(Odometry::default());
        let _ = nominal_pub.publish(nominal);
        let _ = scan_pub.publish(corridor(0.0));
        std::thread::sleep(Duration::from_millis(50));
        while let Ok(Some((s, _))) = state_sub.take() {
            ready |= s.data.contains("\"ok\":true");
        }
    }
    assert!(ready, "no filtered command within 60 s: is DDS discovery working on this host?");
    std::thread::sleep(Duration::from_millis(200));
    while let Ok(Some(_)) = cmd_sub.take() {}
    while let Ok(Some(_)) = state_sub.take() {}

    // waits for the command without spinning (the probe would take a core from the node); a
    // tick every 500 ms ends a wait for a command that does not come
    let (tick_tx, mut ticks) = futures::channel::mpsc::unbounded::<()>();
    std::thread::spawn(move || {
        while tick_tx.unbounded_send(()).is_ok() {
            std::thread::sleep(Duration::from_millis(500));
        }
    });
    let mut round = Vec::new();
    let mut lost = 0;
    for k in 0..iterations + 50 {
        let scan = corridor(1e-4 * (k % 50) as f64);
        let sent = Instant::now();
        let _ = scan_pub.publish(scan);
        while ticks.try_recv().is_ok() {}
        let got = futures::executor::block_on(async {
            futures::select! {
                r = cmd_sub.async_take().fuse() => r.is_ok(),
                _ = ticks.next() => false,
            }
        });
        let dt = sent.elapsed().as_secs_f64() * 1e6;
        if !got {
            // its command may still come: let it, and drop it
            lost += 1;
            std::thread::sleep(Duration::from_millis(100));
            while let Ok(Some(_)) = cmd_sub.take() {}
        } else if k >= 50 {
            round.push(dt);
        }
        while let Ok(Some(_)) = state_sub.take() {}
        std::thread::sleep(Duration::from_millis(2));
    }
    drop(n);
    node.stop().expect("the node stops");

    // the same round trip through an echo (a LaserScan in, a zero Twist out at once): what
    // DDS itself costs on this host
    let echo = std::thread::spawn(move || {
        let ctx = context(domain as u16).expect("participant");
        let mut n = ctx.new_node(NodeName::new("/", "latency_echo").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
        let ping = subscribe::<LaserScan>(&mut n, "/ping", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
        let pong = advertise::<Twist>(&mut n, "/pong", "geometry_msgs", "Twist", command_out_qos()).unwrap();
        futures::executor::block_on(async {
            let mut s = Box::pin(ping.async_stream());
            while let Some(r) = s.next().await {
                match r {
                    Ok((m, _)) if m.ranges.is_empty() => break,
                    _ => {
                        let _ = pong.publish(Twist::default());
                    }
                }
            }
        });
    });
    let mut n = ctx.new_node(NodeName::new("/", "latency_probe2").unwrap(), NodeOptions::new().enable_rosout(false)).unwrap();
    let ping = advertise::<LaserScan>(&mut n, "/ping", "sensor_msgs", "LaserScan", sensor_qos()).unwrap();
    let pong = subscribe::<Twist>(&mut n, "/pong", "geometry_msgs", "Twist", command_out_qos()).unwrap();
    let start = Instant::now();
    let mut ready = false;
    while start.elapsed() < Duration::from_secs(60) && !ready {
        let _ = ping.publish(corridor(0.0));
        std::thread::sleep(Duration::from_millis(50));
        ready = matches!(pong.take(), Ok(Some(_)));
    }
    std::thread::sleep(Duration::from_millis(200));
    while let Ok(Some(_)) = pong.take() {}
    let mut echo_round = Vec::new();
    for k in 0..iterations + 50 {
        let scan = corridor(1e-4 * (k % 50) as f64);
        let sent = Instant::now();
        let _ = ping.publish(scan);
        while ticks.try_recv().is_ok() {}
        let got = futures::executor::block_on(async {
            futures::select! {
                r = pong.async_take().fuse() => r.is_ok(),
                _ = ticks.next() => false,
            }
        });
        let dt = sent.elapsed().as_secs_f64() * 1e6;
        if !got {
            std::thread::sleep(Duration::from_millis(100));
            while let Ok(Some(_)) = pong.take() {}
        } else if k >= 50 {
            echo_round.push(dt);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = ping.publish(LaserScan::default());
    let _ = ping.publish(LaserScan::default());

    println!("shieldnav-ros2 latency, {BEAMS}-beam LaserScan, method {method}, {iterations} scans");
    report("scan published → command received (DDS)", round);
    if !echo_round.is_empty() {
        report("the same through an echo (DDS alone)", echo_round);
    }
    report("in the node: scan → command (no DDS)", in_node);
    report("the shield alone (ShieldOutcome)", shield);
    if lost > 0 {
        println!("{lost} scans got no command within 500 ms");
    }
    drop(n);
    let _ = echo.join();
}
