//! One writer per stream (docs/PROTOCOL.md, "One writer per stream"): the daemon created every service with
//! one writer slot (`vservo_protocol::writers`); here it looks, a few times a second, at who holds them. A
//! live process holding the slot of a stream the daemon or one of its nodes writes, that is neither, has
//! taken the stream: the fault `stream_taken`, with a line naming the stream and the process. The robot
//! driver's and the camera's streams have no designed process when they are external (the user's): there
//! the one-writer rule is the protection, and the daemon names the process that holds the slot when it
//! changes. A node that cannot create its port because the slot is held exits with [`SLOT_TAKEN_EXIT`],
//! which is the same fault rather than a silent crash loop.

use std::time::{Duration, Instant};

use nix::errno::Errno;
use nix::sys::signal::kill;
use nix::unistd::Pid;
use vservo_protocol::NodeRole;
use vservo_protocol::writers::{WatchedStream, Writer};

use super::node::NodeRecord;

/// The exit code of a node whose port was refused because its slots are held (EX_PROTOCOL).
pub const SLOT_TAKEN_EXIT: u8 = 76;

/// How often the writers are looked at.
const LOOK_EVERY: Duration = Duration::from_millis(250);

/// Which processes may hold a stream's writer slot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Designed {
    /// These processes (the daemon, or its node of that role).
    Pids(Vec<i32>),
    /// The user's process (an external robot driver or camera): whoever holds the slot.
    External,
}

/// Who may write `writer`'s stream: `daemon_pid`, the supervised nodes' pids, or, for the robot driver's and
/// camera's streams when they are the user's, anyone.
pub fn designed<'a>(
    writer: Writer,
    daemon_pid: i32,
    nodes: impl Iterator<Item = &'a NodeRecord> + Clone,
    external_robot: bool,
    external_camera: bool,
) -> Designed {
    let pid_of = |role: NodeRole| {
        nodes.clone().filter(|n| n.role == role).filter_map(|n| n.pid).map(|pid| pid as i32).collect()
    };
    match writer {
        Writer::Daemon => Designed::Pids(vec![daemon_pid]),
        Writer::Node(role) => Designed::Pids(pid_of(role)),
        Writer::AnyNode => Designed::Pids(nodes.filter_map(|n| n.pid).map(|pid| pid as i32).collect()),
        Writer::RobotDriver if external_robot => Designed::External,
        Writer::RobotDriver => Designed::Pids(pid_of(NodeRole::Plant)),
        Writer::Camera if external_camera => Designed::External,
        Writer::Camera => Designed::Pids(pid_of(NodeRole::Vision)),
    }
}

/// The writers of a stream that are live processes other than its designed ones (a dead process's slot is
/// a leftover the cleanup frees, not a writer).
pub fn foreign(designed: &Designed, writers: &[i32], alive: impl Fn(i32) -> bool) -> Vec<i32> {
    match designed {
        Designed::External => Vec::new(),
        Designed::Pids(pids) => writers.iter().copied().filter(|w| !pids.contains(w) && alive(*w)).collect(),
    }
}

/// Whether process `pid` exists (one of another user counts).
fn alive(pid: i32) -> bool {
    !matches!(kill(Pid::from_raw(pid), None), Err(Errno::ESRCH))
}

/// The name the kernel keeps for a process (`/proc/<pid>/comm`), for the log.
fn command_name(pid: i32) -> String {
    std::fs::read_to_string(format!("/proc/{pid}/comm")).map_or_else(|_| "?".into(), |c| c.trim().to_string())
}

/// The daemon's watch over the writers of every stream.
pub struct StreamWatch {
    streams: Vec<WatchedStream>,
    daemon_pid: i32,
    external_robot: bool,
    external_camera: bool,
    /// Per stream: the foreign writers last found, and the external writer last named.
    foreign_found: Vec<Vec<i32>>,
    external_named: Vec<Option<i32>>,
    next_look: Instant,
    pids: Vec<i32>,
}

