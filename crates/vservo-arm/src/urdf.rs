//! An arm from its URDF: the serial chain between a base link and a tool link, read with the `urdf-rs`
//! parser, fixed joints folded into the moving joints' origins.
//!
//! A text beyond the bounds of [`crate::urdf_bounds`] (size, nesting, elements, a DOCTYPE) is refused before it is
//! parsed; two links or two joints of one name, or a joint naming a link the file does not declare, after.
//! What vservo cannot honour is refused with the joint (or link) and why: a prismatic, floating, planar or
//! mimic joint on the chain, a tool link that is not below the base link, a tree that branches where the tool
//! link was left to be found, a link with two parents, an axis of zero length, fewer than six or more than
//! seven moving joints. Position and speed limits come from the file; a continuous joint has no position
//! limits, and a joint whose `<limit>` is missing or empty has none at all: those are reported as missing
//! ([`UrdfArm::position_limits`]), for the configuration to give or refuse.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{Rotation3, Translation3, Unit, Vector3};
use urdf_rs::JointType;

use crate::Transform;
use crate::chain::{Chain, ChainJoint, MAX_CHAIN_JOINTS, MIN_CHAIN_JOINTS};

/// Why a URDF does not give an arm vservo can drive.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum UrdfError {
    /// The file could not be read or is not a URDF.
    #[error("{path}: {message}")]
    Read {
        /// The file.
        path: String,
        /// The parser's message.
        message: String,
    },
    /// The text is beyond what a URDF is read up to (`crate::urdf_bounds`): refused before it is parsed.
    #[error("{path}: {bound}")]
    OutOfBounds {
        /// The file.
        path: String,
        /// The bound it breaks.
        bound: crate::urdf_bounds::Bound,
    },
    /// Two links, or two joints, have one name.
    #[error("two {what} are named {name:?}")]
    Duplicate {
        /// "links" or "joints".
        what: &'static str,
        /// The name.
        name: String,
    },
    /// A joint names a parent or child link the file does not declare.
    #[error("joint {joint:?} names link {link:?}, which the file does not declare")]
    UndeclaredLink {
        /// The joint.
        joint: String,
        /// The link it names.
        link: String,
    },
    /// A link named in the configuration is not in the file.
    #[error("no link named {link:?} (links: {known})")]
    NoSuchLink {
        /// The name asked for.
        link: String,
        /// The links the file has, for the message.
        known: String,
    },
    /// The file has several root links and no base link was named.
    #[error("the tree has several roots ({roots}): name the base link (robot.arm.base_link)")]
    SeveralRoots {
        /// The root links.
        roots: String,
    },
    /// Two joints have the same child link: not a tree.
    #[error("link {link:?} is the child of two joints ({first:?} and {second:?})")]
    TwoParents {
        /// The link.
        link: String,
        /// One joint.
        first: String,
        /// The other.
        second: String,
    },
    /// The tool link was left to be found and the tree branches below the base.
    #[error("the tree branches at link {link:?} (to {children}): name the tool link (robot.arm.tip_link)")]
    Branches {
        /// The link with several child joints.
        link: String,
        /// The links it branches to.
        children: String,
    },
    /// The tool link does not hang below the base link.
    #[error("link {tip:?} is not below link {base:?}")]
    TipNotBelowBase {
        /// The base link.
        base: String,
        /// The tool link.
        tip: String,
    },
    /// A joint on the chain is of a kind vservo cannot drive.
    #[error("joint {joint:?} is {kind}: {why}")]
    Unsupported {
        /// The joint.
        joint: String,
        /// Its type.
        kind: &'static str,
        /// Why it cannot be honoured.
        why: &'static str,
    },
    /// A joint's axis has zero length.
    #[error("joint {joint:?}: its axis has zero length")]
    ZeroAxis {
        /// The joint.
        joint: String,
    },
    /// A number of a joint on the chain is not finite.
    #[error("joint {joint:?}: its {what} is not finite")]
    NotFinite {
        /// The joint.
        joint: String,
        /// Which number ("origin", "axis", "limit").
        what: &'static str,
    },
    /// The chain has too few or too many moving joints.
    #[error(
        "the chain from {base:?} to {tip:?} has {count} moving joints ({joints}); vservo drives arms of {MIN_CHAIN_JOINTS} or {MAX_CHAIN_JOINTS}"
    )]
    JointCount {
        /// The base link.
        base: String,
        /// The tool link.
        tip: String,
        /// How many.
        count: usize,
        /// Their names.
        joints: String,
    },
}

