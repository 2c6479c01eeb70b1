//! # vservo-driver — the robot driver's side of the contract
//!
//! docs/DRIVERS.md's rules for a robot driver, written once as a pure, clock-free state machine
//! ([`DriverSide`]) that a driver process feeds with what it sees and the times it sees it at:
//! - the driver's run: its `driver_epoch` (its start) and `period_ns`;
//! - **command admission**, with one age window ([`MAX_COMMAND_AGE_TICKS`]): a `joint_command` is taken only if it
//!   carries the rmrc's seal (the run's key, handed to the drivers vservod starts as to its nodes), is of this
//!   schema, this run (epoch), the declared command mode and joint count, answers one of the last
//!   [`MAX_COMMAND_AGE_TICKS`] + 1 joint states published, is finite, and — while the cell is held (its sealed
//!   `cell_mode` a safe stop) — brings the arm to rest (`held`); each refusal is a [`CommandRefused`] that names
//!   its cause, and an unsealed command holds the arm at once (the rmrc's stream in someone else's hands);
//! - **holding**: no command taken for `hold_after_ns` (vservo gone, stalled or refusing) and the driver holds
//!   the arm at rest, saying so in `driver_status`;
//! - **`applied_command_tick`**: each joint state reports the `answers_tick` of the command applied over the
//!   period that ended with it (2⁶⁴−1 while holding);
//! - **the period check**: the median of the last [`PERIOD_CHECK_GAPS`] gaps between the states' stamps must be
//!   the configured period's (within −25 % and +50 %), else the driver reports a fault and holds;
//! - the position- and velocity-limit bits of `faults`.
//!
//! What the arm is and how it is commanded (a robot's network protocol, a simulator) stays in the driver; the
//! state machine does no I/O, reads no clock and allocates nothing. Of the workspace this crate depends on
//! `vservo-wire` (the schema) only; it also holds the driver and helper processes' logging to stderr ([`logging`]).
//!
//! Its users: the Franka driver (the binary `vservo-franka`, crate `vservo-franka-driver`) and the ROS 2 driver
//! (`vservo_ros2::arm_driver`) run all of it; the simulated plant (`vservo-runtime`'s plant node) its command
//! admission ([`DriverSide::take_command`], after [`DriverSide::published`]), applying only the answer to the tick
//! it just published (the lockstep replays a run tick for tick) with its own torque check; the Python
//! reference drivers' `vservo_driver.refusal` is tied to [`DriverSide::take_command`] by a test that hands both
//! the same commands (tests/tests/python_layout.rs). tests/tests/architecture.rs checks that no other source
//! writes the rule again.

mod held;
mod key;
pub mod logging;
mod period;
mod side;

pub use key::{KeyError, seal_key};
pub use period::{PERIOD_CHECK_GAPS, PeriodCheck};
pub use side::{
    CommandRefused, DriverCounts, DriverSettings, DriverSide, InForce, MAX_COMMAND_AGE_TICKS, Measured,
    speed_gained_braking,
};
