//! The node on the network: a RustDDS participant, the subscriptions and publishers of
//! [`NodeParams::topics`], and one event loop handing each message to a [`ShieldNode`] and
//! publishing its answers.

use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use futures::channel::{mpsc as fmpsc, oneshot};
use futures::stream::{LocalBoxStream, StreamExt};
use futures::FutureExt;
use ros2_client::{Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Subscription};
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::logic::{Output, ShieldNode};
use crate::msg::{Header, Imu, LaserScan, Odometry, PointCloud2, StringMsg, Time, Twist, TwistStamped};
use crate::params::NodeParams;
use crate::record::{now_ns, Recorder};

/// The QoS of the sensor and odometry subscriptions: best effort, newest only (matches both
/// best-effort "sensor data" and reliable publishers).
pub fn sensor_qos() -> QosProfile {
    QosProfile::subscription_default()
}

/// The QoS of the nominal command subscription: best effort, up to 5 queued.
pub fn command_in_qos() -> QosProfile {
    QosProfile::subscription_default().history(ros2_client::qos::History::KeepLast { depth: 5 })
}

/// The QoS of the published command and state: reliable, keep last 10 (as `rclcpp`'s default).
pub fn command_out_qos() -> QosProfile {
    QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 10 })
}

/// A ROS 2 context on `domain_id` (same-host peers are found over loopback unicast as well as
/// multicast, RustDDS's default).
pub fn context(domain_id: u16) -> Result<Context, String> {
    Context::with_options(ContextOptions::new().domain_id(domain_id)).map_err(|e| format!("cannot create the DDS participant on domain {domain_id}: {e:?}"))
}

/// A topic of the ROS 2 type `package/msg/type_name`.
pub fn topic(node: &mut Node, name: &str, package: &str, type_name: &str, qos: &QosProfile) -> Result<ros2_client::dds::rustdds::Topic, String> {
    let n = Name::parse(name).map_err(|e| format!("topic {name:?}: {e:?}"))?;
    node.create_topic(&n, MessageTypeName::new(package, type_name), qos).map_err(|e| format!("topic {name:?}: {e:?}"))
}

/// A subscription to `name` of the ROS 2 type `package/msg/type_name`.
pub fn subscribe<M: DeserializeOwned + 'static>(node: &mut Node, name: &str, package: &str, type_name: &str, qos: QosProfile) -> Result<Subscription<M>, String> {
    let t = topic(node, name, package, type_name, &qos)?;
    node.create_subscription(&t, Some(qos)).map_err(|e| format!("subscription to {name:?}: {e:?}"))
}

/// A publisher on `name` of the ROS 2 type `package/msg/type_name`.
pub fn advertise<M: Serialize>(node: &mut Node, name: &str, package: &str, type_name: &str, qos: QosProfile) -> Result<Publisher<M>, String> {
    let t = topic(node, name, package, type_name, &qos)?;
    node.create_publisher(&t, Some(qos)).map_err(|e| format!("publisher on {name:?}: {e:?}"))
}

/// A nominal command the node answered: its twist, its header when stamped, and when it came
/// (ns since the epoch, its log time in the recording).
struct Heard {
    twist: Twist,
    header: Option<Header>,
    at: u64,
}

/// The filtered command's publisher: `Twist`, or `TwistStamped`.
enum CommandOut {
    Plain(Publisher<Twist>),
    Stamped(Publisher<TwistStamped>),
}

impl CommandOut {
    /// Publishes `twist` (a stamped command with `header`).
    fn publish(&self, twist: Twist, header: Header) -> Result<(), String> {
        match self {
            CommandOut::Plain(p) => p.publish(twist).map_err(|e| format!("{e:?}")),
            CommandOut::Stamped(p) => p.publish(TwistStamped { header, twist }).map_err(|e| format!("{e:?}")),
        }
    }
}