/// The arm a URDF describes between two links.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfArm {
    /// The robot's name in the file.
    pub robot_name: String,
    /// The chain.
    pub chain: Chain,
    /// Each joint's `[lower, upper]` (rad), `None` where the file gives none (a continuous joint, or no
    /// `<limit>`, or lower ≥ upper).
    pub position_limits: Vec<Option<[f64; 2]>>,
    /// Each joint's speed limit (rad/s), `None` where the file gives none (missing, zero or negative).
    pub velocity_limits: Vec<Option<f64>>,
}

/// Reads the arm between `base_link` and `tip_link` of the URDF at `path` (either link `None`: the tree's
/// root, and the one leaf below the base).
pub fn read(path: &Path, base_link: Option<&str>, tip_link: Option<&str>) -> Result<UrdfArm, UrdfError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| UrdfError::Read { path: path.display().to_string(), message: e.to_string() })?;
    parse(&text, &path.display().to_string(), base_link, tip_link)
}

/// The arm between `base_link` and `tip_link` of the URDF `text`, read from `path` (for messages).
pub fn parse(
    text: &str,
    path: &str,
    base_link: Option<&str>,
    tip_link: Option<&str>,
) -> Result<UrdfArm, UrdfError> {
    crate::urdf_bounds::check(text)
        .map_err(|bound| UrdfError::OutOfBounds { path: path.to_string(), bound })?;
    let robot = urdf_rs::read_from_string(text)
        .map_err(|e| UrdfError::Read { path: path.to_string(), message: e.to_string() })?;
    arm_from_robot(&robot, base_link, tip_link)
}

/// The arm between two links of a parsed URDF (see [`read`]).
pub fn arm_from_robot(
    robot: &urdf_rs::Robot,
    base_link: Option<&str>,
    tip_link: Option<&str>,
) -> Result<UrdfArm, UrdfError> {
    let tree = Tree::of(robot)?;
    let base = match base_link {
        Some(name) => tree.link(name)?.to_string(),
        None => tree.root()?,
    };
    let tip = match tip_link {
        Some(name) => tree.link(name)?.to_string(),
        None => tree.single_leaf_below(&base)?,
    };
    let path = tree.joints_between(&base, &tip)?;
    chain_along(robot, &path, base, tip)
}

/// The names, each once; `Err` naming the first given twice.
fn unique_names<'a>(
    what: &'static str,
    names: impl Iterator<Item = &'a str>,
) -> Result<std::collections::HashSet<&'a str>, UrdfError> {
    let mut seen = std::collections::HashSet::new();
    for name in names {
        if !seen.insert(name) {
            return Err(UrdfError::Duplicate { what, name: name.to_string() });
        }
    }
    Ok(seen)
}

/// The links and joints of a URDF, by name.
struct Tree<'a> {
    robot: &'a urdf_rs::Robot,
    /// The joint whose child each link is.
    parent_joint: HashMap<&'a str, usize>,
}

