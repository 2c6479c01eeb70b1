//! `[ros2.qos.<topic>]`: a topic's reliability, durability and depth written in place of the bridge's default;
//! a topic not written keeps the default; an unknown topic, reliability or depth out of range is refused naming
//! it.

use vservo_config::{Config, ConfigError, QosDurability, QosReliability, Ros2Topic, TopicQos};

const DEFAULT: &str = include_str!("../../../config/vservo.toml");

fn with_qos(text: &str) -> Result<Config, ConfigError> {
    Config::from_toml(&format!("{DEFAULT}\n{text}\n"), "t.toml")
}

#[test]
fn a_topics_qos_is_taken_as_written_and_the_others_keep_the_default() {
    let config = with_qos(
        "[ros2.qos.image]\nreliability = \"best_effort\"\ndepth = 1\n\
         [ros2.qos.joint_states]\ndurability = \"transient_local\"\n",
    )
    .expect("valid");
    assert_eq!(
        config.ros2.qos_of(Ros2Topic::Image),
        TopicQos { reliability: Some(QosReliability::BestEffort), durability: None, depth: Some(1) }
    );
    assert_eq!(config.ros2.qos_of(Ros2Topic::JointStates).durability, Some(QosDurability::TransientLocal));
    assert_eq!(config.ros2.qos_of(Ros2Topic::Tf), TopicQos::default());
    assert_eq!(Config::from_toml(DEFAULT, "t.toml").expect("valid").ros2.qos, []);
}

#[test]
fn an_unknown_topic_a_bad_reliability_and_a_depth_out_of_range_are_refused_naming_them() {
    let unknown = with_qos("[ros2.qos.imagee]\ndepth = 1\n").expect_err("refused").to_string();
    assert!(unknown.contains("imagee") && unknown.contains("image"), "{unknown}");
    let reliability =
        with_qos("[ros2.qos.image]\nreliability = \"sometimes\"\n").expect_err("refused").to_string();
    assert!(reliability.contains("sometimes") && reliability.contains("best_effort"), "{reliability}");
    let depth = with_qos("[ros2.qos.tf]\ndepth = 0\n").expect_err("refused").to_string();
    assert!(depth.contains("ros2.qos.tf.depth") && depth.contains("1 to 1000"), "{depth}");
    let key = with_qos("[ros2.qos.tf]\nhistory = 3\n").expect_err("refused").to_string();
    assert!(key.contains("history"), "{key}");
}
