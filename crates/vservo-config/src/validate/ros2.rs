//! `[ros2]`: the ROS 2 bridge's domain, namespace, interface and topics.

use super::checker::Checker;
use crate::raw::{RawRos2, RawRos2Driver};
use crate::{ConfigError, Ros2, Ros2Driver, Ros2Topic, TopicQos};

/// The highest ROS_DOMAIN_ID: DDS's port formula (7400 + 250 · domain + …) leaves no valid port above it.
pub const MAX_DOMAIN_ID: u16 = 232;

/// The most frames `image_every` may skip.
const MAX_IMAGE_EVERY: u32 = 1000;

/// What vservo takes from the ROS 2 graph: the arm (`[robot] driver = "ros2"`), the camera (`[camera] source =
/// "ros2"`).
#[derive(Debug, Clone, Copy, Default)]
pub struct FromRos2 {
    /// The arm.
    pub arm: bool,
    /// The camera.
    pub camera: bool,
}

/// The bridge's and the driver's settings, each value in range.
pub fn ros2(check: &Checker, r: &RawRos2, joint_count: usize, from: FromRos2) -> Result<Ros2, ConfigError> {
    let domain_id = check.whole(
        "ros2.domain_id",
        r.domain_id,
        0u16,
        MAX_DOMAIN_ID,
        &format!("must be a ROS domain id from 0 to {MAX_DOMAIN_ID}"),
    )?;
    if let Err(reason) = namespace_ok(&r.namespace) {
        return Err(check.invalid("ros2.namespace", format!("{:?}", r.namespace), reason));
    }
    let interface = interface(check, &r.interface)?;
    for (i, topic) in r.publish.iter().enumerate() {
        if r.publish[..i].contains(topic) {
            return Err(check.invalid("ros2.publish", format!("{topic:?}"), "is named twice"));
        }
    }
    let image_every = check.whole(
        "ros2.image_every",
        r.image_every,
        1u32,
        MAX_IMAGE_EVERY,
        &format!("must be from 1 (every frame) to {MAX_IMAGE_EVERY}"),
    )?;
    let joint_state_rate_hz =
        check.within("ros2.joint_state_rate_hz", r.joint_state_rate_hz, 0.1, 1000.0, "Hz")?;
    if !r.joint_names.is_empty() && r.joint_names.len() != joint_count {
        return Err(check.invalid(
            "ros2.joint_names",
            format!("{:?}", r.joint_names),
            format!("must name the arm's {joint_count} joints, from the base outwards (or be left out)"),
        ));
    }
    for (i, name) in r.joint_names.iter().enumerate() {
        if !ros_token_ok(name) || r.joint_names[..i].contains(name) {
            return Err(check.invalid(
                "ros2.joint_names",
                format!("{name:?}"),
                "each must be a distinct name of letters, digits and '_' that does not start with a digit",
            ));
        }
    }
    let driver = driver(check, &r.driver, &r.namespace)?;
    bridge_apart_from_driver(check, r, &driver, from)?;
    let qos = qos(check, r)?;
    Ok(Ros2 {
        enabled: r.enabled,
        domain_id,
        namespace: r.namespace.clone(),
        interface,
        publish: r.publish.clone(),
        image_every,
        joint_state_rate_hz,
        joint_names: r.joint_names.clone(),
        allow_motion: r.allow_motion,
        driver,
        qos,
    })
}

/// The most samples a topic's history keeps.
const MAX_QOS_DEPTH: u32 = 1000;

/// `[ros2.qos.<topic>]`: each topic's depth in range.
fn qos(check: &Checker, r: &RawRos2) -> Result<Vec<(Ros2Topic, TopicQos)>, ConfigError> {
    r.qos
        .iter()
        .map(|(&topic, written)| {
            let depth = written
                .depth
                .map(|depth| {
                    check.whole(
                        &format!("ros2.qos.{}.depth", topic.name()),
                        depth,
                        1u32,
                        MAX_QOS_DEPTH,
                        &format!("must keep from 1 to {MAX_QOS_DEPTH} samples"),
                    )
                })
                .transpose()?;
            Ok((topic, TopicQos { reliability: written.reliability, durability: written.durability, depth }))
        })
        .collect()
}

