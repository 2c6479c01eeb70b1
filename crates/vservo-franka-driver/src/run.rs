//! The driver's loop: one robot state in, one `joint_state` out, the rmrc's answer (or the command in force)
//! through the guard, one command back to the robot within its cycle.

use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::Context as _;
use vservo_config::{Config, Franka};
use vservo_driver::{DriverSettings, DriverSide, Measured, speed_gained_braking};
use vservo_franka::{Connection, JointVelocityCommand, MotionPhase, RobotState};
use vservo_protocol::{CellMode, CommandMode, DriverError, MAX_JOINTS};

use crate::cell::CellPorts;
use crate::report::Report;
use crate::shaper::{CommandShaper, ShaperLimits};

mod faults;

use faults::{Phase, driver_error, reconnect};

/// How long a connection, a motion's start or a recovery may take.
const ROBOT_TIMEOUT: Duration = Duration::from_secs(2);

/// No robot state for this long: the robot (or the network) is gone.
const STATE_TIMEOUT: Duration = Duration::from_millis(500);

/// With the motion stopped, the driver publishes the arm's state this often (the last one again where the robot
/// sends none).
const IDLE_PERIOD: Duration = Duration::from_millis(1);

/// A fault is reported at least this long, so that the cell's fault monitor sees it (ns).
const FAULT_SHOWN_NS: u64 = 200_000_000;

/// With the robot gone, a new connection is tried this often.
const RECONNECT_EVERY: Duration = Duration::from_secs(1);

/// Runs until `stop` is set, then brings the arm to rest and ends the motion.
pub fn run(
    config: &Config,
    franka: &Franka,
    key: Option<vservo_protocol::seal::SealKey>,
    stop: &AtomicBool,
) -> anyhow::Result<()> {
    let stopped = || vservo_protocol::signals::stopped(stop);
    let waiting = |why: &_| tracing::info!("instance {:?}: {why}; waiting for vservod", config.instance);
    let Some(dir) = vservo_protocol::InstanceDir::locate_until(&config.instance, stopped, waiting)? else {
        return Ok(());
    };
    let mut cell = CellPorts::connect(&config.instance, &dir)?;
    let mut robot = Connection::connect(franka.address, ROBOT_TIMEOUT)
        .map_err(|error| anyhow::anyhow!("{}: {error}", connection_advice(franka.address, &error)))?;
    if robot.server_version() != vservo_franka::PROTOCOL_VERSION {
        tracing::warn!(
            "the Franka at {} took protocol version {} and reports version {} beside its success (a server that lays \
             its reply out otherwise, as franky-sim; libfranka goes on too)",
            franka.address,
            vservo_franka::PROTOCOL_VERSION,
            robot.server_version()
        );
    }
    tracing::info!(
        robot = %franka.address,
        protocol = robot.server_version(),
        limit_rate = franka.limit_rate,
        "driving the instance {:?} with the Franka",
        config.instance
    );
    go_realtime(config);
    let mut driver = Driver::new(config, franka, monotonic_ns(), key);
    driver.start_motion(&mut robot, None)?;
    // with the robot gone: the connection being made again, in a thread of its own (a robot that does not answer
    // makes a connection wait its timeout, and the cell must keep hearing the driver meanwhile)
    let mut reconnecting: Option<std::sync::mpsc::Receiver<Connection>> = None;
    loop {
        let stopping = vservo_protocol::signals::stopped(stop);
        if let Some(connection) = reconnecting.as_ref().and_then(|r| r.try_recv().ok()) {
            robot = connection;
            reconnecting = None;
            driver.reconnected(&robot);
        }
        // a robot that stopped its motion may send no states (franka-sim does not): the driver goes on alone, at
        // its own period, slept (a socket's receive timeout counts in the kernel's ticks: a 1 ms one waited 8 ms
        // here, and the period check took the driver's states for a robot at 125 Hz)
        let moving = driver.moving();
        if !moving {
            std::thread::sleep(IDLE_PERIOD);
        }
        let received = robot.recv_state(if moving { STATE_TIMEOUT } else { Duration::ZERO });
        driver.report.datagrams(robot.dropped());
        let next = match received {
            // connected again, before the new motion: the robot's idle states (franka-sim sends them every 8 ms)
            // update the arm's state, which the driver publishes at its own period, as while the robot was gone
            Ok(state) if driver.connected_again() => {
                driver.note_idle_state(&state);
                driver.cycle_without_robot(&mut robot, &mut cell, stopping)
            }
            Ok(state) if !driver.robot_gone() => driver.cycle(&mut robot, &mut cell, &state, stopping),
            // the robot stopped streaming mid-motion (or its socket failed): it ended the motion (the driver or the
            // network was away), or it went away altogether
            Err(error) if driver.moving() => {
                let why = match error {
                    vservo_franka::RecvStateError::Timeout { waited, .. } => {
                        format!("no robot state for {waited:?}")
                    }
                    other => format!("the robot states failed: {other}"),
                };
                driver.motion_lost(&mut robot, &mut cell, &why);
                Ok(Next::Go)
            }
            // no state (a stopped motion; a robot gone, whose socket may say so by an error)
            _ => driver.cycle_without_robot(&mut robot, &mut cell, stopping),
        };
        let next = match next {
            Ok(next) => next,
            // the robot closed the connection under a call: gone, as a silence with the connection closed is
            Err(error) if !stopping && robot.closed() => {
                driver.connection_lost(&mut cell, &format!("{error:#}"));
                Next::Go
            }
            Err(error) => return Err(error),
        };
        if driver.robot_gone() && reconnecting.is_none() {
            reconnecting = Some(reconnect(franka.address));
        }
        if next == Next::End {
            break;
        }
    }
    driver.report.log("the motion ended; stopping");
    driver.report.summary_line();
    Ok(())
}