/// The running node: stop it with [`RunningNode::stop`] (or let it run; dropping the
/// handle leaves it running).
pub struct RunningNode {
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<Result<(), String>>>,
}

impl RunningNode {
    /// Stops the event loop and waits for it.
    pub fn stop(mut self) -> Result<(), String> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> Result<(), String> {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| "the node's thread panicked".to_string())?,
            None => Ok(()),
        }
    }

    /// The node's loop has ended (it ends on [`RunningNode::stop`] only, or an error).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Waits until the node stops (it stops on an error only).
    pub fn join(mut self) -> Result<(), String> {
        if let Some(s) = self.stop.take() {
            // (dropped, the sender would stop the loop)
            std::mem::forget(s);
        }
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| "the node's thread panicked".to_string())?,
            None => Ok(()),
        }
    }
}

impl Drop for RunningNode {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

/// Starts the node on its own thread; returns once its subscriptions and publishers exist.
pub fn spawn(params: NodeParams) -> Result<RunningNode, String> {
    let (ready_tx, ready_rx) = mpsc::channel::<Result<(), String>>();
    let (stop_tx, stop_rx) = oneshot::channel::<()>();
    let thread = std::thread::Builder::new().name("shieldnav-ros2".into()).spawn(move || run(params, stop_rx, ready_tx)).map_err(|e| format!("cannot start the node's thread: {e}"))?;
    match ready_rx.recv() {
        Ok(Ok(())) => Ok(RunningNode { stop: Some(stop_tx), thread: Some(thread) }),
        Ok(Err(e)) => {
            let _ = thread.join();
            Err(e)
        }
        Err(_) => Err(thread.join().map_err(|_| "the node's thread panicked".to_string())?.err().unwrap_or_else(|| "the node stopped".into())),
    }
}

fn boxed<'a, M: DeserializeOwned + 'static>(s: &'a Option<Subscription<M>>) -> futures::stream::Fuse<LocalBoxStream<'a, ros2_client::ReadResult<(M, ros2_client::MessageInfo)>>> {
    match s {
        Some(s) => s.async_stream().boxed_local().fuse(),
        None => futures::stream::pending().boxed_local().fuse(),
    }
}

/// Prints a message when it differs from the last one printed (a bad input repeats at its
/// topic's rate).
#[derive(Default)]
struct Quiet {
    last: String,
}

impl Quiet {
    fn note(&mut self, what: &str) {
        if what != self.last {
            eprintln!("shieldnav-ros2: {what}");
            self.last = what.to_string();
        }
    }
}

/// Runs the node until `stop` fires or is dropped; `ready` hears once the entities exist.
pub fn run(params: NodeParams, stop: oneshot::Receiver<()>, ready: mpsc::Sender<Result<(), String>>) -> Result<(), String> {
    let setup = (|| -> Result<_, String> {
        let ctx = context(params.domain_id)?;
        let name = NodeName::new("/", &params.node_name).map_err(|e| format!("node name {:?}: {e:?}", params.node_name))?;
        let mut node = ctx.new_node(name, NodeOptions::new().enable_rosout(false)).map_err(|e| format!("cannot create the node: {e:?}"))?;
        let t = params.topics.clone();
        let scan: Option<Subscription<LaserScan>> = t.scan.as_deref().map(|n| subscribe(&mut node, n, "sensor_msgs", "LaserScan", sensor_qos())).transpose()?;
        let cloud: Option<Subscription<PointCloud2>> = t.cloud.as_deref().map(|n| subscribe(&mut node, n, "sensor_msgs", "PointCloud2", sensor_qos())).transpose()?;
        let odom: Option<Subscription<Odometry>> = t.odom.as_deref().map(|n| subscribe(&mut node, n, "nav_msgs", "Odometry", sensor_qos())).transpose()?;
        let imu: Option<Subscription<Imu>> = t.imu.as_deref().map(|n| subscribe(&mut node, n, "sensor_msgs", "Imu", sensor_qos())).transpose()?;
        let (nominal, nominal_stamped): (Option<Subscription<Twist>>, Option<Subscription<TwistStamped>>) = if params.nominal_stamped {
            (None, Some(subscribe(&mut node, &t.nominal, "geometry_msgs", "TwistStamped", command_in_qos())?))
        } else {
            (Some(subscribe(&mut node, &t.nominal, "geometry_msgs", "Twist", command_in_qos())?), None)
        };
        let cmd = if params.cmd_stamped {
            CommandOut::Stamped(advertise(&mut node, &t.cmd, "geometry_msgs", "TwistStamped", command_out_qos())?)
        } else {
            CommandOut::Plain(advertise(&mut node, &t.cmd, "geometry_msgs", "Twist", command_out_qos())?)
        };
        let state: Publisher<StringMsg> = advertise(&mut node, &t.state, "std_msgs", "String", command_out_qos())?;
        let spinner = node.spinner().map_err(|e| format!("cannot start the node's spinner: {e:?}"))?;
        let shield = ShieldNode::new(params.clone()).map_err(|e| format!("shield: {e}"))?;
        let recorder = params.record.as_deref().map(|path| Recorder::create(path, &params)).transpose()?;
        Ok((ctx, node, spinner, scan, cloud, odom, imu, nominal, nominal_stamped, cmd, state, shield, recorder))
    })();
    let (ctx, node, spinner, scan, cloud, odom, imu, nominal, nominal_stamped, cmd, state, mut shield, recorder) = match setup {
        Ok(s) => {
            let _ = ready.send(Ok(()));
            s
        }
        Err(e) => {
            let _ = ready.send(Err(e.clone()));
            return Err(e);
        }
    };

    // the watchdog's clock: a thread ticking until the loop is gone
    let (tick_tx, mut ticks) = fmpsc::unbounded::<()>();
    if let Some(period) = params.watchdog_period {
        std::thread::Builder::new()
            .name("shieldnav-ros2-watchdog".into())
            .spawn(move || {
                while tick_tx.unbounded_send(()).is_ok() {
                    std::thread::sleep(period);
                }
            })
            .map_err(|e| format!("cannot start the watchdog: {e}"))?;
    } else {
        drop(tick_tx);
    }

    // the node's background work (ROS graph, discovery info) on its own thread, off the
    // command's path
    std::thread::Builder::new()
        .name("shieldnav-ros2-spinner".into())
        .spawn(move || {
            if let Err(e) = futures::executor::block_on(spinner.spin()) {
                eprintln!("shieldnav-ros2: spinner stopped: {e:?}");
            }
        })
        .map_err(|e| format!("cannot start the spinner: {e}"))?;

    let mut quiet = Quiet::default();
    let mut recording = recorder;
    // `heard`: the nominal command answered (its twist, its header if stamped, when it came)
    let publish = |out: Output, heard: Option<Heard>, quiet: &mut Quiet, recording: &mut Option<Recorder>| {
        if let Some(r) = &out.state.reason {
            quiet.note(&format!("zero command: {r}"));
        } else {
            quiet.note("filtering");
        }
        // a stamped command carries the stamped nominal command's stamp, else the time of sending
        let stamp = heard.as_ref().and_then(|h| h.header.as_ref()).map(|h| h.stamp);
        let header = Header { stamp: stamp.unwrap_or_else(Time::now), frame_id: params.base_frame.clone() };
        if let Err(e) = cmd.publish(out.command, header.clone()) {
            quiet.note(&format!("cannot publish the command: {e}"));
        }
        let json = out.state.to_json();
        // the recording once the command is out (its writes stay off the command's path); off
        // after its first error, the commands go on
        if let Some(r) = recording.as_mut() {
            let written = heard.map_or(Ok(()), |h| r.nominal(h.twist, h.header, h.at)).and_then(|_| r.command(out.command, header, &json, now_ns()));
            if let Err(e) = written {
                quiet.note(&format!("{e}; recording stopped"));
                *recording = None;
            }
        }
        let _ = state.publish(StringMsg { data: json });
    };

    let main = async {
        let (mut scan_s, mut cloud_s, mut odom_s, mut imu_s) = (boxed(&scan), boxed(&cloud), boxed(&odom), boxed(&imu));
        let (mut nominal_s, mut stamped_s) = (boxed(&nominal), boxed(&nominal_stamped));
        let mut stop = stop.fuse();
        loop {
            futures::select! {
                r = scan_s.select_next_some() => {
                    let now = Instant::now();
                    let r = r.map_err(|e| format!("LaserScan not decodable: {e}")).and_then(|(m, _)| shield.on_scan(&m, now));
                    if let Err(e) = r {
                        shield.reject_scan(e.clone());
                        quiet.note(&format!("scan rejected: {e}"));
                    }
                    if params.filter_on_scan { publish(shield.command(now), None, &mut quiet, &mut recording) }
                }
                r = cloud_s.select_next_some() => {
                    let now = Instant::now();
                    let r = r.map_err(|e| format!("PointCloud2 not decodable: {e}")).and_then(|(m, _)| shield.on_cloud(&m, now));
                    if let Err(e) = r {
                        shield.reject_scan(e.clone());
                        quiet.note(&format!("cloud rejected: {e}"));
                    }
                    if params.filter_on_scan { publish(shield.command(now), None, &mut quiet, &mut recording) }
                }
                r = odom_s.select_next_some() => {
                    let r = r.map_err(|e| format!("Odometry not decodable: {e}")).and_then(|(m, _)| shield.on_odometry(&m, Instant::now()));
                    if let Err(e) = r {
                        shield.reject_motion(e.clone());
                        quiet.note(&format!("odometry rejected: {e}"));
                    }
                }
                r = imu_s.select_next_some() => {
                    let r = r.map_err(|e| format!("Imu not decodable: {e}")).and_then(|(m, _)| shield.on_imu(&m, Instant::now()));
                    if let Err(e) = r {
                        shield.reject_motion(e.clone());
                        quiet.note(&format!("IMU rejected: {e}"));
                    }
                }
                r = nominal_s.select_next_some() => {
                    let now = Instant::now();
                    let (out, heard) = match r {
                        Ok((m, _)) => (shield.on_nominal(&m, now), Some(Heard { twist: m, header: None, at: now_ns() })),
                        Err(e) => (shield.reject_nominal(format!("nominal Twist not decodable: {e}"), now), None),
                    };
                    publish(out, heard, &mut quiet, &mut recording);
                }
                r = stamped_s.select_next_some() => {
                    let now = Instant::now();
                    let (out, heard) = match r {
                        Ok((m, _)) => (shield.on_nominal(&m.twist, now), Some(Heard { twist: m.twist, header: Some(m.header), at: now_ns() })),
                        Err(e) => (shield.reject_nominal(format!("nominal TwistStamped not decodable: {e}"), now), None),
                    };
                    publish(out, heard, &mut quiet, &mut recording);
                }
                _ = ticks.select_next_some() => {
                    if let Some(out) = shield.tick(Instant::now()) { publish(out, None, &mut quiet, &mut recording) }
                }
                _ = stop => break,
            }
        }
    };
    futures::executor::block_on(main);
    // a last zero command: the robot is not left with the last filtered one
    let _ = cmd.publish(Twist::default(), Header { stamp: Time::now(), frame_id: params.base_frame.clone() });
    if let Some(r) = recording {
        if let Err(e) = r.finish() {
            eprintln!("shieldnav-ros2: {e}");
        }
    }
    node.stop_spinner();
    drop(node);
    drop(ctx);
    std::thread::sleep(Duration::from_millis(10));
    Ok(())
}