impl StreamWatch {
    /// Watches `streams` (every service of the instance, created by the daemon).
    pub fn new(
        streams: Vec<WatchedStream>,
        external_robot: bool,
        external_camera: bool,
        now: Instant,
    ) -> Self {
        let count = streams.len();
        Self {
            streams,
            daemon_pid: std::process::id() as i32,
            external_robot,
            external_camera,
            foreign_found: vec![Vec::new(); count],
            external_named: vec![None; count],
            next_look: now,
            pids: Vec::new(),
        }
    }

    /// Looks at the writers when due; whether a stream is taken (as of the latest look).
    pub fn cycle<'a>(&mut self, nodes: impl Iterator<Item = &'a NodeRecord> + Clone, now: Instant) -> bool {
        if now >= self.next_look {
            self.next_look = now + LOOK_EVERY;
            self.look(nodes);
        }
        self.taken()
    }

    /// Whether a live foreign process holds a writer slot (as of the latest look).
    pub fn taken(&self) -> bool {
        self.foreign_found.iter().any(|found| !found.is_empty())
    }

    fn look<'a>(&mut self, nodes: impl Iterator<Item = &'a NodeRecord> + Clone) {
        for (index, stream) in self.streams.iter().enumerate() {
            stream.writer_pids(&mut self.pids);
            let designed = designed(
                stream.writer,
                self.daemon_pid,
                nodes.clone(),
                self.external_robot,
                self.external_camera,
            );
            let found = foreign(&designed, &self.pids, alive);
            for pid in found.iter().filter(|pid| !self.foreign_found[index].contains(pid)) {
                tracing::error!(
                    stream = stream.name,
                    pid,
                    command = command_name(*pid),
                    "stream taken: a process that is not the stream's writer holds its writer slot"
                );
            }
            self.foreign_found[index] = found;
            if designed == Designed::External {
                let writer = self.pids.iter().copied().find(|pid| alive(*pid));
                if writer.is_some() && writer != self.external_named[index] {
                    let pid = writer.unwrap_or(0);
                    tracing::info!(stream = stream.name, pid, command = command_name(pid), "written by");
                }
                self.external_named[index] = writer;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::supervisor::restart::RestartPolicy;

    fn records() -> Vec<NodeRecord> {
        let policy = RestartPolicy::new(Duration::from_millis(100), Duration::from_secs(1), Instant::now());
        let mut servo = NodeRecord::started(NodeRole::Servo, 30, policy);
        servo.ended(-9, Instant::now());
        vec![
            NodeRecord::started(NodeRole::Plant, 10, policy),
            NodeRecord::started(NodeRole::Rmrc, 20, policy),
            servo,
            NodeRecord::started(NodeRole::Vision, 40, policy),
        ]
    }

    #[test]
    fn each_stream_is_written_by_its_own_process_only() {
        let nodes = records();
        let of = |writer, robot, camera| designed(writer, 1, nodes.iter(), robot, camera);
        assert_eq!(of(Writer::Daemon, false, false), Designed::Pids(vec![1]));
        assert_eq!(of(Writer::Node(NodeRole::Rmrc), false, false), Designed::Pids(vec![20]));
        assert_eq!(of(Writer::Node(NodeRole::Servo), false, false), Designed::Pids(vec![]), "servo is down");
        assert_eq!(of(Writer::AnyNode, false, false), Designed::Pids(vec![10, 20, 40]));
        assert_eq!(of(Writer::RobotDriver, false, false), Designed::Pids(vec![10]));
        assert_eq!(of(Writer::RobotDriver, true, false), Designed::External);
        assert_eq!(of(Writer::Camera, false, false), Designed::Pids(vec![40]));
        assert_eq!(of(Writer::Camera, false, true), Designed::External);
    }

    #[test]
    fn a_live_process_in_a_slot_not_its_own_is_foreign_a_dead_one_is_a_leftover() {
        let designed = Designed::Pids(vec![20]);
        let live = |pid: i32| pid != 66;
        assert_eq!(foreign(&designed, &[20], live), Vec::<i32>::new());
        assert_eq!(foreign(&designed, &[77], live), vec![77]);
        assert_eq!(foreign(&designed, &[66], live), Vec::<i32>::new(), "dead: cleaned up next");
        assert_eq!(foreign(&Designed::Pids(vec![]), &[77], live), vec![77], "taken while its node restarts");
        assert_eq!(foreign(&Designed::External, &[77], live), Vec::<i32>::new());
    }
}
