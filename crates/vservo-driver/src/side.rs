//! [`DriverSide`]: what a robot driver does with the rmrc's commands and its own joint states.

use vservo_wire::messages::fault_bits;
use vservo_wire::seal::{SealKey, sealed_by};
use vservo_wire::{
    CellMode, CellModeMsg, CommandMode, DriverError, DriverStatus, JointCommandMsg, JointStateMsg,
    MAX_JOINTS, SCHEMA_VERSION,
};

use crate::held::HeldEnvelope;
use crate::period::PeriodCheck;

/// A command must answer the joint state last published or one of the two before it (docs/DRIVERS.md, "When to
/// read the command"): the one age window, whatever the driver and however long it was silent.
pub const MAX_COMMAND_AGE_TICKS: u64 = 2;

/// What the driver is and what it declares.
#[derive(Debug, Clone, PartialEq)]
pub struct DriverSettings {
    /// The command it takes (`command_mode`).
    pub mode: CommandMode,
    /// The arm's joints (6 or 7).
    pub joint_count: usize,
    /// Its period (ns): `[robot] period_s`.
    pub period_ns: u64,
    /// No command taken for this long: hold (ns).
    pub hold_after_ns: u64,
    /// Each joint's lowest angle (rad), for the position-limit bits.
    pub position_min_rad: [f64; MAX_JOINTS],
    /// Each joint's highest angle (rad).
    pub position_max_rad: [f64; MAX_JOINTS],
    /// Each joint's speed limit (rad/s), for the velocity-limit bits.
    pub velocity_max_rad_s: [f64; MAX_JOINTS],
    /// The speed each joint may still gain once a ramp to rest has begun (rad/s): [`speed_gained_braking`]
    /// of its acceleration and jerk limits; what a held cell's commands may add to the speed in force.
    pub braking_gain_rad_s: [f64; MAX_JOINTS],
}

/// The speed a joint still gains while a jerk-limited ramp to rest takes its acceleration (at most
/// `acceleration` rad/s²) down to zero at `jerk` rad/s³: a²/(2j) (zero without a jerk limit, where the
/// acceleration can drop at once).
pub fn speed_gained_braking(acceleration: f64, jerk: f64) -> f64 {
    let gained = acceleration * acceleration / (2.0 * jerk);
    if gained.is_finite() { gained } else { 0.0 }
}

/// Why a `joint_command` is not taken.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum CommandRefused {
    /// It does not carry the seal of the run's key: not the rmrc's (docs/PROTOCOL.md, "Seals"). The driver
    /// holds the arm at once: the rmrc is gone, or someone else writes its stream.
    #[error("it is not sealed by the rmrc (someone else writes joint_command, or this driver has no key)")]
    Unsealed,
    /// The cell is held (a safe stop) and it does not bring the arm to rest: a joint faster than the speed in
    /// force when the hold began (plus what a ramp to rest still gains), or turned around.
    #[error(
        "the cell is held and joint {} would go at {speed_rad_s:.4} rad/s, beyond its ramp to rest (at most {envelope_rad_s:.4} rad/s, same direction)",
        .joint + 1
    )]
    NotTowardsRest {
        /// The joint (zero-based).
        joint: usize,
        /// The speed it asks for (rad/s, signed).
        speed_rad_s: f64,
        /// The most a ramp to rest may ask (rad/s).
        envelope_rad_s: f64,
    },
    /// Another schema's message (docs/PROTOCOL.md's changelog).
    #[error("schema {found}, not this driver's {SCHEMA_VERSION}")]
    Schema {
        /// Its schema.
        found: u32,
    },
    /// It answers another run of the driver (`driver_epoch`): a restarted driver's old commands.
    #[error("it answers another run of the driver (epoch {found}, this run's {expected})")]
    Epoch {
        /// Its epoch.
        found: u64,
        /// This run's.
        expected: u64,
    },
    /// Another command mode than the one declared.
    #[error("command mode {found}, not the declared {expected}")]
    Mode {
        /// Its mode code.
        found: u32,
        /// The declared one's.
        expected: u32,
    },
    /// Another arm's number of joints.
    #[error("{found} joints, not the arm's {expected}")]
    JointCount {
        /// Its joint count.
        found: u32,
        /// The arm's.
        expected: usize,
    },
    /// It answers a joint state not published yet, or came before any was.
    #[error("it answers tick {answers}, which was not published (the last: {last_tick:?})")]
    NotPublished {
        /// The tick it answers.
        answers: u64,
        /// The last tick published.
        last_tick: Option<u64>,
    },
    /// It answers a state older than [`MAX_COMMAND_AGE_TICKS`] before the last published (also after the
    /// driver's own silence: it is as old as its tick says).
    #[error(
        "it answers tick {answers}, more than {MAX_COMMAND_AGE_TICKS} before the last published, {last_tick}"
    )]
    TooOld {
        /// The tick it answers.
        answers: u64,
        /// The last tick published.
        last_tick: u64,
    },
    /// A value the driver would apply is not a finite number.
    #[error("joint {} is not a finite number", .joint + 1)]
    NotFinite {
        /// The joint (zero-based).
        joint: usize,
    },
}

