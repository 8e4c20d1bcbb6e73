//! Bus load: the worst-case CAN load of the machine configuration's bus schedule (the
//! `hob bus-load` figures), as JSON.

use hob_process_image::plan::BusPlan;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficRow {
    pub name: String,
    pub bytes: usize,
    pub per_cycle: f64,
    pub bits_per_cycle: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BusLoadBench {
    pub bitrate_bit_s: u32,
    pub cycle_us: f64,
    pub bits_per_cycle: f64,
    pub capacity_bits: f64,
    pub load_percent: f64,
    pub limit_percent: f64,
    pub traffic: Vec<TrafficRow>,
}

pub fn run(machine: &Path, out: &Path) -> Result<BusLoadBench, String> {
    let m = hob_store::files::load_machine(machine).map_err(|e| e.to_string())?;
    let plan = BusPlan::from_machine(&m);
    let load = plan.load();
    let r = BusLoadBench {
        bitrate_bit_s: plan.bitrate_bit_s,
        cycle_us: plan.cycle_s * 1e6,
        bits_per_cycle: load.bits_per_cycle,
        capacity_bits: load.capacity_bits,
        load_percent: load.load * 100.0,
        limit_percent: plan.bus_load_limit * 100.0,
        traffic: load
            .traffic
            .iter()
            .map(|t| TrafficRow {
                name: t.name.clone(),
                bytes: t.bytes,
                per_cycle: t.per_cycle,
                bits_per_cycle: t.bits_per_cycle(),
            })
            .collect(),
    };
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    crate::write_json(&out.join("busload.json"), &r)?;
    Ok(r)
}

pub fn text(r: &BusLoadBench) -> String {
    format!(
        "bus load: {:.1} of {:.0} bits per {:.0} us cycle at {} bit/s: {:.1} % (limit {:.0} %), {} kinds of frame\n",
        r.bits_per_cycle,
        r.capacity_bits,
        r.cycle_us,
        r.bitrate_bit_s,
        r.load_percent,
        r.limit_percent,
        r.traffic.len()
    )
}