impl<'a> Tree<'a> {
    fn of(robot: &'a urdf_rs::Robot) -> Result<Self, UrdfError> {
        let links = unique_names("links", robot.links.iter().map(|l| l.name.as_str()))?;
        unique_names("joints", robot.joints.iter().map(|j| j.name.as_str()))?;
        for joint in &robot.joints {
            for link in [&joint.parent.link, &joint.child.link] {
                if !links.contains(link.as_str()) {
                    return Err(UrdfError::UndeclaredLink { joint: joint.name.clone(), link: link.clone() });
                }
            }
        }
        let mut parent_joint: HashMap<&str, usize> = HashMap::new();
        for (index, joint) in robot.joints.iter().enumerate() {
            if let Some(&first) = parent_joint.get(joint.child.link.as_str()) {
                return Err(UrdfError::TwoParents {
                    link: joint.child.link.clone(),
                    first: robot.joints[first].name.clone(),
                    second: joint.name.clone(),
                });
            }
            parent_joint.insert(joint.child.link.as_str(), index);
        }
        Ok(Self { robot, parent_joint })
    }

    fn link(&self, name: &str) -> Result<&'a str, UrdfError> {
        let found = self.robot.links.iter().find(|link| link.name == name);
        found.map(|link| link.name.as_str()).ok_or_else(|| UrdfError::NoSuchLink {
            link: name.to_string(),
            known: listed(self.robot.links.iter().map(|l| l.name.as_str())),
        })
    }

    fn root(&self) -> Result<String, UrdfError> {
        let roots: Vec<&str> = self
            .robot
            .links
            .iter()
            .map(|l| l.name.as_str())
            .filter(|name| !self.parent_joint.contains_key(name))
            .collect();
        match roots.as_slice() {
            [one] => Ok((*one).to_string()),
            _ => Err(UrdfError::SeveralRoots { roots: listed(roots.into_iter()) }),
        }
    }

    fn child_joints(&self, link: &str) -> Vec<&'a urdf_rs::Joint> {
        self.robot.joints.iter().filter(|j| j.parent.link == link).collect()
    }

    fn single_leaf_below(&self, base: &str) -> Result<String, UrdfError> {
        let mut link = base.to_string();
        loop {
            match self.child_joints(&link).as_slice() {
                [] => return Ok(link),
                [one] => link = one.child.link.clone(),
                several => {
                    return Err(UrdfError::Branches {
                        link,
                        children: several
                            .iter()
                            .map(|j| j.child.link.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                    });
                }
            }
        }
    }

    /// The joints from `base` down to `tip`, base first.
    fn joints_between(&self, base: &str, tip: &str) -> Result<Vec<usize>, UrdfError> {
        let mut path = Vec::new();
        let mut link = tip;
        while link != base {
            let Some(&joint) = self.parent_joint.get(link) else {
                return Err(UrdfError::TipNotBelowBase { base: base.to_string(), tip: tip.to_string() });
            };
            path.push(joint);
            link = self.robot.joints[joint].parent.link.as_str();
        }
        path.reverse();
        Ok(path)
    }
}