/// What a failed connection to the robot at `address` asks the user to check, by its cause.
fn connection_advice(address: std::net::SocketAddr, error: &vservo_franka::ConnectError) -> String {
    use vservo_franka::ConnectError;
    match error {
        ConnectError::IncompatibleVersion { .. } => format!(
            "the Franka at {address} ([franka] address and port) speaks another version of the FCI protocol than \
             this driver (the Panda's version 5 is not supported yet; check the robot's system version)"
        ),
        _ => format!(
            "no Franka answered as an FCI server at {address} ([franka] address and port): check the address, the \
             cable to the Control's LAN port, and that FCI is activated in Desk (the robot unlocked, FCI on)"
        ),
    }
}

/// Memory locked (`[runtime] lock_memory`) and SCHED_FIFO at the rmrc's priority (`[runtime.rmrc]
/// fifo_priority`), where permitted: the robot wants its answer within its millisecond.
fn go_realtime(config: &Config) {
    use nix::sys::mman::{MlockAllFlags, mlockall};
    if config.runtime.lock_memory
        && let Err(error) = mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE)
    {
        tracing::warn!("mlockall not permitted ({error}): a page fault may delay an answer to the robot");
    }
    use thread_priority::{
        RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue, ThreadSchedulePolicy,
        set_thread_priority_and_policy, thread_native_id,
    };
    let priority = config.runtime.rmrc.fifo_priority;
    if priority == 0 {
        return;
    }
    let result = ThreadPriorityValue::try_from(priority).map_err(|e| e.to_string()).and_then(|value| {
        let policy = ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo);
        set_thread_priority_and_policy(thread_native_id(), ThreadPriority::Crossplatform(value), policy)
            .map_err(|e| format!("{e:?}"))
    });
    if let Err(error) = result {
        tracing::warn!(
            "SCHED_FIFO {priority} not permitted ({error}): the normal scheduler answers the robot"
        );
    }
}

use vservo_time::monotonic_ns;

/// Whether the loop goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Next {
    Go,
    End,
}