/// `[ros2.driver]`: its topics as absolute names, its hold and clock tolerance in range.
fn driver(check: &Checker, d: &RawRos2Driver, namespace: &str) -> Result<Ros2Driver, ConfigError> {
    let topic = |key: &str, name: &str| {
        topic_ok(name)
            .map(|()| resolved(namespace, name))
            .map_err(|reason| check.invalid(key, format!("{name:?}"), reason))
    };
    Ok(Ros2Driver {
        joint_states_topic: topic("ros2.driver.joint_states_topic", &d.joint_states_topic)?,
        command_topic: topic("ros2.driver.command_topic", &d.command_topic)?,
        image_topic: topic("ros2.driver.image_topic", &d.image_topic)?,
        hold_after_s: check.within("ros2.driver.hold_after_s", d.hold_after_s, 0.001, 1.0, "s")?,
        clock_tolerance_s: check.within(
            "ros2.driver.clock_tolerance_s",
            d.clock_tolerance_s,
            0.001,
            10.0,
            "s",
        )?,
    })
}

/// The bridge does not publish on a topic the driver reads: it would feed the arm's joint states (or the
/// camera's images) back to where they come from.
fn bridge_apart_from_driver(
    check: &Checker,
    r: &RawRos2,
    driver: &Ros2Driver,
    from: FromRos2,
) -> Result<(), ConfigError> {
    let bridge_topic = |topic: Ros2Topic, relative: &str| {
        (r.enabled && r.publish.contains(&topic)).then(|| resolved(&r.namespace, relative))
    };
    let clashes = [
        (
            from.arm,
            bridge_topic(Ros2Topic::JointStates, "joint_states"),
            &driver.joint_states_topic,
            "joint_states",
        ),
        (from.camera, bridge_topic(Ros2Topic::Image, "camera/image_raw"), &driver.image_topic, "image"),
    ];
    for (read, published, topic, name) in clashes {
        if read && published.as_ref() == Some(topic) {
            return Err(check.invalid(
                "ros2.publish",
                format!("{name:?}"),
                format!(
                    "the bridge would publish on {topic}, the topic the ROS 2 driver reads: leave {name:?} out of \
                     ros2.publish (the arm's own driver publishes it already)"
                ),
            ));
        }
    }
    Ok(())
}

/// A topic name as ROS takes one: absolute (`/a/b`) or relative (`a/b`), names of letters, digits and `_`.
fn topic_ok(name: &str) -> Result<(), &'static str> {
    let relative = name.strip_prefix('/').unwrap_or(name);
    if relative.split('/').all(ros_token_ok) {
        Ok(())
    } else {
        Err(
            "must be a ROS topic name: names of letters, digits and '_' (not starting with a digit) joined by \
             single '/', absolute (\"/joint_states\") or relative to ros2.namespace",
        )
    }
}

/// A topic name made absolute in `namespace`.
fn resolved(namespace: &str, name: &str) -> String {
    if name.starts_with('/') { name.to_string() } else { format!("{namespace}/{name}") }
}

/// The interface by its address: empty for every interface.
fn interface(check: &Checker, text: &str) -> Result<Option<std::net::IpAddr>, ConfigError> {
    if text.is_empty() {
        return Ok(None);
    }
    match text.parse::<std::net::IpAddr>() {
        Ok(address) if !address.is_unspecified() && !address.is_multicast() => Ok(Some(address)),
        _ => Err(check.invalid(
            "ros2.interface",
            format!("{text:?}"),
            "must be the IP address of one of this machine's interfaces (127.0.0.1: this machine only), or \
             empty for every interface",
        )),
    }
}

/// A ROS namespace as `rcl` accepts it: empty, or `/` then names of letters, digits and `_` that do not start
/// with a digit, joined by single `/`, with none at the end.
pub fn namespace_ok(namespace: &str) -> Result<(), &'static str> {
    if namespace.is_empty() {
        return Ok(());
    }
    let Some(rest) = namespace.strip_prefix('/') else {
        return Err("must be empty or start with '/' (e.g. \"/cell1\")");
    };
    if rest.split('/').all(ros_token_ok) {
        Ok(())
    } else {
        Err(
            "must be names of letters, digits and '_' (not starting with a digit) joined by single '/', with no '/' at the end",
        )
    }
}