/// The chain along `path` (joint indices, base first): fixed joints folded into the next moving joint's
/// origin, or into the tool's after the last.
fn chain_along(
    robot: &urdf_rs::Robot,
    path: &[usize],
    base: String,
    tip: String,
) -> Result<UrdfArm, UrdfError> {
    let mut joints = Vec::new();
    let mut position_limits = Vec::new();
    let mut velocity_limits = Vec::new();
    let mut pending = Transform::identity();
    for &index in path {
        let joint = &robot.joints[index];
        finite(joint)?;
        let origin = pending * origin_of(&joint.origin);
        let bounded = match joint.joint_type {
            JointType::Fixed => {
                pending = origin;
                continue;
            }
            JointType::Revolute => true,
            JointType::Continuous => false,
            JointType::Prismatic => {
                return Err(unsupported(joint, "prismatic", "vservo drives revolute joints only"));
            }
            JointType::Floating => {
                return Err(unsupported(joint, "floating", "an arm's joints are revolute"));
            }
            JointType::Planar => return Err(unsupported(joint, "planar", "an arm's joints are revolute")),
            JointType::Spherical => {
                return Err(unsupported(joint, "spherical", "an arm's joints are revolute"));
            }
        };
        if joint.mimic.is_some() {
            return Err(unsupported(
                joint,
                "a mimic joint",
                "every joint of the chain must be driven on its own",
            ));
        }
        let axis = Vector3::from(joint.axis.xyz.0);
        let axis =
            Unit::try_new(axis, 1e-9).ok_or_else(|| UrdfError::ZeroAxis { joint: joint.name.clone() })?;
        joints.push(ChainJoint {
            name: joint.name.clone(),
            child_link: joint.child.link.clone(),
            parent_from_joint: origin,
            axis,
        });
        let limit = &joint.limit;
        let range =
            bounded && limit.lower.is_finite() && limit.upper.is_finite() && limit.lower < limit.upper;
        position_limits.push(range.then_some([limit.lower, limit.upper]));
        velocity_limits.push((limit.velocity.is_finite() && limit.velocity > 0.0).then_some(limit.velocity));
        pending = Transform::identity();
    }
    if !(MIN_CHAIN_JOINTS..=MAX_CHAIN_JOINTS).contains(&joints.len()) {
        return Err(UrdfError::JointCount {
            count: joints.len(),
            joints: joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", "),
            base,
            tip,
        });
    }
    Ok(UrdfArm {
        robot_name: robot.name.clone(),
        chain: Chain { base_link: base, tip_link: tip, joints, last_from_tip: pending },
        position_limits,
        velocity_limits,
    })
}

/// The joint's origin and axis are finite numbers, and so are its limits (infinite speed limits aside: those
/// are reported missing).
fn finite(joint: &urdf_rs::Joint) -> Result<(), UrdfError> {
    let not_finite = |what| UrdfError::NotFinite { joint: joint.name.clone(), what };
    let all = |values: &[f64]| values.iter().all(|v| v.is_finite());
    if !all(&joint.origin.xyz.0) || !all(&joint.origin.rpy.0) {
        return Err(not_finite("origin"));
    }
    if !all(&joint.axis.xyz.0) {
        return Err(not_finite("axis"));
    }
    if joint.limit.lower.is_nan() || joint.limit.upper.is_nan() || joint.limit.velocity.is_nan() {
        return Err(not_finite("limit"));
    }
    Ok(())
}

fn unsupported(joint: &urdf_rs::Joint, kind: &'static str, why: &'static str) -> UrdfError {
    UrdfError::Unsupported { joint: joint.name.clone(), kind, why }
}

/// A URDF `<origin xyz rpy>`: rpy are fixed-axis roll, pitch, yaw, R = Rz(yaw)·Ry(pitch)·Rx(roll).
fn origin_of(pose: &urdf_rs::Pose) -> Transform {
    let [x, y, z] = pose.xyz.0;
    let [roll, pitch, yaw] = pose.rpy.0;
    Transform::from_parts(Translation3::new(x, y, z), Rotation3::from_euler_angles(roll, pitch, yaw))
}

/// The most names an error lists: a file of thousands of links names the first few and how many more.
const NAMES_LISTED: usize = 12;