impl CommandRefused {
    /// The kind of refusal, for a log that says each kind once and counts the rest.
    pub fn kind(&self) -> &'static str {
        match self {
            CommandRefused::Unsealed => "unsealed",
            CommandRefused::NotTowardsRest { .. } => "not towards rest",
            CommandRefused::Schema { .. } => "schema",
            CommandRefused::Epoch { .. } => "epoch",
            CommandRefused::Mode { .. } => "mode",
            CommandRefused::JointCount { .. } => "joint count",
            CommandRefused::NotPublished { .. } => "not published",
            CommandRefused::TooOld { .. } => "too old",
            CommandRefused::NotFinite { .. } => "not finite",
        }
    }
}

/// A command taken: the values the driver applies and the state it answers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InForce {
    /// The values of the declared mode (`qd_ref_rad_s`, `q_ref_rad` or `torque_nm`).
    pub values: [f64; MAX_JOINTS],
    /// The `tick` it answers.
    pub answers_tick: u64,
    /// When it was taken (ns).
    pub taken_ns: u64,
}

/// What the driver saw so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DriverCounts {
    /// Joint states made.
    pub states: u64,
    /// Commands taken.
    pub commands_taken: u64,
    /// Commands refused.
    pub commands_refused: u64,
    /// Periods held (no command in force).
    pub holds: u64,
    /// Cell modes not sealed by the daemon: ignored.
    pub modes_refused: u64,
}

/// The driver's side of the contract between its joint states.
#[derive(Debug, Clone)]
pub struct DriverSide {
    settings: DriverSettings,
    epoch: u64,
    /// The last state made: its tick and stamp.
    last: Option<(u64, u64)>,
    in_force: Option<InForce>,
    /// The `answers_tick` of the command applied over the period running (2⁶⁴−1: holding).
    applying: u64,
    period: PeriodCheck,
    /// The run's key: only commands sealed with it are taken (none: nothing is taken).
    key: Option<SealKey>,
    /// The cell's mode as the daemon last sealed it, and its sequence.
    cell: Option<(CellMode, u64)>,
    /// The dynamics override in force (0–1], as the daemon last sealed it (1 before any).
    speed_scale: f64,
    /// While the cell is held: what its commands may still ask of each joint.
    held: Option<HeldEnvelope>,
    /// What happened so far.
    pub counts: DriverCounts,
}

impl DriverSide {
    /// A driver run that starts now: `epoch` is its start time (ns), as docs/DRIVERS.md asks; `key`, the run's
    /// seal key as vservod hands it to the processes it starts (without it no command is taken: none can be
    /// the rmrc's).
    pub fn new(settings: DriverSettings, epoch: u64, key: Option<SealKey>) -> Self {
        Self {
            settings,
            epoch,
            last: None,
            in_force: None,
            applying: u64::MAX,
            period: PeriodCheck::default(),
            key,
            cell: None,
            speed_scale: 1.0,
            held: None,
            counts: DriverCounts::default(),
        }
    }

