//! `vservoctl top` in a real terminal (a tmux pane): it shows the nodes, refreshes, and `q` quits with exit 0.

use std::process::Command;
use std::time::Duration;

use vservo_system_tests::{TmuxSession as Session, binary, running_daemon, unique, wait_until};

/// The refresh counter `top` prints on its last line.
fn refreshes(screen: &str) -> Option<u64> {
    screen.split("refresh ").nth(1)?.split_whitespace().next()?.parse().ok()
}

#[test]
fn top_shows_the_nodes_refreshes_and_quits_on_q() {
    let instance = unique("top");
    let (_config, daemon) = running_daemon(&instance);
    let session = Session(instance.clone());
    let command =
        format!("{} top --instance {instance}; echo top-exit=$?; sleep 60", binary("vservoctl").display());
    let started = Command::new("tmux")
        .args(["new-session", "-d", "-s", &session.0, "-x", "150", "-y", "40", &command])
        .status()
        .expect("tmux runs");
    assert!(started.success());
    assert!(
        wait_until(Duration::from_secs(10), || {
            let screen = session.capture();
            ["plant", "rmrc", "servo", "vision", "running", "feature error"]
                .iter()
                .all(|w| screen.contains(w))
        }),
        "{}",
        session.capture()
    );
    let first = refreshes(&session.capture()).expect("a refresh count");
    std::thread::sleep(Duration::from_secs(1));
    let later = refreshes(&session.capture()).expect("a refresh count");
    println!("top refreshed {} times in 1 s", later - first);
    assert!(later >= first + 3, "several refreshes a second: {first} → {later}");
    let sent = Command::new("tmux").args(["send-keys", "-t", &session.0, "q"]).status().expect("tmux runs");
    assert!(sent.success());
    assert!(
        wait_until(Duration::from_secs(5), || session.capture().contains("top-exit=0")),
        "{}",
        session.capture()
    );
    daemon.stop();
}
