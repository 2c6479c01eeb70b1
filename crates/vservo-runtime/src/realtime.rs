//! Real-time setup of a node process: SCHED_FIFO priority, CPU affinity, locked memory, timer slack.
//! What the system does not permit is reported back as a warning; the node runs on without it.

use nix::sched::{CpuSet, sched_setaffinity};
use nix::sys::mman::{MlockAllFlags, mlockall};
use nix::unistd::Pid;
use thread_priority::{
    RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue, ThreadSchedulePolicy,
    set_thread_priority_and_policy, thread_native_id,
};
use vservo_config::{NodeRealtime, Runtime};

/// Applies a node's real-time settings to the calling thread (and, for memory, the process). Returns one
/// message per setting that could not be applied.
pub fn apply(node: &NodeRealtime, runtime: &Runtime) -> Vec<String> {
    let mut warnings = Vec::new();
    if runtime.lock_memory
        && let Err(e) = mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE)
    {
        warnings.push(format!(
            "runtime.lock_memory: mlockall failed ({e}); pages may fault on the real-time path (raise RLIMIT_MEMLOCK, e.g. LimitMEMLOCK=infinity)"
        ));
    }
    if let Err(e) = nix::sys::prctl::set_timerslack(runtime.timer_slack_ns) {
        warnings.push(format!("runtime.timer_slack_ns: prctl(PR_SET_TIMERSLACK) failed ({e})"));
    }
    if !node.cpus.is_empty() {
        let mut set = CpuSet::new();
        let mut bad = Vec::new();
        for &cpu in &node.cpus {
            if set.set(cpu).is_err() {
                bad.push(cpu);
            }
        }
        if !bad.is_empty() {
            warnings.push(format!("cpus {bad:?}: beyond what a CPU set can hold; ignored"));
        }
        if let Err(e) = sched_setaffinity(Pid::from_raw(0), &set) {
            warnings
                .push(format!("cpus {:?}: sched_setaffinity failed ({e}); running on any CPU", node.cpus));
        }
    }
    if node.fifo_priority > 0 {
        // for the real-time policies the cross-platform value is the POSIX priority itself
        let result =
            ThreadPriorityValue::try_from(node.fifo_priority).map_err(|e| e.to_string()).and_then(|value| {
                let policy = ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo);
                set_thread_priority_and_policy(
                    thread_native_id(),
                    ThreadPriority::Crossplatform(value),
                    policy,
                )
                .map_err(|e| format!("{e:?}"))
            });
        if let Err(e) = result {
            warnings.push(format!(
                "fifo_priority {}: SCHED_FIFO not permitted ({e}); running on the normal scheduler (needs CAP_SYS_NICE or an rtprio limit)",
                node.fifo_priority
            ));
        }
    }
    warnings
}