/// The driver's state between robot states.
struct Driver {
    side: DriverSide,
    limits: ShaperLimits,
    shaper: Option<CommandShaper>,
    limit_rate: bool,
    answer_within_ns: u64,
    origin_id: Option<u64>,
    /// The last joint state's tick and stamp, and what was measured then.
    last: Option<(u64, u64, Measured)>,
    /// Ticks counted by the driver alone (no robot states while the motion was stopped).
    tick_offset: u64,
    phase: Phase,
    report: Report,
}

impl Driver {
    fn new(
        config: &Config,
        franka: &Franka,
        epoch: u64,
        key: Option<vservo_protocol::seal::SealKey>,
    ) -> Self {
        let arm = &config.cell.arm;
        let joints = arm.joint_count();
        let mut settings = DriverSettings {
            mode: CommandMode::Velocity,
            joint_count: joints,
            period_ns: vservo_time::nanos(config.cell.robot.period_s),
            hold_after_ns: vservo_time::nanos(franka.hold_after_s),
            position_min_rad: [f64::NEG_INFINITY; MAX_JOINTS],
            position_max_rad: [f64::INFINITY; MAX_JOINTS],
            velocity_max_rad_s: [f64::INFINITY; MAX_JOINTS],
            braking_gain_rad_s: [0.0; MAX_JOINTS],
        };
        for (j, limits) in arm.limits().enumerate().take(joints) {
            settings.position_min_rad[j] = limits.position_min;
            settings.position_max_rad[j] = limits.position_max;
            settings.velocity_max_rad_s[j] = limits.velocity_max;
        }
        let interpolator = &config.cell.interpolator;
        // no jerk limits (the configuration then refuses limit_rate): the guard is off
        let jerk =
            interpolator.jerk_limit.map_or([f64::INFINITY; MAX_JOINTS], |j| std::array::from_fn(|i| j[i]));
        // kept inside the arm's as the rmrc's reference is (the acceleration limit times the margin's square, the
        // jerk limit times its cube): a reference that keeps them passes unchanged, and the robot's check of the
        // discrete derivatives never meets a limit exactly
        let margin = vservo_arm::LIMIT_MARGIN;
        let limits = ShaperLimits {
            acceleration: std::array::from_fn(|j| interpolator.acceleration_limit[j] * margin * margin),
            jerk: std::array::from_fn(|j| jerk[j] * margin * margin * margin),
            dt_s: config.cell.robot.period_s,
        };
        settings.braking_gain_rad_s =
            std::array::from_fn(|j| speed_gained_braking(limits.acceleration[j], limits.jerk[j]));
        Self {
            side: DriverSide::new(settings, epoch, key),
            limits,
            shaper: None,
            limit_rate: franka.limit_rate,
            answer_within_ns: vservo_time::nanos(franka.answer_within_s),
            origin_id: None,
            last: None,
            tick_offset: 0,
            phase: Phase::Moving,
            report: Report::new(),
        }
    }

    /// Starts a joint-velocity motion (at the start, and after a recovery): the guard starts from the robot's
    /// own desired velocity and acceleration.
    fn start_motion(&mut self, robot: &mut Connection, sequence: Option<u64>) -> anyhow::Result<()> {
        let first =
            robot.start_joint_velocity_motion(ROBOT_TIMEOUT).context("starting a joint-velocity motion")?;
        let joints = self.side.settings().joint_count;
        self.shaper = Some(CommandShaper::new(self.limits, joints, widen(&first.dq_d), widen(&first.ddq_d)));
        self.report.motion_started();
        self.phase = Phase::Moving;
        tracing::info!(after = ?sequence, "the Franka's joint-velocity motion runs");
        Ok(())
    }