/// `names` comma-separated, the first [`NAMES_LISTED`] of them and a count of the rest.
fn listed<'n>(names: impl Iterator<Item = &'n str>) -> String {
    let names: Vec<&str> = names.collect();
    let shown = names[..names.len().min(NAMES_LISTED)].join(", ");
    match names.len().saturating_sub(NAMES_LISTED) {
        0 => shown,
        more => format!("{shown} and {more} more"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_error_lists_a_few_names_and_counts_the_rest() {
        assert_eq!(listed(["a", "b"].into_iter()), "a, b");
        let many: Vec<String> = (0..1000).map(|i| format!("l{i}")).collect();
        let text = listed(many.iter().map(String::as_str));
        assert!(text.starts_with("l0, l1, ") && text.ends_with("l11 and 988 more"), "{text}");
    }

    /// A six-joint arm in URDF, with a fixed flange and a branch (two fingers) after it.
    pub(crate) fn six_joint_urdf(joint_5_kind: &str, limit_5: &str) -> String {
        let mut joints = String::new();
        for j in 1..=6 {
            let (kind, limit) = if j == 5 {
                (joint_5_kind, limit_5)
            } else {
                ("revolute", r#"<limit lower="-2" upper="2" velocity="3" effort="10"/>"#)
            };
            joints += &format!(
                r#"<joint name="j{j}" type="{kind}"><parent link="l{p}"/><child link="l{j}"/>
                   <origin xyz="0 0 0.1" rpy="{rx} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>"#,
                p = j - 1,
                rx = if j % 2 == 0 { std::f64::consts::FRAC_PI_2 } else { 0.0 }
            );
        }
        let links: String = (0..=6).map(|l| format!(r#"<link name="l{l}"/>"#)).collect();
        format!(
            r#"<robot name="test">{links}<link name="flange"/><link name="f1"/><link name="f2"/>{joints}
               <joint name="flange_joint" type="fixed"><parent link="l6"/><child link="flange"/><origin xyz="0 0 0.05"/></joint>
               <joint name="finger1" type="prismatic"><parent link="flange"/><child link="f1"/><axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/></joint>
               <joint name="finger2" type="prismatic"><parent link="flange"/><child link="f2"/><axis xyz="0 -1 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/></joint>
               </robot>"#
        )
    }

    fn arm(text: &str, base: Option<&str>, tip: Option<&str>) -> Result<UrdfArm, UrdfError> {
        let robot = urdf_rs::read_from_string(text).expect("parses");
        arm_from_robot(&robot, base, tip)
    }

    const LIMIT: &str = r#"<limit lower="-2" upper="2" velocity="3" effort="10"/>"#;

    #[test]
    fn the_chain_to_the_flange_folds_the_fixed_joint_into_the_tool() {
        let arm = arm(&six_joint_urdf("revolute", LIMIT), None, Some("flange")).expect("an arm");
        assert_eq!(arm.chain.joint_count(), 6);
        assert_eq!(arm.chain.base_link, "l0");
        assert_eq!(arm.chain.joints[3].name, "j4");
        assert_eq!(arm.chain.joints[3].child_link, "l4", "the link the joint moves, as the URDF names it");
        assert_eq!(arm.chain.tip_link, "flange");
        assert_eq!(arm.chain.last_from_tip.translation.vector, Vector3::new(0.0, 0.0, 0.05));
        assert_eq!(arm.position_limits[0], Some([-2.0, 2.0]));
        assert_eq!(arm.velocity_limits[5], Some(3.0));
    }

    #[test]
    fn a_tree_that_branches_needs_the_tool_link_named() {
        let error = arm(&six_joint_urdf("revolute", LIMIT), None, None).expect_err("branches");
        assert!(matches!(&error, UrdfError::Branches { link, .. } if link == "flange"), "{error}");
        assert!(error.to_string().contains("robot.arm.tip_link"));
    }

    #[test]
    fn a_prismatic_joint_on_the_chain_is_refused_by_name() {
        let error = arm(&six_joint_urdf("revolute", LIMIT), None, Some("f1")).expect_err("prismatic");
        assert!(
            matches!(&error, UrdfError::Unsupported { joint, kind: "prismatic", .. } if joint == "finger1")
        );
        let error = arm(&six_joint_urdf("prismatic", LIMIT), None, Some("flange")).expect_err("prismatic");
        assert!(error.to_string().contains("\"j5\" is prismatic"), "{error}");
    }

    #[test]
    fn a_continuous_joint_or_a_missing_limit_leaves_the_limits_to_give() {
        let arm1 = arm(&six_joint_urdf("continuous", ""), None, Some("flange")).expect("an arm");
        assert_eq!(arm1.position_limits[4], None);
        assert_eq!(arm1.velocity_limits[4], None);
        let arm2 = arm(&six_joint_urdf("revolute", ""), None, Some("flange")).expect("an arm");
        assert_eq!(arm2.position_limits[4], None);
    }

    #[test]
    fn too_few_joints_wrong_links_and_a_tip_above_the_base_are_refused() {
        let text = six_joint_urdf("revolute", LIMIT);
        let error = arm(&text, None, Some("l5")).expect_err("five joints");
        assert!(matches!(error, UrdfError::JointCount { count: 5, .. }), "{error}");
        let error = arm(&text, Some("nowhere"), Some("l6")).expect_err("no such link");
        assert!(error.to_string().contains("\"nowhere\""), "{error}");
        let error = arm(&text, Some("l3"), Some("l1")).expect_err("above");
        assert!(matches!(error, UrdfError::TipNotBelowBase { .. }), "{error}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 256, ..Default::default() })]

        /// Any damage to a file gives an arm or a refusal, never a panic.
        #[test]
        fn a_damaged_file_is_refused_or_read_never_a_panic(
            at in 0usize..2000, length in 0usize..40, with in "[ -~]{0,12}",
        ) {
            let text = six_joint_urdf("revolute", LIMIT);
            let at = at.min(text.len());
            let end = (at + length).min(text.len());
            let damaged = format!("{}{with}{}", &text[..at], &text[end..]);
            let _ = parse(&damaged, "damaged.urdf", None, Some("flange"));
        }
    }

    #[test]
    fn numbers_that_are_not_finite_are_refused_by_joint() {
        let cases = [
            (r#"<origin xyz="0 0 0.1""#, r#"<origin xyz="0 nan 0.1""#, "origin"),
            (r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="0 inf 1"/>"#, "axis"),
            (r#"lower="-2""#, r#"lower="NaN""#, "limit"),
        ];
        for (from, to, what) in cases {
            let text = six_joint_urdf("revolute", LIMIT).replacen(from, to, 1);
            let error = arm(&text, None, Some("flange")).expect_err(what);
            assert_eq!(error, UrdfError::NotFinite { joint: "j1".into(), what }, "{what}");
        }
    }

    #[test]
    fn a_zero_axis_and_two_parents_are_refused() {
        let text =
            six_joint_urdf("revolute", LIMIT).replacen(r#"<axis xyz="0 0 1"/>"#, r#"<axis xyz="0 0 0"/>"#, 1);
        let error = arm(&text, None, Some("flange")).expect_err("zero axis");
        assert_eq!(error, UrdfError::ZeroAxis { joint: "j1".into() });
        let text =
            six_joint_urdf("revolute", LIMIT).replace(r#"<child link="f2"/>"#, r#"<child link="f1"/>"#);
        let error = arm(&text, None, Some("flange")).expect_err("two parents");
        assert!(matches!(error, UrdfError::TwoParents { .. }), "{error}");
    }

    /// The security review's files: a link never declared, a link or a joint declared twice.
    #[test]
    fn undeclared_links_and_duplicate_links_or_joints_are_refused_by_name() {
        let urdf = six_joint_urdf("revolute", LIMIT);
        let undeclared = urdf.replace(r#"<child link="f2"/>"#, r#"<child link="ghost"/>"#);
        let error = arm(&undeclared, None, Some("flange")).expect_err("undeclared");
        assert_eq!(error, UrdfError::UndeclaredLink { joint: "finger2".into(), link: "ghost".into() });
        let twice = urdf.replace(r#"<link name="f2"/>"#, r#"<link name="f2"/><link name="f1"/>"#);
        let error = arm(&twice, None, Some("flange")).expect_err("a link twice");
        assert_eq!(error, UrdfError::Duplicate { what: "links", name: "f1".into() });
        let twice = urdf.replace(r#"<joint name="finger2""#, r#"<joint name="finger1""#);
        let error = arm(&twice, None, Some("flange")).expect_err("a joint twice");
        assert_eq!(error, UrdfError::Duplicate { what: "joints", name: "finger1".into() });
    }
}
