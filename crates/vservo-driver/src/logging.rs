//! Logging of the instance's driver and helper processes (the camera driver, the ROS 2 bridge and driver, the
//! Franka driver): to stderr,
//! filtered by `VSERVO_LOG` (tracing's filter syntax) or else `default_filter`, in colour on a terminal only.

/// A process's exit code from how its work ended: 0, or 1 with the error (and its causes) logged.
pub fn exit_code<E: std::fmt::Display>(result: Result<(), E>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            tracing::error!("{error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Sets up the process's logging; call once, first.
pub fn to_stderr(default_filter: &str) {
    use std::io::IsTerminal;
    let filter = tracing_subscriber::EnvFilter::try_from_env("VSERVO_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
}