    /// The cell's mode from the daemon (`cell_mode`): taken when sealed by the daemon and newer than the last.
    /// A safe stop holds the cell: from then until it servos or moves again, a command is taken only if it brings
    /// the arm to rest from the speed in force (velocity commands; see [`CommandRefused::NotTowardsRest`]).
    pub fn cell_mode(&mut self, message: &CellModeMsg) {
        let Ok(mode) = CellMode::try_from(message.mode) else {
            self.counts.modes_refused += 1;
            return;
        };
        if !sealed_by(self.key.as_ref(), message) {
            self.counts.modes_refused += 1;
            return;
        }
        if self.cell.is_some_and(|(_, sequence)| message.sequence <= sequence) {
            return;
        }
        self.cell = Some((mode, message.sequence));
        // a share outside (0, 1] is no override: the one in force stays
        if message.speed_scale > 0.0 && message.speed_scale <= 1.0 {
            self.speed_scale = message.speed_scale;
        }
        self.held = match (mode, self.held) {
            (CellMode::SafeStop, Some(held)) => Some(held),
            (CellMode::SafeStop, None) => Some(HeldEnvelope::from_speed(
                self.in_force.filter(|_| self.settings.mode == CommandMode::Velocity).map(|c| c.values),
                &self.settings.braking_gain_rad_s,
            )),
            _ => None,
        };
    }

    /// The cell's mode as last taken.
    pub fn mode(&self) -> Option<(CellMode, u64)> {
        self.cell
    }

    /// The dynamics override in force (0–1]: the share of the joints' speed, acceleration and jerk limits the
    /// rmrc's reference keeps, as the last cell mode taken says (1 before any); a driver's own guard keeps it too.
    pub fn speed_scale(&self) -> f64 {
        self.speed_scale
    }

    /// This run's `driver_epoch`.
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// What the driver declares.
    pub fn settings(&self) -> &DriverSettings {
        &self.settings
    }

    /// The tick of the last joint state made.
    pub fn last_tick(&self) -> Option<u64> {
        self.last.map(|(tick, _)| tick)
    }

    /// Takes one of the rmrc's commands, taken at `now_ns`, if the contract admits it.
    pub fn take_command(&mut self, command: &JointCommandMsg, now_ns: u64) -> Result<(), CommandRefused> {
        let admitted = self.admit(command);
        match admitted {
            Ok(values) => {
                if let Some(held) = self.held.as_mut() {
                    held.took(&values[..self.settings.joint_count]);
                }
                let answers_tick = command.answers_tick;
                self.in_force = Some(InForce { values, answers_tick, taken_ns: now_ns });
                self.counts.commands_taken += 1;
                Ok(())
            }
            Err(refused) => {
                self.counts.commands_refused += 1;
                if refused == CommandRefused::Unsealed {
                    // the rmrc's stream in someone else's hands: the arm is brought to rest now, not after
                    // hold_after
                    self.in_force = None;
                }
                Err(refused)
            }
        }
    }

    fn admit(&self, command: &JointCommandMsg) -> Result<[f64; MAX_JOINTS], CommandRefused> {
        let s = &self.settings;
        if !sealed_by(self.key.as_ref(), command) {
            return Err(CommandRefused::Unsealed);
        }
        if command.schema != SCHEMA_VERSION {
            return Err(CommandRefused::Schema { found: command.schema });
        }
        if command.driver_epoch != self.epoch {
            return Err(CommandRefused::Epoch { found: command.driver_epoch, expected: self.epoch });
        }
        if command.mode != s.mode.code() {
            return Err(CommandRefused::Mode { found: command.mode, expected: s.mode.code() });
        }
        if command.joint_count as usize != s.joint_count {
            return Err(CommandRefused::JointCount { found: command.joint_count, expected: s.joint_count });
        }
        let answers = command.answers_tick;
        let last_tick = match self.last_tick() {
            Some(last) if answers <= last => last,
            last_tick => return Err(CommandRefused::NotPublished { answers, last_tick }),
        };
        if answers + MAX_COMMAND_AGE_TICKS < last_tick {
            return Err(CommandRefused::TooOld { answers, last_tick });
        }
        let values = match s.mode {
            CommandMode::Velocity => command.qd_ref_rad_s,
            CommandMode::Position => command.q_ref_rad,
            CommandMode::Torque => command.torque_nm,
        };
        if let Some(joint) = values[..s.joint_count].iter().position(|v| !v.is_finite()) {
            return Err(CommandRefused::NotFinite { joint });
        }
        if let Some(held) = &self.held
            && s.mode == CommandMode::Velocity
        {
            held.admits(&values[..s.joint_count])?;
        }
        Ok(values)
    }