    /// One robot state: published, then answered (moving), or the fault and its recovery looked after.
    fn cycle(
        &mut self,
        robot: &mut Connection,
        cell: &mut CellPorts,
        state: &RobotState,
        stopping: bool,
    ) -> anyhow::Result<Next> {
        let received_ns = monotonic_ns();
        let tick = self.tick_of(state);
        if matches!(self.phase, Phase::Moving)
            && let MotionPhase::Aborted { errors } = MotionPhase::of(state)
        {
            self.motion_aborted(robot, cell, errors, received_ns);
        }
        let measured =
            Measured { q_rad: widen(&state.q), qd_rad_s: widen(&state.dq), torque_nm: widen(&state.tau_J) };
        self.publish(cell, tick, received_ns, measured);
        self.report.cycle(state, received_ns);
        match self.phase {
            Phase::Moving => self.answer(robot, cell, state, tick, received_ns, stopping),
            Phase::Faulted { .. } if stopping => Ok(Next::End),
            Phase::Faulted { .. } => self.look_after_fault(robot, cell, received_ns),
        }
    }

    /// A robot state's tick: the robot's own counter (`message_id`) since the first state, moved on past the
    /// ticks the driver counted alone while the robot sent nothing, so that ticks always grow.
    fn tick_of(&mut self, state: &RobotState) -> u64 {
        let counted = state.message_id.saturating_sub(*self.origin_id.get_or_insert(state.message_id));
        let tick = match self.last {
            Some((last_tick, _, _)) => (counted + self.tick_offset).max(last_tick + 1),
            None => counted,
        };
        self.tick_offset = tick - counted;
        tick
    }

    /// Whether a motion runs (every robot state is answered).
    fn moving(&self) -> bool {
        matches!(self.phase, Phase::Moving)
    }

    /// Publishes the joint state of `tick`: a fault while one is shown, else following or holding.
    fn publish(&mut self, cell: &CellPorts, tick: u64, stamp_ns: u64, measured: Measured) {
        let fault = match self.phase {
            // the robot gone: reported until it is connected again, so that a resume is refused with the reason
            Phase::Faulted { reconnected: Some(false), .. } => Some(DriverError::RobotConnectionLost),
            Phase::Faulted { errors, held_at: None, .. } => Some(driver_error(errors)),
            _ => None,
        };
        let joint_state = self.side.joint_state(tick, stamp_ns, &measured, fault);
        if joint_state.driver_error == DriverError::PeriodMismatch.code() {
            self.say_period_mismatch();
        }
        if !cell.publish(joint_state) {
            self.report.publish_failed += 1;
        }
        self.last = Some((tick, stamp_ns, measured));
    }

    /// The first time a joint state reports the period check's fault (the robot's states come at another period
    /// than `[robot] period_s`): an ERROR line naming the measured (the median gap of the last states) and the
    /// configured period. The driver side reports the fault and holds the arm: the cell's `driver_fault`.
    fn say_period_mismatch(&mut self) {
        if self.report.period_said {
            return;
        }
        let Some(measured_ns) = self.side.period_mismatch_ns() else { return };
        self.report.period_said = true;
        tracing::error!(
            measured_ms = measured_ns as f64 / 1e6,
            expected_ms = self.side.settings().period_ns as f64 / 1e6,
            "the Franka's states come every {:.3} ms (the median of the last {} gaps), not every [robot] period_s = \
             {:.3} ms: the driver reports a fault (driver_fault) and holds the arm; a loaded network or host, or \
             another period configured",
            measured_ns as f64 / 1e6,
            vservo_driver::PERIOD_CHECK_GAPS,
            self.side.settings().period_ns as f64 / 1e6
        );
    }

    /// No robot state came while the motion is stopped: the arm's last state again, at rest, its tick advanced by
    /// the periods gone (the cell keeps hearing the driver, and the fault or the hold it reports).
    fn cycle_without_robot(
        &mut self,
        robot: &mut Connection,
        cell: &mut CellPorts,
        stopping: bool,
    ) -> anyhow::Result<Next> {
        let now_ns = monotonic_ns();
        if let Some((tick, stamp_ns, measured)) = self.last {
            let period_ns = self.side.settings().period_ns.max(1);
            let periods = (now_ns.saturating_sub(stamp_ns) / period_ns).max(1);
            let at_rest = Measured { qd_rad_s: [0.0; MAX_JOINTS], ..measured };
            self.publish(cell, tick + periods, stamp_ns + periods * period_ns, at_rest);
        }
        if stopping {
            return Ok(Next::End);
        }
        self.look_after_fault(robot, cell, now_ns)
    }