/// A name as ROS takes one: letters, digits and `_`, not starting with a digit.
fn ros_token_ok(token: &str) -> bool {
    token.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn namespaces_as_rcl_takes_them() {
        for good in ["", "/cell1", "/lab/cell_2", "/_x"] {
            assert!(namespace_ok(good).is_ok(), "{good}");
        }
        for bad in ["cell", "/", "/cell/", "//cell", "/1cell", "/ce-ll", "/cell//x", "/cèll"] {
            assert!(namespace_ok(bad).is_err(), "{bad}");
        }
    }

    fn raw() -> RawRos2 {
        RawRos2::default()
    }

    fn checked(r: &RawRos2) -> Result<Ros2, ConfigError> {
        ros2(&Checker { file: "test.toml" }, r, 6, FromRos2::default())
    }

    #[test]
    fn driver_topics_resolve_in_the_namespace() {
        let mut r = raw();
        r.namespace = "/cell1".into();
        r.driver.joint_states_topic = "arm/joint_states".into();
        let settings = checked(&r).expect("a relative and an absolute topic");
        assert_eq!(settings.driver.joint_states_topic, "/cell1/arm/joint_states");
        assert_eq!(settings.driver.command_topic, "/forward_velocity_controller/commands");
        for bad in ["", "/", "joint states", "/a//b", "a/", "~/x"] {
            r.driver.joint_states_topic = bad.into();
            let error = checked(&r).expect_err(bad).to_string();
            assert!(error.contains("ros2.driver.joint_states_topic"), "{error}");
        }
    }

    #[test]
    fn the_bridge_does_not_publish_what_the_driver_reads() {
        let mut r = raw();
        r.enabled = true;
        let arm = FromRos2 { arm: true, camera: false };
        let error = ros2(&Checker { file: "test.toml" }, &r, 6, arm).expect_err("a clash").to_string();
        assert!(error.contains("ros2.publish") && error.contains("/joint_states"), "{error}");
        r.namespace = "/vservo_cell".into();
        assert!(ros2(&Checker { file: "test.toml" }, &r, 6, arm).is_ok(), "apart in a namespace");
        r.namespace.clear();
        r.publish.retain(|t| *t != Ros2Topic::JointStates);
        assert!(ros2(&Checker { file: "test.toml" }, &r, 6, arm).is_ok(), "joint_states left out");
        let camera = FromRos2 { arm: false, camera: true };
        let error =
            ros2(&Checker { file: "test.toml" }, &r, 6, camera).expect_err("an image clash").to_string();
        assert!(error.contains("/camera/image_raw"), "{error}");
    }

    #[test]
    fn defaults_publish_everything_and_move_nothing() {
        let settings = checked(&raw()).expect("the defaults");
        assert!(!settings.enabled && !settings.allow_motion);
        assert_eq!(settings.publish, crate::Ros2Topic::ALL.to_vec());
        assert_eq!((settings.domain_id, settings.interface, settings.image_every), (0, None, 1));
    }

    #[test]
    fn refusals_name_the_key() {
        type Edit = fn(&mut RawRos2);
        let cases: [(Edit, &str); 11] = [
            (|r| r.joint_names = vec!["a".into()], "ros2.joint_names"),
            (|r| r.joint_state_rate_hz = 0.0, "ros2.joint_state_rate_hz"),
            (
                |r| r.joint_names = ["a", "a", "b", "c", "d", "e"].map(String::from).to_vec(),
                "ros2.joint_names",
            ),
            (
                |r| r.joint_names = ["shoulder pan", "b", "c", "d", "e", "f"].map(String::from).to_vec(),
                "ros2.joint_names",
            ),
            (|r| r.domain_id = 233, "ros2.domain_id"),
            (|r| r.domain_id = -1, "ros2.domain_id"),
            (|r| r.namespace = "cell".into(), "ros2.namespace"),
            (|r| r.interface = "0.0.0.0".into(), "ros2.interface"),
            (|r| r.interface = "eth0".into(), "ros2.interface"),
            (|r| r.publish = vec![crate::Ros2Topic::Tf, crate::Ros2Topic::Tf], "ros2.publish"),
            (|r| r.image_every = 0, "ros2.image_every"),
        ];
        for (edit, key) in cases {
            let mut r = raw();
            edit(&mut r);
            let error = checked(&r).expect_err(key).to_string();
            assert!(error.contains(key), "{error}");
        }
        let mut r = raw();
        r.interface = "127.0.0.1".into();
        r.joint_names = ["a", "b", "c", "d", "e", "f"].map(String::from).to_vec();
        let settings = checked(&r).expect("a loopback interface and six names");
        assert_eq!(settings.interface, Some(std::net::IpAddr::from([127, 0, 0, 1])));
        assert_eq!(settings.joint_names.len(), 6);
    }
}
