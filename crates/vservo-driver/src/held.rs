//! What a held cell's commands may still ask of the arm: a ramp to rest, or rest. When the cell is held (a safe
//! stop: a fault, the start held, a `stop`), the rmrc ramps its reference to rest within the arm's acceleration
//! and jerk limits and holds it there. So, from the speed in force when the hold began, each joint's commanded
//! speed may still grow by what the ramp gains while its acceleration falls to zero (a²/2j), never turn
//! around, and never grow again past what a later command already asked: its envelope only shrinks.

use vservo_wire::MAX_JOINTS;

use crate::side::CommandRefused;

/// Speeds this small (rad/s) count as rest, of either sign.
const REST_RAD_S: f64 = 1e-9;

/// Each joint's bound while the cell is held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct HeldEnvelope {
    /// The fastest it may go (rad/s).
    speed_max_rad_s: [f64; MAX_JOINTS],
    /// The way it went when the hold began (+1, −1; 0: at rest, either way within the bound).
    direction: [f64; MAX_JOINTS],
    /// What a ramp to rest still gains (rad/s).
    gain_rad_s: [f64; MAX_JOINTS],
}

impl HeldEnvelope {
    /// The envelope of a hold that begins with `speed_rad_s` in force (none: at rest).
    pub(crate) fn from_speed(speed_rad_s: Option<[f64; MAX_JOINTS]>, gain_rad_s: &[f64; MAX_JOINTS]) -> Self {
        let speed = speed_rad_s.unwrap_or([0.0; MAX_JOINTS]);
        Self {
            speed_max_rad_s: std::array::from_fn(|j| speed[j].abs() + gain_rad_s[j]),
            direction: std::array::from_fn(|j| {
                if speed[j].abs() <= REST_RAD_S { 0.0 } else { speed[j].signum() }
            }),
            gain_rad_s: *gain_rad_s,
        }
    }

    /// Whether the velocities `speed_rad_s` (the arm's joints) bring the arm to rest.
    pub(crate) fn admits(&self, speed_rad_s: &[f64]) -> Result<(), CommandRefused> {
        for (joint, speed) in speed_rad_s.iter().enumerate() {
            let envelope_rad_s = self.speed_max_rad_s[joint];
            let turned = self.direction[joint] * speed < 0.0 && speed.abs() > REST_RAD_S;
            if speed.abs() > envelope_rad_s || turned {
                return Err(CommandRefused::NotTowardsRest { joint, speed_rad_s: *speed, envelope_rad_s });
            }
        }
        Ok(())
    }

    /// A command taken: no later one may ask for more than it plus what its ramp still gains.
    pub(crate) fn took(&mut self, speed_rad_s: &[f64]) {
        for (joint, speed) in speed_rad_s.iter().enumerate() {
            let bound = speed.abs() + self.gain_rad_s[joint];
            self.speed_max_rad_s[joint] = self.speed_max_rad_s[joint].min(bound);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GAIN: [f64; MAX_JOINTS] = [0.01; MAX_JOINTS];

    #[test]
    fn from_rest_only_what_a_ramp_gains_is_admitted_either_way() {
        let held = HeldEnvelope::from_speed(None, &GAIN);
        assert!(held.admits(&[0.0; 7]).is_ok());
        assert!(held.admits(&[0.01, -0.01, 0.0, 0.0, 0.0, 0.0, 0.0]).is_ok());
        let takeover = [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(matches!(
            held.admits(&takeover),
            Err(CommandRefused::NotTowardsRest { joint: 0, envelope_rad_s, .. }) if envelope_rad_s == 0.01
        ));
    }

    #[test]
    fn a_ramp_to_rest_is_admitted_and_the_envelope_only_shrinks() {
        let mut speed = [0.0; MAX_JOINTS];
        speed[1] = -0.5;
        let mut held = HeldEnvelope::from_speed(Some(speed), &GAIN);
        // the ramp first gains a little (its acceleration falls to zero), then slows to rest
        for v in [-0.505, -0.509, -0.4, -0.2, -0.05, 0.0] {
            let command = [0.0, v, 0.0, 0.0, 0.0, 0.0, 0.0];
            assert!(held.admits(&command).is_ok(), "{v}");
            held.took(&command);
        }
        for refused in [[0.0, 0.02, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, -0.2, 0.0, 0.0, 0.0, 0.0, 0.0]] {
            assert!(held.admits(&refused).is_err(), "at rest, {refused:?} is no ramp to rest");
        }
        let mut fresh = HeldEnvelope::from_speed(Some(speed), &GAIN);
        assert!(fresh.admits(&[0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0]).is_err(), "turned around");
        assert!(fresh.admits(&[0.0, -0.52, 0.0, 0.0, 0.0, 0.0, 0.0]).is_err(), "faster than the ramp gains");
        fresh.took(&[0.0, -0.3, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!(fresh.admits(&[0.0, -0.45, 0.0, 0.0, 0.0, 0.0, 0.0]).is_err(), "speeding up again");
    }
}
