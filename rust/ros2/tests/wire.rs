//! The messages' wire format: CDR as RustDDS (and every ROS 2 middleware) writes it, field by
//! field in the `.msg` order with CDR alignment. The sizes are worked out by hand from the
//! message definitions, so a field out of order or of the wrong width shows.

use byteorder::LittleEndian;
use serde::de::DeserializeOwned;
use serde::Serialize;
use shieldnav_ros2::msg::{Header, Imu, LaserScan, Odometry, PointCloud2, PointField, StringMsg, Twist, TwistStamped, Vector3};

fn round_trip<T: Serialize + DeserializeOwned + PartialEq + std::fmt::Debug>(m: &T) -> usize {
    let bytes = cdr_encoding::to_vec::<T, LittleEndian>(m).unwrap();
    let (back, used) = cdr_encoding::from_bytes::<T, LittleEndian>(&bytes).unwrap();
    assert_eq!(&back, m);
    assert_eq!(used, bytes.len());
    bytes.len()
}

#[test]
fn message_sizes_follow_the_msg_definitions() {
    // 6 float64
    assert_eq!(round_trip(&Twist { linear: Vector3 { x: 1.0, y: 2.0, z: 3.0 }, angular: Vector3 { x: 4.0, y: 5.0, z: 6.0 } }), 48);
    // stamp 8, frame_id "" (4 + 1), pad to 16, twist 48
    assert_eq!(round_trip(&TwistStamped::default()), 64);
    // header 13 | child_frame_id at 16: 5 → 21 | pose at 24: 24 + 32 + 288 → 368 | twist 48 + 288 → 704
    assert_eq!(round_trip(&Odometry::default()), 704);
    // header 13 | quaternion at 16: 32 + 72 | ω 24 + 72 | a 24 + 72 → 312
    assert_eq!(round_trip(&Imu::default()), 312);
    // header "laser" 8 + 4 + 6 = 18 | 7 float32 at 20 → 48 | ranges 4 + 12 → 64 | intensities 4 → 68
    let scan = LaserScan { header: Header { frame_id: "laser".into(), ..Default::default() }, ranges: vec![1.0, f32::NAN, f32::INFINITY], ..Default::default() };
    let bytes = cdr_encoding::to_vec::<LaserScan, LittleEndian>(&scan).unwrap();
    assert_eq!(bytes.len(), 68);
    let (back, _) = cdr_encoding::from_bytes::<LaserScan, LittleEndian>(&bytes).unwrap();
    assert_eq!(back.ranges[0], 1.0);
    assert!(back.ranges[1].is_nan() && back.ranges[2].is_infinite());
    // std_msgs/String: 4 + "hi\0"
    assert_eq!(round_trip(&StringMsg { data: "hi".into() }), 7);
}

#[test]
fn point_cloud_data_is_one_length_and_the_bytes() {
    // header 13 | height at 16, width → 24 | fields: 4 → 28, "x" 4 + 2 → 34, offset at 36 → 40,
    // datatype → 41, count at 44 → 48 | is_bigendian → 49 | point_step at 52, row_step → 60 |
    // data 4 + 5 → 69 | is_dense → 70
    let c = PointCloud2 {
        height: 1,
        width: 1,
        fields: vec![PointField { name: "x".into(), offset: 0, datatype: PointField::FLOAT32, count: 1 }],
        point_step: 4,
        row_step: 4,
        data: vec![1, 2, 3, 4, 5],
        ..Default::default()
    };
    assert_eq!(round_trip(&c), 70);
    let bytes = cdr_encoding::to_vec::<PointCloud2, LittleEndian>(&c).unwrap();
    assert_eq!(&bytes[60..69], &[5, 0, 0, 0, 1, 2, 3, 4, 5]);
}

#[test]
fn truncated_bytes_do_not_decode() {
    let bytes = cdr_encoding::to_vec::<LaserScan, LittleEndian>(&LaserScan { ranges: vec![1.0; 100], ..Default::default() }).unwrap();
    for cut in [0, 10, 40, bytes.len() - 1] {
        assert!(cdr_encoding::from_bytes::<LaserScan, LittleEndian>(&bytes[..cut]).is_err(), "cut at {cut}");
    }
}
