//! `[ros2]`: the ROS 2 bridge's domain, namespace, interface and topics.

use super::checker::Checker;
use crate::raw::RawRos2;
use crate::{ConfigError, Ros2};

/// The highest ROS_DOMAIN_ID: DDS's port formula (7400 + 250 · domain + …) leaves no valid port above it.
pub const MAX_DOMAIN_ID: u16 = 232;

/// The most frames `image_every` may skip.
const MAX_IMAGE_EVERY: u32 = 1000;

/// The bridge's settings, each value in range.
pub fn ros2(check: &Checker, r: &RawRos2, joint_count: usize) -> Result<Ros2, ConfigError> {
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
    })
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
        ros2(&Checker { file: "test.toml" }, r, 6)
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
