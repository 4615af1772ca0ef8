//! `Node`: the ROS 2 node's decisions (`shieldnav_ros2::ShieldNode`) without the network, fed
//! message by message with the time each arrived: what `shieldnav replay` runs a recording
//! through, so that a replay decides exactly as the node would have.

use std::time::{Duration, Instant};

use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use shieldnav_ros2::msg::{Header, Imu, LaserScan, Odometry, PointCloud2, PointField, Time, Twist, Vector3};
use shieldnav_ros2::{Output, RawParams, ShieldNode};

use crate::errors::{invalid, to_py};

/// The node's decisions, fed by hand (`shieldnav.replay`). Each ``on_*`` takes the time the
/// message arrived, in seconds on any clock that does not go below zero (a recording's).
#[pyclass(name = "Node", module = "shieldnav._core", unsendable)]
pub struct PyNode {
    node: ShieldNode,
    origin: Instant,
}

fn vector(v: [f64; 3]) -> Vector3 {
    Vector3 { x: v[0], y: v[1], z: v[2] }
}

fn header(frame_id: &str) -> Header {
    Header { stamp: Time::default(), frame_id: frame_id.to_owned() }
}

fn answer(out: Output) -> ([f64; 6], String) {
    (out.state.command, out.state.to_json())
}

/// The values of a 1-D `float32` array, whatever its strides and alignment: a recording's
/// decoder may hand out views into its byte buffer at any offset, which an `ndarray` view must
/// not be made of.
fn floats(a: &PyReadonlyArray1<'_, f32>) -> Vec<f32> {
    let n = a.len();
    let stride = a.strides()[0];
    let base = a.data() as *const u8;
    (0..n)
        .map(|i| {
            // SAFETY: the array holds `n` items `stride` bytes apart from `base` and stays
            // borrowed read-only (`PyReadonlyArray1`) while they are read; `read_unaligned`
            // needs no alignment.
            unsafe { std::ptr::read_unaligned(base.offset(i as isize * stride) as *const f32) }
        })
        .collect()
}

impl PyNode {
    /// The instant of time `t` (s): a clock's readings as `Instant`s, `t = 0` at construction.
    fn at(&self, t: f64) -> PyResult<Instant> {
        if !t.is_finite() || !(0.0..1e12).contains(&t) {
            return Err(invalid("t", format!("the arrival time must be finite, ≥ 0 and below 1e12 s, got {t}")));
        }
        Ok(self.origin + Duration::from_secs_f64(t))
    }
}

#[pymethods]
impl PyNode {
    /// ``Node(args)``: the node's command line (``["--params", "shield.yaml", "--ros-args",
    /// "-p", "method:=braking", "-r", "/scan:=/front/scan"]``), checked as the node checks it.
    #[new]
    #[pyo3(signature = (args=Vec::new()))]
    fn new(args: Vec<String>) -> PyResult<Self> {
        let params = RawParams::from_args(args).and_then(|raw| raw.build()).map_err(|e| invalid("args", e))?;
        let node = ShieldNode::new(params).map_err(to_py)?;
        Ok(Self { node, origin: Instant::now() })
    }