    /// The command to apply over the period that starts at `now_ns`: the one in force, if it was taken within
    /// `hold_after_ns`; `None`: hold the arm at rest. The next joint state reports it.
    pub fn apply(&mut self, now_ns: u64) -> Option<InForce> {
        let fresh =
            self.in_force.filter(|c| now_ns.saturating_sub(c.taken_ns) <= self.settings.hold_after_ns);
        if fresh.is_none() {
            self.hold();
        } else {
            self.applying = fresh.map_or(u64::MAX, |c| c.answers_tick);
        }
        fresh
    }

    /// Holds the arm whatever came (a fault, the end, the period's mismatch): no command in force.
    pub fn hold(&mut self) {
        self.in_force = None;
        self.applying = u64::MAX;
        self.counts.holds += 1;
    }

    /// The median gap between the joint states (ns) when it is not the configured period's: the driver then
    /// reports a fault and holds the arm.
    pub fn period_mismatch_ns(&self) -> Option<u64> {
        self.period.mismatch(self.settings.period_ns)
    }

    /// The joint state of `tick`, measured at `stamp_ns` (CLOCK_MONOTONIC): the command applied over the
    /// period that ended with it, the status (a fault when `fault` is given — with the robot's reason —, or when
    /// the period is not the configured one; holding when no command was applied) and the limit bits. Ticks must
    /// grow.
    pub fn joint_state(
        &mut self,
        tick: u64,
        stamp_ns: u64,
        measured: &Measured,
        fault: Option<DriverError>,
    ) -> JointStateMsg {
        self.published(tick, stamp_ns);
        // the robot's own reason first; else the period check's
        let fault = fault.or_else(|| self.period_mismatch_ns().map(|_| DriverError::PeriodMismatch));
        let status = if fault.is_some() {
            DriverStatus::Fault
        } else if self.applying == u64::MAX {
            DriverStatus::Holding
        } else {
            DriverStatus::Following
        };
        let s = &self.settings;
        JointStateMsg {
            schema: SCHEMA_VERSION,
            faults: self.limit_bits(&measured.q_rad, &measured.qd_rad_s),
            tick,
            stamp_ns,
            driver_epoch: self.epoch,
            period_ns: s.period_ns,
            command_mode: s.mode.code(),
            driver_status: status.code(),
            joint_count: s.joint_count as u32,
            driver_error: fault.unwrap_or(DriverError::None).code(),
            q_rad: measured.q_rad,
            qd_rad_s: measured.qd_rad_s,
            torque_nm: measured.torque_nm,
            applied_command_tick: self.applying,
        }
    }

    /// A joint state of `tick` published at `stamp_ns` by a driver that writes its own message (the simulated
    /// plant, whose status and faults are its simulation's): the commands answering it, and the two before it,
    /// are admitted from now on. [`DriverSide::joint_state`] does this itself.
    pub fn published(&mut self, tick: u64, stamp_ns: u64) {
        if let Some((_, last_ns)) = self.last {
            self.period.add(stamp_ns.saturating_sub(last_ns));
        }
        self.last = Some((tick, stamp_ns));
        self.counts.states += 1;
    }

    /// The position- and velocity-limit bits of the configured arm (docs/DRIVERS.md, `faults`).
    fn limit_bits(&self, q_rad: &[f64; MAX_JOINTS], qd_rad_s: &[f64; MAX_JOINTS]) -> u32 {
        let s = &self.settings;
        (0..s.joint_count).fold(0, |bits, j| {
            // NaN is outside: it lies in no range
            let position = !(s.position_min_rad[j]..=s.position_max_rad[j]).contains(&q_rad[j])
                || q_rad[j] == s.position_min_rad[j]
                || q_rad[j] == s.position_max_rad[j];
            let velocity = !(0.0..=s.velocity_max_rad_s[j]).contains(&qd_rad_s[j].abs());
            bits | (u32::from(position) << (fault_bits::POSITION_LIMIT_SHIFT + j as u32))
                | (u32::from(velocity) << (fault_bits::VELOCITY_LIMIT_SHIFT + j as u32))
        })
    }
}

/// What the driver measured of the arm at a joint state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Joint angles (rad).
    pub q_rad: [f64; MAX_JOINTS],
    /// Joint speeds (rad/s).
    pub qd_rad_s: [f64; MAX_JOINTS],
    /// Joint torques (N·m; NaN where not measured).
    pub torque_nm: [f64; MAX_JOINTS],
}

#[cfg(test)]
mod tests;
