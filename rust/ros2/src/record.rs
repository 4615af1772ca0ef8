//! The node's own recording (`record` parameter): every nominal command it heard, every
//! command it sent and its state, as an MCAP file in the ros2 profile (CDR messages with
//! `ros2msg` schemas) that Foxglove and `ros2 bag` open beside the robot's own bag.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use byteorder::LittleEndian;
use serde::Serialize;

use crate::msg::{Header, StringMsg, Twist, TwistStamped};
use crate::params::NodeParams;

/// CDR encapsulation of a little-endian ROS 2 message (`CDR_LE`, no options).
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
const SEPARATOR: &str = "\n================================================================================\n";
const VECTOR3: &str = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z";
const TWIST: &str = "Vector3 linear\nVector3 angular";
const HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id";
const TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec";

/// One of the node's topics in the recording: its channel, and whether it is stamped.
#[derive(Debug, Clone, Copy)]
struct Channel {
    id: u16,
    stamped: bool,
}

/// The recording being written; [`Recorder::finish`] writes its summary (dropped unfinished,
/// the file lacks its index but its messages read).
pub struct Recorder {
    writer: mcap::Writer<BufWriter<File>>,
    nominal: Channel,
    cmd: Channel,
    state: u16,
    sequence: u32,
    buffer: Vec<u8>,
}

fn schema_text(stamped: bool) -> String {
    if stamped {
        ["std_msgs/Header header\nTwist twist", HEADER, TIME, &format!("MSG: geometry_msgs/Twist\n{TWIST}"), VECTOR3].join(SEPARATOR)
    } else {
        [TWIST, VECTOR3].join(SEPARATOR)
    }
}

fn error(what: &str, path: &Path, e: impl std::fmt::Display) -> String {
    format!("record {}: {what}: {e}", path.display())
}

impl Recorder {
    /// Creates the MCAP file `path` (an existing file is an error) with the node's nominal,
    /// command and state topics.
    pub fn create(path: &Path, params: &NodeParams) -> Result<Self, String> {
        let file = File::options().write(true).create_new(true).open(path).map_err(|e| error("cannot create the file", path, e))?;
        let options = mcap::WriteOptions::new().profile("ros2").compression(None).library(concat!("shieldnav-ros2 ", env!("CARGO_PKG_VERSION")));
        let mut writer = options.create(BufWriter::new(file)).map_err(|e| error("cannot start the MCAP", path, e))?;
        let mut channel = |topic: &str, stamped: bool| -> Result<Channel, String> {
            let (name, text) = if stamped { ("geometry_msgs/msg/TwistStamped", schema_text(true)) } else { ("geometry_msgs/msg/Twist", schema_text(false)) };
            let schema = writer.add_schema(name, "ros2msg", text.as_bytes()).map_err(|e| error("schema", path, e))?;
            let id = writer.add_channel(schema, topic, "cdr", &BTreeMap::new()).map_err(|e| error("channel", path, e))?;
            Ok(Channel { id, stamped })
        };
        let t = &params.topics;
        let nominal = channel(&t.nominal, params.nominal_stamped)?;
        let cmd = channel(&t.cmd, params.cmd_stamped)?;
        let schema = writer.add_schema("std_msgs/msg/String", "ros2msg", b"string data").map_err(|e| error("schema", path, e))?;
        let state = writer.add_channel(schema, &t.state, "cdr", &BTreeMap::new()).map_err(|e| error("channel", path, e))?;
        Ok(Self { writer, nominal, cmd, state, sequence: 0, buffer: Vec::new() })
    }

    fn write<M: Serialize>(&mut self, channel: u16, msg: &M, log_time: u64) -> Result<(), String> {
        self.buffer.clear();
        self.buffer.extend_from_slice(&CDR_LE);
        // (CDR aligns from the payload's start, which the serializer counts from)
        cdr_encoding::to_writer::<M, LittleEndian, _>(&mut self.buffer, msg).map_err(|e| format!("record: cannot serialize: {e}"))?;
        self.sequence = self.sequence.wrapping_add(1);
        let header = mcap::records::MessageHeader { channel_id: channel, sequence: self.sequence, log_time, publish_time: log_time };
        self.writer.write_to_known_channel(&header, &self.buffer).map_err(|e| format!("record: cannot write: {e}"))
    }

    fn twist(&mut self, channel: Channel, twist: Twist, header: Header, log_time: u64) -> Result<(), String> {
        if channel.stamped {
            self.write(channel.id, &TwistStamped { header, twist }, log_time)
        } else {
            self.write(channel.id, &twist, log_time)
        }
    }

    /// The nominal command heard at `log_time` (ns since the epoch), with its header if stamped.
    pub fn nominal(&mut self, twist: Twist, header: Option<Header>, log_time: u64) -> Result<(), String> {
        self.twist(self.nominal, twist, header.unwrap_or_default(), log_time)
    }

    /// The command sent at `log_time` (a stamped one with `header`) and the state beside it.
    pub fn command(&mut self, twist: Twist, header: Header, state: &str, log_time: u64) -> Result<(), String> {
        self.twist(self.cmd, twist, header, log_time)?;
        self.write(self.state, &StringMsg { data: state.to_owned() }, log_time)
    }

    /// Writes the summary and index and closes the file.
    pub fn finish(mut self) -> Result<(), String> {
        self.writer.finish().map(|_| ()).map_err(|e| format!("record: cannot finish the MCAP: {e}"))
    }
}

/// Now, in ns since the epoch (an MCAP's log time).
pub fn now_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}