    /// The topics the node reads and writes (remaps applied; ``None``: switched off) and
    /// whether the nominal and the sent command are ``TwistStamped``s.
    fn topics<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.node.params();
        let t = &p.topics;
        let d = PyDict::new(py);
        d.set_item("scan", t.scan.clone())?;
        d.set_item("cloud", t.cloud.clone())?;
        d.set_item("nominal", t.nominal.clone())?;
        d.set_item("odom", t.odom.clone())?;
        d.set_item("imu", t.imu.clone())?;
        d.set_item("cmd", t.cmd.clone())?;
        d.set_item("state", t.state.clone())?;
        d.set_item("nominal_stamped", p.nominal_stamped)?;
        d.set_item("cmd_stamped", p.cmd_stamped)?;
        Ok(d)
    }

    /// The body as the node sees it: ``base_frame``, the sensor's ``mount`` ``(x, y, z,
    /// yaw)``, the braking check's ``footprint`` vertices ``[[x, y], ...]`` and the
    /// ellipse's ``semi_axes`` (m, rad; body frame).
    fn body<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.node.params();
        let d = PyDict::new(py);
        let m = &p.mount;
        d.set_item("base_frame", &p.base_frame)?;
        d.set_item("mount", (m.translation[0], m.translation[1], m.translation[2], m.yaw))?;
        d.set_item("footprint", p.shield.braking.footprint.vertices().iter().map(|v| [v[0], v[1]]).collect::<Vec<_>>())?;
        d.set_item("semi_axes", p.shield.semi_axes.clone())?;
        Ok(d)
    }

    /// The held scan's returns, body frame, shape ``(n, 3)`` (m; a copy): empty when no scan
    /// is held or the last was rejected.
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pts = self.node.points();
        numpy::ndarray::Array2::from_shape_vec((pts.len() / 3, 3), pts.to_vec()).map(|a| a.into_pyarray(py)).map_err(|e| invalid("points", e.to_string()))
    }

    /// The shield's method (``"braking"``, ``"composite"``, ...).
    #[getter]
    fn method(&self) -> &'static str {
        self.node.params().shield.method.name()
    }

    /// The scan/command timeouts and the watchdog period (s; ``None``: off).
    fn timeouts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.node.params();
        let d = PyDict::new(py);
        d.set_item("scan", p.scan_timeout.as_secs_f64())?;
        d.set_item("command", p.command_timeout.as_secs_f64())?;
        d.set_item("odom", p.odom_timeout.as_secs_f64())?;
        d.set_item("watchdog", p.watchdog_period.map(|w| w.as_secs_f64()))?;
        d.set_item("filter_on_scan", p.filter_on_scan)?;
        Ok(d)
    }

    /// A ``sensor_msgs/LaserScan`` that arrived at ``t``; the reason it was rejected, or None.
    #[pyo3(signature = (t, frame_id, angle_min, angle_max, angle_increment, range_min, range_max, ranges, intensities=None, time_increment=0.0, scan_time=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn on_scan(
        &mut self,
        t: f64,
        frame_id: &str,
        angle_min: f32,
        angle_max: f32,
        angle_increment: f32,
        range_min: f32,
        range_max: f32,
        ranges: PyReadonlyArray1<'_, f32>,
        intensities: Option<PyReadonlyArray1<'_, f32>>,
        time_increment: f32,
        scan_time: f32,
    ) -> PyResult<Option<String>> {
        let now = self.at(t)?;
        let msg = LaserScan {
            header: header(frame_id),
            angle_min,
            angle_max,
            angle_increment,
            time_increment,
            scan_time,
            range_min,
            range_max,
            ranges: floats(&ranges),
            intensities: intensities.map(|i| floats(&i)).unwrap_or_default(),
        };
        Ok(self.node.on_scan(&msg, now).err())
    }

    /// A ``sensor_msgs/PointCloud2`` that arrived at ``t``: ``fields`` as ``(name, offset,
    /// datatype, count)``; the reason it was rejected, or None.
    #[pyo3(signature = (t, frame_id, height, width, fields, is_bigendian, point_step, row_step, data, is_dense=true))]
    #[allow(clippy::too_many_arguments)]
    fn on_cloud(
        &mut self,
        t: f64,
        frame_id: &str,
        height: u32,
        width: u32,
        fields: Vec<(String, u32, u8, u32)>,
        is_bigendian: bool,
        point_step: u32,
        row_step: u32,
        data: Vec<u8>,
        is_dense: bool,
    ) -> PyResult<Option<String>> {
        let now = self.at(t)?;
        let fields = fields.into_iter().map(|(name, offset, datatype, count)| PointField { name, offset, datatype, count }).collect();
        let msg = PointCloud2 { header: header(frame_id), height, width, fields, is_bigendian, point_step, row_step, data, is_dense };
        Ok(self.node.on_cloud(&msg, now).err())
    }

    /// A scan or cloud that could not be decoded: the robot stops until a valid one arrives.
    fn reject_scan(&mut self, reason: String) {
        self.node.reject_scan(reason);
    }

    /// ``nav_msgs/Odometry``'s twist (body frame) at ``t``; the reason it was rejected, or None.
    fn on_odometry(&mut self, t: f64, linear: [f64; 3], angular: [f64; 3]) -> PyResult<Option<String>> {
        let now = self.at(t)?;
        let mut msg = Odometry::default();
        msg.twist.twist = Twist { linear: vector(linear), angular: vector(angular) };
        Ok(self.node.on_odometry(&msg, now).err())
    }

    /// ``sensor_msgs/Imu``'s angular velocity at ``t``; the reason it was rejected, or None.
    fn on_imu(&mut self, t: f64, angular_velocity: [f64; 3]) -> PyResult<Option<String>> {
        let now = self.at(t)?;
        let msg = Imu { angular_velocity: vector(angular_velocity), ..Imu::default() };
        Ok(self.node.on_imu(&msg, now).err())
    }

    /// An odometry or IMU message that could not be decoded.
    fn reject_motion(&mut self, reason: String) {
        self.node.reject_motion(reason);
    }

    /// A nominal ``Twist`` at ``t``: the command the node sends, ``[vx, vy, vz, wx, wy, wz]``,
    /// and its state topic's JSON text.
    fn on_nominal(&mut self, t: f64, linear: [f64; 3], angular: [f64; 3]) -> PyResult<([f64; 6], String)> {
        let now = self.at(t)?;
        let msg = Twist { linear: vector(linear), angular: vector(angular) };
        Ok(answer(self.node.on_nominal(&msg, now)))
    }

    /// A nominal command that could not be decoded, at ``t``: zero and the reason.
    fn reject_nominal(&mut self, t: f64, reason: String) -> PyResult<([f64; 6], String)> {
        let now = self.at(t)?;
        Ok(answer(self.node.reject_nominal(reason, now)))
    }

    /// The watchdog at ``t``: the zero command and its state when the nominal command is
    /// missing or stale, else None.
    fn tick(&mut self, t: f64) -> PyResult<Option<([f64; 6], String)>> {
        let now = self.at(t)?;
        Ok(self.node.tick(now).map(answer))
    }

    /// The command for the inputs held at ``t`` (what ``filter_on_scan`` sends on a scan).
    fn command(&mut self, t: f64) -> PyResult<([f64; 6], String)> {
        let now = self.at(t)?;
        Ok(answer(self.node.command(now)))
    }
}

/// Adds `Node` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyNode>()
}
