//! `shieldnav-ros2`: the safety shield between a planner and a robot, as a ROS 2 node.
//!
//! `shieldnav-ros2 [--params FILE.yaml] [--ros-args -p name:=value -r from:=to ...]`

use std::sync::atomic::{AtomicBool, Ordering};

use shieldnav_ros2::params::{RawParams, NODE_NAME, PARAMETERS};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--help" || a == "-h") {
        println!("shieldnav-ros2: the composite-CBF safety shield as a ROS 2 node\n");
        println!("usage: shieldnav-ros2 [--params FILE.yaml] [--ros-args [-p name:=value]... [--params-file FILE]... [-r from:=to]... [-r __node:=name]]\n");
        println!("The parameter file has the ROS 2 layout `{NODE_NAME}: {{ros__parameters: {{...}}}}` (or `/**:`).\nParameters:");
        for (name, help) in PARAMETERS {
            println!("  {name:<22} {help}");
        }
        return;
    }
    let params = match RawParams::from_args(args).and_then(|raw| raw.build()) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("shieldnav-ros2: {e}");
            std::process::exit(2);
        }
    };
    let t = &params.topics;
    eprintln!(
        "shieldnav-ros2: node {:?} on domain {}, method {}: scan {:?}, cloud {:?}, nominal {:?}, odom {:?}, imu {:?} -> cmd {:?}, state {:?}",
        params.node_name,
        params.domain_id,
        params.shield.method.name(),
        t.scan,
        t.cloud,
        t.nominal,
        t.odom,
        t.imu,
        t.cmd,
        t.state
    );
    // SIGINT / SIGTERM: stop the loop, which sends one last zero command and leaves the DDS
    // network cleanly
    // SAFETY: the handler only stores to an atomic, which is async-signal-safe.
    unsafe {
        libc::signal(libc::SIGINT, on_signal as *const () as libc::sighandler_t);
        libc::signal(libc::SIGTERM, on_signal as *const () as libc::sighandler_t);
    }
    let node = match shieldnav_ros2::ros::spawn(params) {
        Ok(n) => n,
        Err(e) => {
            eprintln!("shieldnav-ros2: {e}");
            std::process::exit(1);
        }
    };
    while !STOP.load(Ordering::SeqCst) && !node.is_finished() {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    if let Err(e) = node.stop() {
        eprintln!("shieldnav-ros2: {e}");
        std::process::exit(1);
    }
}

static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::SeqCst);
}