    /// Moving: the rmrc's answer to `tick` (waited for until `answer_within_s` after the state came), or the
    /// command in force, or rest; through the guard; sent within the cycle. Stopping: rest, then the motion
    /// finished.
    fn answer(
        &mut self,
        robot: &mut Connection,
        cell: &mut CellPorts,
        state: &RobotState,
        tick: u64,
        received_ns: u64,
        stopping: bool,
    ) -> anyhow::Result<Next> {
        if stopping && self.report.speed_at_stop_rad_s.is_none() {
            let last = self.report.last_sent.map_or([0.0; MAX_JOINTS], |(v, _)| v);
            self.report.speed_at_stop_rad_s = Some(last.iter().fold(0.0, |m: f64, v| m.max(v.abs())));
        }
        let answered = self.take_answer(cell, tick, received_ns + self.answer_within_ns);
        if !answered {
            self.report.late_answers += 1;
        }
        let in_force = self.side.apply(monotonic_ns());
        let target = match in_force {
            Some(command) if !stopping => command.values,
            _ => [0.0; MAX_JOINTS],
        };
        let velocity = match (&mut self.shaper, self.limit_rate) {
            (Some(shaper), true) => {
                // the dynamics override in force, as the reference keeps it: a late answer smoothed within it too
                shaper.set_speed_scale(self.side.speed_scale());
                shaper.next(&target)
            }
            _ => target,
        };
        let at_rest = self.shaper.as_ref().is_none_or(|s| !self.limit_rate || s.at_rest());
        if stopping && at_rest && velocity.iter().all(|v| *v == 0.0) {
            robot.finish_motion(state, [0.0; 7], ROBOT_TIMEOUT).context("finishing the motion")?;
            tracing::info!("the arm is at rest and the motion finished");
            return Ok(Next::End);
        }
        let command = JointVelocityCommand::new(std::array::from_fn(|j| velocity[j]));
        let latency = robot.send_command(state, &command).context("answering the robot")?;
        self.report.latency(latency);
        self.report.sent(&velocity, self.limits.dt_s);
        Ok(Next::Go)
    }

    /// The cell's mode as the daemon sealed it, after the newest one published (a forged one is counted and
    /// ignored by the driver side).
    fn cell_mode(&mut self, cell: &mut CellPorts) -> Option<(CellMode, u64)> {
        if let Some(message) = cell.newest_mode() {
            self.side.cell_mode(&message);
        }
        self.side.mode()
    }

    /// Takes the rmrc's commands until one answers `tick` or `deadline_ns` passes; whether it came. The cell's
    /// mode is looked at first: a held cell's commands may only bring the arm to rest.
    fn take_answer(&mut self, cell: &mut CellPorts, tick: u64, deadline_ns: u64) -> bool {
        self.cell_mode(cell);
        loop {
            let mut answered = false;
            let (side, report) = (&mut self.side, &mut self.report);
            let now = monotonic_ns();
            let mut other_schema = 0;
            cell.each_command(&mut other_schema, |command| match side.take_command(&command, now) {
                Ok(()) => answered |= command.answers_tick == tick,
                Err(refused) => report.refused(refused),
            });
            report.commands_refused += other_schema;
            if answered {
                return true;
            }
            if monotonic_ns() >= deadline_ns {
                return false;
            }
            std::thread::sleep(Duration::from_micros(20));
        }
    }
}

/// The robot's single-precision values as the contract's f64 arrays (the slots past seven none).
fn widen(values: &[f64; 7]) -> [f64; MAX_JOINTS] {
    std::array::from_fn(|j| values.get(j).copied().unwrap_or(0.0))
}
