//! What machine a result was measured on (every result file carries it).

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SystemInfo {
    pub kernel: String,
    pub preempt_rt: bool,
    pub cpus: usize,
    pub cpu_model: String,
    /// The CPU reports a hypervisor (a virtual machine: stalls of milliseconds happen).
    pub virtual_machine: bool,
}

pub fn probe() -> SystemInfo {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        cpuinfo
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
            .unwrap_or_default()
    };
    SystemInfo {
        kernel: std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| s.trim().to_string())
            .unwrap_or_default(),
        preempt_rt: hob_rt_os::kernel_is_preempt_rt(),
        cpus: std::thread::available_parallelism().map_or(1, usize::from),
        cpu_model: field("model name"),
        virtual_machine: field("flags").split_whitespace().any(|f| f == "hypervisor"),
    }
}
