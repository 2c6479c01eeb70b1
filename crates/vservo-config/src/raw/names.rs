//! Every name a key takes, as a serde enum (an unknown name is a parser error naming the key and listing the
//! accepted names), with the setting each names where a stage takes it.

use serde::Deserialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawTargetKind {
    Marks,
    AprilTag,
    Bundle,
}

/// The tag families vservo renders and detects: tag36h11 only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum RawTagFamily {
    #[serde(rename = "tag36h11")]
    Tag36h11,
}

/// `plant.kinematic_follows`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawKinematicFollows {
    #[default]
    Position,
    Velocity,
}

/// `robot.arm.preset`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawArmPreset {
    Puma560,
    Custom,
    Urdf,
}

/// `camera.source`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawCameraSource {
    #[default]
    Simulated,
    External,
    Directory,
    Ros2,
    Gstreamer,
}

/// `camera.mount`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawCameraMount {
    #[default]
    Hand,
    World,
}

/// `robot.start`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawStart {
    Held,
    Servoing,
}

/// `robot.driver`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawRobotDriver {
    Simulated,
    External,
    Ros2,
    Franka,
}

/// `controller.law`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RawLaw {
    Paper,
    DelayAware,
    Pbvs,
    PbvsTarget,
    #[serde(rename = "2.5d")]
    TwoAndAHalfD,
}

impl From<RawLaw> for vservo_settings::control::ControlLaw {
    fn from(law: RawLaw) -> Self {
        match law {
            RawLaw::Paper => Self::Paper,
            RawLaw::DelayAware => Self::DelayAware,
            RawLaw::Pbvs => Self::Pbvs,
            RawLaw::PbvsTarget => Self::PbvsTarget,
            RawLaw::TwoAndAHalfD => Self::TwoAndAHalfD,
        }
    }
}

/// `controller.r_units`.
#[derive(Debug, Clone, Copy, Deserialize)]
pub enum RawInputUnits {
    #[serde(rename = "mm-mrad")]
    MillimetreMilliradian,
    #[serde(rename = "si")]
    Si,
}

impl From<RawInputUnits> for vservo_settings::weights::InputUnits {
    fn from(units: RawInputUnits) -> Self {
        match units {
            RawInputUnits::MillimetreMilliradian => Self::MillimetreMilliradian,
            RawInputUnits::Si => Self::Si,
        }
    }
}

/// `controller.interaction`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawInteraction {
    Desired,
    Mean,
    Current,
}

impl From<RawInteraction> for vservo_settings::control::Interaction {
    fn from(interaction: RawInteraction) -> Self {
        match interaction {
            RawInteraction::Desired => Self::Desired,
            RawInteraction::Mean => Self::Mean,
            RawInteraction::Current => Self::Current,
        }
    }
}

/// `plant.mode`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawPlantMode {
    Dynamic,
    Kinematic,
}

impl From<RawPlantMode> for vservo_settings::simulation::PlantMode {
    fn from(mode: RawPlantMode) -> Self {
        match mode {
            RawPlantMode::Dynamic => Self::Dynamic,
            RawPlantMode::Kinematic => Self::Kinematic,
        }
    }
}

/// `interpolator.twist_hold`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RawTwistHold {
    ZeroOrder,
    Linear,
}

impl From<RawTwistHold> for vservo_settings::simulation::TwistHold {
    fn from(hold: RawTwistHold) -> Self {
        match hold {
            RawTwistHold::ZeroOrder => Self::ZeroOrder,
            RawTwistHold::Linear => Self::Linear,
        }
    }
}

/// `joint_servo.law`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RawJointServoLaw {
    ComputedTorque,
    PdGravity,
}

impl From<RawJointServoLaw> for vservo_settings::simulation::JointServoLaw {
    fn from(law: RawJointServoLaw) -> Self {
        match law {
            RawJointServoLaw::ComputedTorque => Self::ComputedTorque,
            RawJointServoLaw::PdGravity => Self::PdGravity,
        }
    }
}

/// `scenario.object_motion` (the motion's numbers are keys of their own).
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RawObjectMotion {
    Hold,
    Step,
    Circle,
}
